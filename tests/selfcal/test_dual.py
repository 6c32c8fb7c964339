"""Two encoders on one joint calibrate each other (issue 31): truth from the simulator, the CLI, refusals."""

import json

import numpy as np
import pytest

from encal.cli import main
from encal._core.errors import InputError
from encal.selfcal.dual import confounded_pairs, dual, simulate_dual


def separable_rms(series, truth, side, confounded):
    """``(miss, truth)``: the RMS over the turn of the recovered series' miss of ``truth`` and of ``truth`` itself
    (arcmin), on the orders of ``series`` that no confounded pair holds on this ``side`` (0 motor, 1 output)."""
    grid = np.arange(4096) * 360.0 / 4096
    spectrum = np.fft.rfft(truth(grid)) / 4096 * 2.0
    true_cos, true_sin = spectrum.real[series.orders], -spectrum.imag[series.orders]
    keep = np.array([k not in {pair[side] for pair in confounded} for k in series.orders])
    miss = np.sum((series.cos_arcmin - true_cos)[keep] ** 2 + (series.sin_arcmin - true_sin)[keep] ** 2)
    return float(np.sqrt(miss / 2)), float(np.sqrt(np.sum(true_cos[keep] ** 2 + true_sin[keep] ** 2) / 2))


def relative_error(series, truth, side, confounded):
    miss, whole = separable_rms(series, truth, side, confounded)
    return miss / whole


@pytest.mark.parametrize("ratio", [6.0, 7.5, -9.0])
def test_both_profiles_recovered_within_10_percent_on_the_separable_orders(ratio):
    motor, output, truth = simulate_dual(ratio, seed=1, output_turns=2.0)
    result = dual(motor, output, ratio, pinion_teeth=12)
    assert relative_error(result.motor.series, truth["motor_at_reading"], 0, result.confounded) < 0.10
    assert relative_error(result.output.series, truth["output_at_reading"], 1, result.confounded) < 0.10
    assert result.ratio_estimated == pytest.approx(ratio, rel=1e-5)
    assert result.motor.removed_orders == (12, 24)


def test_the_confounded_orders_are_named():
    assert confounded_pairs(6.0, range(1, 31), range(1, 31), 3.0) == [(1, 6), (2, 12), (3, 18), (4, 24), (5, 30)]
    assert confounded_pairs(7.5, range(1, 31), range(1, 31), 3.0) == [(2, 15), (4, 30)]
    motor, output, _ = simulate_dual(6.0, seed=2, output_turns=1.5)
    result = dual(motor, output, 6.0)
    assert result.confounded == [(1, 6), (2, 12), (3, 18), (4, 24), (5, 30)]
    assert "motor 1 / output 6" in result.summary()


def test_the_uncertainty_of_a_confounded_order_is_large():
    motor, output, _ = simulate_dual(6.0, seed=3, output_turns=2.0)
    result = dual(motor, output, 6.0)
    sigma = np.sqrt(np.diag(result.motor.series.covariance))
    orders = result.motor.series.orders
    assert sigma[list(orders).index(1)] > 10 * sigma[list(orders).index(7)]


def test_refusals_are_one_sentence():
    motor, output, _ = simulate_dual(6.0, seed=4, output_turns=2.0)
    with pytest.raises(InputError, match="expected --ratio 6"):
        dual(motor, output, -6.0)
    with pytest.raises(InputError, match="expected at least one full turn"):
        dual(motor[:2000], output[:2000], 6.0)
    with pytest.raises(InputError, match="not 0"):
        dual(motor, output, 0.0)


@pytest.mark.parametrize("ratio", [1.0, -1.0])
def test_a_ratio_of_one_is_refused_as_it_cannot_tell_the_two_encoders_apart(ratio):
    # arc8: both shafts at one speed, every order meets its namesake; fitted anyway, the motor profile came out
    # 0.03 arcmin RMS (truth 12) with a +-2 sigma of 0.5 arcmin at order 1, and exit 0.
    motor, output, _ = simulate_dual(ratio, seed=3, output_turns=1.5, samples_per_motor_turn=120)
    with pytest.raises(InputError, match="every motor order up to 30 meets an order of the other shaft"):
        dual(motor, output, ratio)


def test_the_band_of_a_confounded_pair_covers_the_split_the_prior_got_wrong():
    # arc8: ratio 2, the fast (motor) shaft's error the smaller: every motor order meets output order 2j and the
    # prior gave the pairs to the output; the motor profile was 4.0 arcmin RMS off (of 4) with its +-2 sigma band
    # covering 4 % of a 2-degree grid, the output's 6 %.
    motor, output, truth = simulate_dual(2.0, seed=3, output_turns=2.0, samples_per_motor_turn=240,
                                         motor_rms_arcmin=4.0, output_rms_arcmin=12.0)
    result = dual(motor, output, 2.0, pinion_teeth=12)
    grid = np.arange(0.0, 360.0, 2.0)
    for shaft in ("motor", "output"):
        got, want = getattr(result, shaft).error_arcmin(grid), truth[f"{shaft}_at_reading"](grid)
        miss = (got - got.mean()) - (want - want.mean())
        assert np.mean(np.abs(miss) <= 2.0 * getattr(result, shaft).sigma_arcmin(grid)) > 0.9, shaft


@pytest.mark.parametrize("which", ["both", "motor", "output"])
def test_counts_given_as_degrees_are_refused(which):
    # arc8: 16-bit counts in both columns wrap at 65536, 182 turns and 16 "degrees": each wrap's step was a
    # plausible 75 degrees, and the fit exited 0 with 273 output turns and a motor profile of 0 arcmin.
    motor, output, _ = simulate_dual(6.0, seed=3, samples_per_motor_turn=2880, output_turns=1.5)
    counts = {name: np.round(angle * 2**16 / 360.0) % 2**16 for name, angle in (("motor", motor), ("output", output))}
    motor = counts["motor"] if which in ("both", "motor") else motor
    output = counts["output"] if which in ("both", "output") else output
    with pytest.raises(InputError, match=r"expected degrees, wrapped within one turn|expected them to agree"):
        dual(motor, output, 6.0)
    unwrapped = np.rad2deg(np.unwrap(np.deg2rad(simulate_dual(6.0, seed=3)[0])))
    assert np.ptp(unwrapped) > 360.0 and dual(unwrapped, simulate_dual(6.0, seed=3)[1], 6.0).ratio == 6.0


def test_cli_dual_writes_both_calibrations(tmp_path, capsys):
    motor, output, _ = simulate_dual(6.0, seed=5, output_turns=1.5, samples_per_motor_turn=360)
    log = tmp_path / "joint.csv"
    log.write_text("motor_deg,output_deg\n" + "".join(f"{m:.9f},{o:.9f}\n" for m, o in zip(motor, output)))
    args = ["selfcal", "dual", str(log), "--ratio", "6", "--motor-cal", str(tmp_path / "m.csv"),
            "--output-cal", str(tmp_path / "o.csv"), "--pinion-teeth", "12", "--json"]
    assert main(args) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["confounded"][0] == {"motor_order": 1, "output_order": 6}
    assert summary["motor_removed_orders"] == [12, 24]
    assert main(["fit", str(tmp_path / "o.csv"), "-o", str(tmp_path / "o.json")]) == 0
    bad = tmp_path / "bad.csv"
    bad.write_text("motor_deg,angle\n1,2\n")
    capsys.readouterr()
    assert main(["selfcal", "dual", str(bad), "--ratio", "6", "--motor-cal", str(tmp_path / "m2.csv"),
                 "--output-cal", str(tmp_path / "o2.csv")]) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "output_deg" in err
