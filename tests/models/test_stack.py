"""The stacked model (encal.models.stack): a weighted mean of member models, and every way it is deployed."""

import json
import shutil
import subprocess

import numpy as np
import pytest

import encal
from encal.cli import main
from encal.deploy import (Compensator, compile_table, export_c, load_model, model_to_dict, read_model, save_model,
                          write_c)
from encal import runtime
from encal.deploy.cexport import FLOAT32_BUDGET_ARCMIN
from encal._core.errors import InputError, ModelFileError
from encal.models.ann import fit_ann
from encal.models.directional import DirectionalModel
from encal.models.fourier import FourierModel, fit_fourier
from encal.models.hybrid import fit_hybrid
from encal.models.lut import LookupTableModel, fit_lut
from encal.models.stack import WEIGHT_SUM_TOLERANCE, StackModel, fit_stack

GRID = np.arange(0.0, 360.0, 2.0)  # the paper's training grid
DENSE = np.linspace(-360.0, 720.0, 1000)  # 1000 angles over three turns, wrap included
BITS = 16


def harmonics(theta_deg):
    """A noise-free profile of orders 0, 1 and 2, in arcmin."""
    r = np.radians(theta_deg)
    return 0.4 + 3.0 * np.sin(r + 0.3) + 1.5 * np.cos(2 * r)


def bump(theta_deg):
    """A local defect: a 2-arcmin Gaussian bump of 4 degrees (sigma) at 100 degrees."""
    distance = (np.asarray(theta_deg) - 100.0 + 180.0) % 360.0 - 180.0
    return 2.0 * np.exp(-0.5 * (distance / 4.0) ** 2)


def two_fourier():
    first = FourierModel([0, 1], [0.5, 2.0], [0.0, -1.0])
    second = FourierModel([1, 3], [0.25, 1.0], [3.0, 0.0])
    return StackModel([first, second], [0.25, 0.75], encoder={"name": "enc1", "resolution_bits": BITS})


@pytest.fixture(scope="module")
def lut_ann():
    error = harmonics(GRID) + bump(GRID)
    members = [fit_lut(GRID, error, interpolation="cubic"), fit_ann(GRID, error, hidden=5, epochs=40, rng=0)]
    return StackModel(members, [0.6, 0.4], encoder={"name": "enc2", "resolution_bits": BITS})


@pytest.fixture(scope="module")
def every_kind():
    """A stack of one member of each kind, fitted (real weights and tables)."""
    error = harmonics(GRID) + bump(GRID)
    members = [fit_fourier(GRID, error, orders=[0, 1, 2]), fit_lut(GRID, error),
               fit_ann(GRID, error, hidden=6, epochs=40, rng=1),
               fit_hybrid(GRID, error, n_orders=3, hidden=4, epochs=30, restarts=1, rng=2)]
    return StackModel(members, [0.4, 0.3, 0.2, 0.1], encoder={"name": "enc3", "resolution_bits": BITS})


@pytest.fixture(scope="module")
def directional(lut_ann):
    forward = StackModel([FourierModel([1], [0.0], [2.0]), lut_ann.members[0]], [0.7, 0.3])
    reverse = StackModel([FourierModel([1, 2], [0.1, 0.5], [1.5, 0.0]), lut_ann.members[1]], [0.5, 0.5])
    return DirectionalModel(forward, reverse, encoder={"name": "enc4", "resolution_bits": BITS})


def weighted_sum(stack, theta):
    return sum(weight * member.predict(theta) for weight, member in zip(stack.weights, stack.members))


# -- the model ----------------------------------------------------------------------------

def test_prediction_is_the_weighted_sum_of_two_fourier_members():
    stack = two_fourier()
    r = np.radians(DENSE)
    truth = (0.25 * (0.5 + 2.0 * np.cos(r) - np.sin(r))
             + 0.75 * (0.25 * np.cos(r) + 3.0 * np.sin(r) + np.cos(3 * r)))
    np.testing.assert_allclose(stack.predict(DENSE), weighted_sum(stack, DENSE), rtol=0, atol=1e-12)
    np.testing.assert_allclose(stack.predict(DENSE), truth, rtol=0, atol=1e-12)


def test_prediction_is_the_weighted_sum_of_a_table_and_a_network(lut_ann):
    np.testing.assert_allclose(lut_ann.predict(DENSE), weighted_sum(lut_ann, DENSE), rtol=0, atol=1e-12)
    assert lut_ann.predict(np.ones((2, 3))).shape == (2, 3) and np.ndim(lut_ann.predict(5.0)) == 0


def test_attributes_and_repr():
    stack = two_fourier()
    assert isinstance(stack.members, tuple) and [m.kind for m in stack.members] == ["fourier", "fourier"]
    assert stack.weights.dtype == float and stack.weights.tolist() == [0.25, 0.75]
    assert repr(stack) == "<StackModel 0.25 fourier + 0.75 fourier for enc1>"
    lut = LookupTableModel([0.0, 180.0, 360.0], [[0.0, 0.0], [1.0, 1.0]], "linear")
    assert repr(StackModel([FourierModel([0], [1.0], [0.0]), lut], [0.62, 0.38])) == \
        "<StackModel 0.62 fourier + 0.38 lut for unnamed encoder>"


def test_parameters_follow_the_model_file_layout_and_rebuild_exactly(every_kind):
    parameters = every_kind.parameters()
    assert [member["kind"] for member in parameters["members"]] == ["fourier", "lut", "ann", "hybrid"]
    assert parameters["weights"] == [0.4, 0.3, 0.2, 0.1]
    assert json.loads(json.dumps(parameters)) == parameters  # plain JSON data
    rebuilt = StackModel.from_parameters(parameters)
    assert np.array_equal(rebuilt.predict(DENSE), every_kind.predict(DENSE))


def test_the_documented_example():
    # docs/model-file.md, kind `stack`
    parameters = {"members": [{"kind": "fourier", "parameters": {"orders": [1], "cos": [0.0], "sin": [2.0]}},
                              {"kind": "lut", "parameters": {"interpolation": "linear",
                                                             "breaks_deg": [0.0, 180.0, 360.0],
                                                             "coefficients": [[0.01, -0.01], [0.0, 1.8]]}}],
                  "weights": [0.6, 0.4]}
    assert float(StackModel.from_parameters(parameters).predict(90.0)) == pytest.approx(1.56, abs=1e-12)
    assert runtime.normalisation_of("stack", parameters) == {"members": [{}, {}]}


# -- model file and the standalone runtime -------------------------------------------------

@pytest.mark.parametrize("name", ["two_fourier", "lut_ann", "every_kind"])
def test_save_load_round_trip_is_exact_and_the_checksum_verifies(request, tmp_path, name):
    stack = two_fourier() if name == "two_fourier" else request.getfixturevalue(name)
    path = save_model(stack, tmp_path / "stack.json")
    loaded, sha = read_model(path)
    document = json.loads(path.read_text(encoding="utf-8"))
    assert loaded.kind == "stack" and document["kind"] == "stack"
    assert sha == document["sha256"] == runtime.content_sha256(document)
    assert np.array_equal(loaded.predict(DENSE), stack.predict(DENSE))
    assert document["normalisation"] == {"members": [runtime.normalisation_of(m.kind, m.parameters())
                                                     for m in stack.members]}


@pytest.mark.parametrize("name", ["two_fourier", "lut_ann", "every_kind"])
def test_runtime_agrees_with_predict(request, tmp_path, name):
    stack = two_fourier() if name == "two_fourier" else request.getfixturevalue(name)
    stored = runtime.load(save_model(stack, tmp_path / "stack.json"))
    ours = np.array([stored.predict_arcmin(theta) for theta in DENSE])
    np.testing.assert_allclose(ours, stack.predict(DENSE), rtol=0, atol=1e-12)
    corrected = np.array([stored.correct_deg(theta) for theta in DENSE])
    assert np.abs((corrected - stack.correct(DENSE) + 180.0) % 360.0 - 180.0).max() <= 1e-12 / 60


def test_a_directional_model_with_stacked_parts(directional, tmp_path):
    path = save_model(directional, tmp_path / "dir.json")
    loaded = load_model(path)
    stored = runtime.load(path)
    assert [loaded.forward.kind, loaded.reverse.kind] == ["stack", "stack"]
    for direction in (1, -1, None):
        expected = directional.predict(DENSE, direction=direction)
        assert np.array_equal(loaded.predict(DENSE, direction=direction), expected)
        ours = np.array([stored.predict_arcmin(theta, direction) for theta in DENSE])
        np.testing.assert_allclose(ours, expected, rtol=0, atol=1e-12)
    assert json.loads(path.read_text())["normalisation"]["reverse"]["members"][1]["target_gain"] == \
        directional.reverse.members[1].parameters()["target_gain"]


# -- C export -------------------------------------------------------------------------------

GCC = shutil.which("gcc")
CFLAGS = ["-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", "-Wshadow",
          "-Wdouble-promotion", "-Wconversion", "-O2"]
needs_gcc = pytest.mark.skipif(GCC is None, reason="gcc is not installed")

# Includes the generated source to reach its static double-precision functions.
DOUBLE_DRIVER = """\
#include <stdio.h>
#include "{prefix}.c"

int main(void)
{{
    uint32_t k;
    for (k = 0; k < {n}u; ++k) {{
        const double theta = (double)k * (360.0 / {n}.0);
        const double out[{width}] = {{{values}}};
        fwrite(out, sizeof(double), {width}, stdout);
    }}
    return 0;
}}
"""

FLOAT_DRIVER = """\
#include <stdio.h>
#include <stdint.h>
#include "{prefix}.h"

int main(void)
{{
    uint32_t k;
    for (k = 0; k < {n}u; ++k) {{
        const float theta = (float)((double)k * (360.0 / {n}.0));
        const float out[3] = {{{prefix}_predict_arcmin(theta), {prefix}_correct_deg(theta),
                               {prefix}_correct_counts(k)}};
        fwrite(out, sizeof(float), 3, stdout);
    }}
    return 0;
}}
"""


def run_c(folder, prefix, driver, dtype):
    (folder / "driver.c").write_text(driver)
    program = folder / "driver"
    sources = [str(folder / "driver.c")] + ([] if f'"{prefix}.c"' in driver else [str(folder / f"{prefix}.c")])
    compiled = subprocess.run([GCC, *CFLAGS, "-I", str(folder), *sources, "-lm", "-o", str(program)],
                              capture_output=True, text=True, timeout=300)
    assert compiled.returncode == 0, compiled.stderr
    raw = subprocess.run([str(program)], capture_output=True, timeout=60, check=True).stdout
    return np.frombuffer(raw, dtype=dtype).astype(float)


def circular(a, b):
    return np.abs((np.asarray(a) - np.asarray(b) + 180.0) % 360.0 - 180.0)


@needs_gcc
@pytest.mark.parametrize("name", ["two_fourier", "every_kind"])
def test_c_formula_in_double_agrees_to_1e9_arcmin(request, tmp_path, name):
    stack = two_fourier() if name == "two_fourier" else request.getfixturevalue(name)
    files = write_c(stack, tmp_path, prefix="stk", constants="double")
    assert "static const double model_weight[" in files[1].read_text()
    n = 2**BITS
    out = run_c(tmp_path, "stk", DOUBLE_DRIVER.format(prefix="stk", n=n, width=1, values="error_arcmin(theta)"),
                np.float64)
    theta = np.arange(n) * (360.0 / n)
    assert np.abs(out - stack.predict(theta)).max() <= 1e-9


@needs_gcc
def test_c_directional_with_stacked_parts_agrees_to_1e9_arcmin(tmp_path, directional):
    write_c(directional, tmp_path, prefix="dst", constants="double")
    n = 2**BITS
    values = ("model_directed_error_arcmin(theta, 1), model_directed_error_arcmin(theta, -1), "
              "model_directed_error_arcmin(theta, 0)")
    out = run_c(tmp_path, "dst", DOUBLE_DRIVER.format(prefix="dst", n=n, width=3, values=values),
                np.float64).reshape(-1, 3)
    theta = np.arange(n) * (360.0 / n)
    for column, direction in enumerate((1, -1, None)):
        assert np.abs(out[:, column] - directional.predict(theta, direction=direction)).max() <= 1e-9


@needs_gcc
@pytest.mark.parametrize("name, constants", [("two_fourier", "float"), ("every_kind", "auto"),
                                             ("directional", "auto")])
def test_c_float_api_agrees_within_the_float32_budget(request, tmp_path, name, constants):
    # The tolerances of tests/deploy/test_cexport.py: float32 constants, then the float32 return value.
    model = two_fourier() if name == "two_fourier" else request.getfixturevalue(name)
    comp = Compensator(model)
    files = write_c(comp, tmp_path, prefix="flt", constants=constants)
    if constants == "float":
        assert "static const float model_weight[2] = {\n    0.25f, 0.75f\n};" in files[1].read_text()
    n = 2**BITS
    out = run_c(tmp_path, "flt", FLOAT_DRIVER.format(prefix="flt", n=n), np.float32).reshape(-1, 3)
    theta = (np.arange(n) * (360.0 / n)).astype(np.float32).astype(float)
    error = comp.predict(theta)
    tolerance = FLOAT32_BUDGET_ARCMIN + 2.0**-23 * np.abs(error).max()
    assert np.abs(out[:, 0] - error).max() <= tolerance
    angle_tolerance = 2.0**-16 + tolerance / 60
    assert circular(out[:, 1], comp.correct(theta)).max() <= angle_tolerance
    assert circular(out[:, 2], comp.correct(np.arange(n) * (360.0 / n))).max() <= angle_tolerance


def test_float32_weights_are_measured_not_refused():
    # Rounded to float32, 0.1 + 0.2 + 0.7 no longer sums to 1 within 1e-9; the exporter must still measure
    # the model change (some 1e-8 arcmin here) rather than fall back to double.
    stack = StackModel([FourierModel([1], [1.0], [0.0]), FourierModel([2], [0.0], [1.0]),
                        FourierModel([0], [3.0], [0.0])], [0.1, 0.2, 0.7], encoder={"resolution_bits": 12})
    rounded = np.float32([0.1, 0.2, 0.7]).astype(float)
    assert abs(rounded.sum() - 1.0) > WEIGHT_SUM_TOLERANCE
    source = export_c(stack)["encal.c"]
    assert "static const float model_weight[3]" in source
    assert "constants stored as float" in source


@needs_gcc
def test_c_table_of_a_stack_agrees_with_the_python_table(tmp_path, lut_ann):
    comp = Compensator(lut_ann)
    write_c(comp, tmp_path, prefix="tab", table="int16")
    n = 2**BITS
    out = run_c(tmp_path, "tab", FLOAT_DRIVER.format(prefix="tab", n=n), np.float32).reshape(-1, 3)
    table = compile_table(comp, BITS, dtype="int16")
    codes = np.arange(n)
    expected = table.predict_counts(codes)
    assert np.abs(out[:, 0] - expected).max() <= 2.0**-24 * np.abs(expected).max()
    assert circular(out[:, 2], table.correct_counts(codes)).max() <= 2.0**-16
    theta = codes * (360.0 / n)
    assert np.abs(expected - lut_ann.predict(theta)).max() <= table.quantisation_arcmin


def test_cli_exports_a_stack_file_as_c_and_as_a_table(tmp_path, capsys, lut_ann):
    path = save_model(lut_ann, tmp_path / "stack.json")
    assert main(["export", str(path), "--format", "c", "-o", str(tmp_path / "fw")]) == 0
    assert "kind stack" in (tmp_path / "fw" / "encal.c").read_text()
    assert main(["export", str(path), "--format", "c", "--table", "-o", str(tmp_path / "tab")]) == 0
    assert "error_table[65536]" in (tmp_path / "tab" / "encal.c").read_text()
    assert capsys.readouterr().err == ""
    assert main(["export", str(path), "--format", "table", "--bits", "12", "-o", str(tmp_path / "t.tab")]) == 0
    assert capsys.readouterr().err.startswith("encal export: warning: --bits 12 differs from the 16 bits")


# -- fitting ----------------------------------------------------------------------------------

def test_two_identical_fourier_members_recover_a_noise_free_profile():
    members = [{"family": "fourier", "options": {"orders": [0, 1, 2]}}] * 2
    stack = fit_stack(GRID, harmonics(GRID), members=members, weights=[0.3, 0.7])
    np.testing.assert_allclose(stack.predict(DENSE), harmonics(DENSE), rtol=0, atol=1e-10)


def test_a_fitted_stack_is_the_weighted_sum_of_its_members_fitted_alone():
    error = harmonics(GRID) + bump(GRID)
    members = [{"family": "lut", "options": {"interpolation": "linear"}},
               {"family": "fourier", "options": {"n_orders": 4}}]
    stack = fit_stack(GRID, error, members=members, weights=[0.35, 0.65])
    alone = 0.35 * fit_lut(GRID, error, interpolation="linear").predict(DENSE) \
        + 0.65 * fit_fourier(GRID, error, n_orders=4).predict(DENSE)
    np.testing.assert_allclose(stack.predict(DENSE), alone, rtol=0, atol=1e-12)


def test_training_records_the_options_and_each_members_record():
    members = [{"family": "fourier", "options": {"orders": [0, 1, 2]}},
               {"family": "ann", "options": {"hidden": 3, "epochs": 10}}]
    stack = fit_stack(GRID, harmonics(GRID), members=members, weights=[0.5, 0.5], rng=4)
    training = stack.training
    assert training["seed"] == 4
    assert training["options"] == {"members": members, "weights": [0.5, 0.5]}
    assert training["members"][0]["orders"] == [0, 1, 2] and training["members"][1]["hidden"] == 3
    assert all(member.training == {} for member in stack.members)
    members[0]["options"]["orders"].append(3)  # the record keeps what was fitted
    assert training["options"]["members"][0]["options"]["orders"] == [0, 1, 2]


def test_a_member_draws_from_its_own_stream():
    # Member i uses the i-th stream spawned from the seed, whatever the other members are.
    error = harmonics(GRID) + bump(GRID)
    ann = {"family": "ann", "options": {"hidden": 3, "epochs": 10}}
    beside_fourier = fit_stack(GRID, error, members=[{"family": "fourier"}, ann], weights=[0.5, 0.5], rng=7)
    beside_table = fit_stack(GRID, error, members=[{"family": "lut"}, ann], weights=[0.5, 0.5], rng=7)
    alone = fit_ann(GRID, error, hidden=3, epochs=10,
                    rng=np.random.default_rng(np.random.SeedSequence(7).spawn(2)[1]))
    assert beside_fourier.members[1].parameters() == beside_table.members[1].parameters() == alone.parameters()


def test_rng_may_be_a_generator_or_none():
    members = [{"family": "ann", "options": {"hidden": 3, "epochs": 10}}, {"family": "lut"}]
    first, second = (fit_stack(GRID, harmonics(GRID), members=members, weights=[0.5, 0.5],
                               rng=np.random.default_rng(3)) for _ in range(2))
    assert first.training["seed"] is None and first.parameters() == second.parameters()
    drawn = fit_stack(GRID, harmonics(GRID), members=members, weights=[0.5, 0.5])
    again = fit_stack(GRID, harmonics(GRID), members=members, weights=[0.5, 0.5], rng=drawn.training["seed"])
    assert drawn.parameters() == again.parameters()


def calibration(name="enc"):
    return encal.Calibration(GRID, GRID + (harmonics(GRID) + bump(GRID)) / 60.0, name=name)


STACK_OPTIONS = {"members": [{"family": "fourier", "options": {"orders": [0, 1, 2]}},
                             {"family": "ann", "options": {"hidden": 4, "epochs": 30}}],
                 "weights": [0.4, 0.6]}


def test_fit_with_method_stack_is_deterministic_and_the_seed_matters():
    cal = calibration()
    first, second = (encal.fit(cal, method="stack", rng=0, **STACK_OPTIONS) for _ in range(2))
    assert first.kind == "stack" and first.training["method"] == "stack" and first.training["seed"] == 0
    assert first.training["fit_options"] == STACK_OPTIONS
    assert np.array_equal(first.predict(DENSE), second.predict(DENSE))
    other = encal.fit(cal, method="stack", rng=1, **STACK_OPTIONS)
    assert np.array_equal(other.members[0].predict(DENSE), first.members[0].predict(DENSE))
    assert other.members[1].parameters()["W1"] != first.members[1].parameters()["W1"]
    assert not np.array_equal(other.members[1].predict(DENSE), first.members[1].predict(DENSE))


def test_fit_with_method_stack_saves_and_reloads(tmp_path):
    model = encal.fit(calibration("enc9"), method="stack", rng=0, **STACK_OPTIONS)
    document = model_to_dict(model)
    assert document["training"]["options"]["weights"] == [0.4, 0.6]
    assert document["training"]["members"][1]["hidden"] == 4
    loaded = load_model(save_model(model, tmp_path / "m.json"))
    assert np.array_equal(loaded.predict(DENSE), model.predict(DENSE))
    assert loaded.encoder["name"] == "enc9"


def test_uncertainty_refits_the_stack_with_its_recorded_options():
    options = {"members": [{"family": "fourier", "options": {"orders": [0, 1, 2]}}, {"family": "lut"}],
               "weights": [0.5, 0.5]}
    model = encal.fit(calibration(), method="stack", rng=0, uncertainty=True, **options)
    mean, std = model.predict(DENSE, return_std=True)
    assert np.array_equal(mean, model.predict(DENSE))
    assert np.all(np.isfinite(std) & (std > 0))


# -- bad input --------------------------------------------------------------------------------

MEMBERS = [{"family": "fourier", "options": {"orders": [0, 1]}}, {"family": "lut"}]


@pytest.mark.parametrize("options, message", [
    ({"weights": [0.5, 0.6]}, r"'weights' parameter of fit_stack must sum to 1 \(within 1e-09\)"),
    ({"weights": [1.2, -0.2]}, r"'weights' parameter of fit_stack must hold finite floats > 0"),
    ({"weights": [1.0, 0.0]}, r"'weights' parameter of fit_stack must hold finite floats > 0"),
    ({"weights": [np.nan, 0.5]}, r"'weights' parameter of fit_stack must hold finite floats > 0"),
    ({"weights": [1.0]}, r"'weights' parameter of fit_stack must hold one weight per member \(2\)"),
    ({"weights": "half"}, r"'weights' parameter of fit_stack must be a sequence of floats"),
    ({"weights": ["0.5", "0.5"]}, r"'weights' parameter of fit_stack must be a sequence of floats"),
    ({"members": MEMBERS + [{"family": "directional"}]}, r"Got family 'directional' for member 2"),
    ({"members": [MEMBERS[0], {"family": "stack"}]}, r"Got family 'stack' for member 1"),
    ({"members": [MEMBERS[0], {"family": "auto"}]}, r"Got family 'auto' for member 1"),
    ({"members": [MEMBERS[0], {"family": "spline"}]}, r"family one of fourier, spectral, lut, hybrid, ann"),
    ({"members": [MEMBERS[0], {"family": "ann", "options": {"rng": 3}}]}, r"no 'rng' option"),
    ({"members": [MEMBERS[0], {"family": "lut", "interpolation": "cubic"}]}, r"for member 1"),
    ({"members": [], "weights": []}, r"Got an empty list instead"),
    ({"members": "fourier"}, r"'members' parameter of fit_stack must be a non-empty list"),
    ({"rng": -1}, r"'rng' parameter of fit_stack must be None, an int >= 0"),
])
def test_fit_stack_refuses_bad_options(options, message):
    arguments = {"members": MEMBERS, "weights": [0.5, 0.5], **options}
    with pytest.raises(InputError, match=message):
        fit_stack(GRID, harmonics(GRID), **arguments)


def test_encal_fit_refuses_bad_weights():
    with pytest.raises(InputError, match="must sum to 1"):
        encal.fit(calibration(), method="stack", rng=0, members=MEMBERS, weights=[0.5, 0.4])


@pytest.mark.parametrize("members, weights, message", [
    (lambda: [FourierModel([0], [1.0], [0.0])] * 2, [0.5, 0.6], r"'weights' parameter of StackModel must sum to 1"),
    (lambda: [FourierModel([0], [1.0], [0.0])] * 2, [1.5, -0.5], r"must hold finite floats > 0"),
    (lambda: [FourierModel([0], [1.0], [0.0])] * 2, [1.0], r"must hold one weight per member \(2\)"),
    (lambda: [FourierModel([0], [1.0], [0.0]), two_fourier()], [0.5, 0.5],
     r"'members' parameter of StackModel must hold models of kind fourier, spectral, lut, hybrid, ann. Got a 'stack'"),
    (lambda: [DirectionalModel(FourierModel([0], [1.0], [0.0]), FourierModel([0], [2.0], [0.0]))], [1.0],
     r"Got a 'directional' model instead"),
    (lambda: ["fourier"], [1.0], r"Got a str instead"),
    (lambda: [], [], r"must hold at least one model"),
])
def test_the_constructor_refuses_bad_members_and_weights(members, weights, message):
    with pytest.raises(InputError, match=message):
        StackModel(members(), weights)


def bad_parameters():
    """(id, change to a good stack's parameters, message of from_parameters, message of the runtime)."""
    directional = {"kind": "directional", "parameters": {}}
    return [
        ("sum", lambda p: p.update(weights=[0.25, 0.7]), r"must sum to 1", r"to sum to 1 \(within 1e-09\)"),
        ("negative", lambda p: p.update(weights=[1.25, -0.25]), r"floats > 0", r"weights to be > 0"),
        ("zero", lambda p: p.update(weights=[1.0, 0.0]), r"floats > 0", r"weights to be > 0"),
        ("length", lambda p: p.update(weights=[1.0]), r"one weight per member", r"weights to be a list of 2"),
        ("directional member", lambda p: p["members"].append(directional),
         r"members must be of kind fourier, spectral, lut, hybrid, ann. Got 'directional'",
         r"members\[2\]\.kind to be one of"),
        ("stack member", lambda p: p["members"].__setitem__(0, {"kind": "stack", "parameters": {}}),
         r"Got 'stack' instead",
         r"members\[0\]\.kind to be one of ann, arc, fourier, hybrid, lut, spectral, got \"stack\""),
        ("no weights", lambda p: p.pop("weights"), r"a list 'weights'", r"weights to be a list of 2"),
        ("no members", lambda p: p.update(members=[]), r"non-empty list 'members'", r"members to be a non-empty"),
        ("bad member", lambda p: p["members"][1]["parameters"].pop("sin"), r"fourier model parameters",
         r"members\[1\]\.parameters\.sin"),
    ]


@pytest.mark.parametrize("change, message", [pytest.param(c, m, id=i) for i, c, m, _ in bad_parameters()])
def test_from_parameters_refuses_bad_data(change, message):
    parameters = two_fourier().parameters()
    change(parameters)
    with pytest.raises(ModelFileError, match=message):
        StackModel.from_parameters(parameters)


def write_resigned(path, document):
    document = dict(document)
    document["sha256"] = runtime.content_sha256(document)
    path.write_text(json.dumps(document), encoding="utf-8")
    return path


@pytest.mark.parametrize("change, message", [pytest.param(c, m, id=i) for i, c, _, m in bad_parameters()])
def test_runtime_and_encal_refuse_the_same_bad_files(tmp_path, change, message):
    document = model_to_dict(two_fourier())
    change(document["parameters"])
    path = write_resigned(tmp_path / "bad.json", document)
    with pytest.raises(runtime.ModelFileError, match=message):
        runtime.load(path)
    with pytest.raises(ModelFileError, match=message):
        load_model(path)


@pytest.mark.parametrize("excess, accepted", [(0.5e-9, True), (-0.9e-9, True), (2e-9, False), (-2e-9, False)])
def test_runtime_and_encal_share_the_weight_tolerance(tmp_path, excess, accepted):
    assert runtime.WEIGHT_SUM_TOLERANCE == WEIGHT_SUM_TOLERANCE
    document = model_to_dict(two_fourier())
    document["parameters"]["weights"] = [0.25, 0.75 + excess]
    path = write_resigned(tmp_path / "edge.json", document)
    if accepted:
        assert float(load_model(path).predict(10.0)) == pytest.approx(runtime.load(path).predict_arcmin(10.0),
                                                                       abs=1e-12)
    else:
        with pytest.raises(runtime.ModelFileError, match="sum to 1"):
            runtime.load(path)
        with pytest.raises(ModelFileError, match="sum to 1"):
            load_model(path)


def test_a_stack_without_members_or_weights_is_refused_in_one_sentence():
    theta = np.arange(0.0, 360.0, 10.0)
    for options in ({}, {"members": [{"family": "lut"}]}):
        with pytest.raises(InputError, match=r"^fit_stack expects members and weights: "):
            fit_stack(theta, np.sin(np.radians(theta)), **options)


def test_drift_offers_no_stack_method(tmp_path, capsys):
    from encal.cli import main
    theta = np.arange(0.0, 360.0, 10.0)
    path = tmp_path / "a.csv"
    path.write_text("reference_deg,encoder_deg\n" + "".join(f"{t},{t + 0.01}\n" for t in theta))
    with pytest.raises(SystemExit) as info:
        main(["drift", str(path), str(path), "--method", "stack"])
    assert info.value.code == 2 and "invalid choice: 'stack'" in capsys.readouterr().err
