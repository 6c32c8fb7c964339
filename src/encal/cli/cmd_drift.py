"""Compare repeated calibrations of one encoder with the first, and say whether a model fitted on the first still holds.

The first file is the baseline; each later one is compared at the same shaft positions. When the reference's
zero is arbitrary (--zero; by default when a calibration's zero offset, the circular mean of its error, exceeds
1 degree) each calibration's offset is removed and the changes of offset are stated apart. A model of the
first calibration (by default the one `encal fit` makes of it: --method auto) still holds on a later one when its
residual RMS there exceeds the residual expected on an unchanged repeat by at most the tolerance: by default
max(1 LSB, 10 % or three standard errors).
The verdict is data: the exit status is 0 whether the model holds or not, 1 on bad input.

Examples:
  encal drift enc1_train.csv enc1_epoch2.csv
  encal drift runs.csv --json                 (one file whose epoch column names the runs)
  encal drift a.csv b.csv --tolerance 0.5 --method lut
"""

import argparse
from pathlib import Path

from .._core.errors import InputError
from ._common import add_calibration_options, add_zero_options, check_paths, print_json, read_calibration_from_args


def _number(text):
    from .._core.number_cells import not_plain_note, read_number

    try:
        return read_number(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number of arc-minutes, got {text!r}{not_plain_note(text)}") \
            from None


def add_arguments(parser):
    parser.add_argument("calibrations", metavar="CAL.csv", nargs="+",
                        help="the first calibration, then later ones (or one file with an epoch column)")
    parser.add_argument("--tolerance", metavar="ARCMIN", type=_number, default=None,
                        help="allowed excess of the residual RMS over the one expected on an unchanged repeat "
                             "(default: max(1 LSB, max(10%%, 3/sqrt(n)) of that))")
    parser.add_argument("--method", default=None, choices=("auto", "spectral", "fourier", "lut", "ann", "hybrid"),
                        help="model fitted on the first calibration (default: auto, the model encal fit makes; "
                             "fourier is the paper's ten harmonics; not with --model)")
    parser.add_argument("--model", metavar="MODEL.json", default=None,
                        help="judge this model file instead of fitting one on the first calibration")
    parser.add_argument("--keep-offset", dest="zero", action="store_const", const="fixed", default="auto",
                        help="same as --zero fixed: compare errors as measured, zero offsets included")
    parser.add_argument("--seed", type=int, default=None,
                        help="seed of a randomised --method (not with --model)")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    add_zero_options(parser)
    add_calibration_options(parser)


def run(args):
    from ..reports.drift import circular_mean_offset_arcmin, compare_calibrations, split_epochs
    from ..analysis.profile import zero_is_arbitrary, zero_sentence

    check_paths(inputs=[*((path, "calibration") for path in args.calibrations), (args.model, "model")])
    cals, labels = [], []
    for path in args.calibrations:
        cal = read_calibration_from_args(path, args)
        runs = split_epochs(cal) if len(args.calibrations) == 1 else [cal]
        cals.extend(runs)
        labels.extend([Path(path).name] if len(runs) == 1 else [str(run.epoch[0]) for run in runs])
    model = None
    if args.model is not None:
        from ..deploy import load_model

        fitting_options = [flag for flag, value in (("--method", args.method), ("--seed", args.seed))
                           if value is not None]
        if fitting_options:
            verb = "choose" if len(fitting_options) > 1 else "chooses"
            raise InputError(f"{' and '.join(fitting_options)} {verb} the model fitted on the first calibration "
                             f"and cannot be used with --model {args.model}.")
        model = load_model(args.model)
    offsets = [circular_mean_offset_arcmin(cal) for cal in cals]
    arbitrary = zero_is_arbitrary(args.zero, *offsets)
    report = compare_calibrations(cals, tolerance_arcmin=args.tolerance, model=model,
                                  method=args.method or "auto",
                                  offset="remove" if arbitrary else "keep", labels=labels,
                                  rng=args.seed)
    for epoch in report.epochs:
        if epoch.correction_worse:  # the verdict is data (status 0), but never a quiet one
            import warnings

            from .._core.errors import EncalWarning

            warnings.warn(epoch.worse_sentence(), EncalWarning, stacklevel=2)
    largest = max(offsets, key=abs)
    note = zero_sentence(args.zero, largest, arbitrary).replace("zero offset", "largest zero offset", 1)
    if args.json:
        print_json({**report.as_dict(), "zero": "arbitrary" if arbitrary else "fixed", "zero_note": note})
    else:
        print(note)
        _print_table(report, args.model)
    return 0


def _print_table(report, model_path):
    lsb = report.lsb_arcmin
    if lsb is None:
        resolution = "resolution unknown"
    else:
        how = "inferred from the readings" if report.resolution_inferred else "given"
        resolution = f"{report.resolution_bits}-bit ({how}), 1 LSB = {lsb:.4f}'"
    offsets = (f"zero offsets removed; the first's is {report.baseline_offset_arcmin:+.2f}" if report.offset == "remove"
               else "zero offsets kept")
    source = f"{report.model_kind} model from {model_path}" if model_path else \
        f"{report.method} model fitted on {report.baseline_label}"
    print(f"drift against {report.baseline_label} (arcmin; {resolution}; {offsets})")
    print(f"{source}: residual RMS {report.baseline_rms_arcmin:.4f} on the first calibration, "
          f"{report.expected_rms_arcmin:.4f} expected on an unchanged repeat (from the noise, least over the "
          f"later ones); "
          f"tolerance +{report.tolerance_arcmin:.4f} ({report.tolerance_rule}); "
          f"catches a drift of {report.detectable_drift_rms_arcmin:.4f} RMS")
    width = max(12, *(len(epoch.label) for epoch in report.epochs))
    header = (f"{'calibration':<{width}} {'n':>5} {'interp':>6} {'offset Δ':>10} {'diff RMS':>9} "
              f"{'max |d|':>8} {'≤1 LSB':>7} {'resid RMS':>10} {'excess':>8}  verdict")
    print(header)
    for epoch in report.epochs:
        stats = epoch.difference
        share = "-" if epoch.share_within_lsb is None else f"{100 * epoch.share_within_lsb:.0f}%"
        print(f"{epoch.label:<{width}} {stats.n:>5d} {'yes' if epoch.interpolated else 'no':>6} "
              f"{epoch.offset_change_arcmin:>+10.3f} {stats.rms:>9.4f} {stats.max_abs:>8.4f} {share:>7} "
              f"{epoch.residual_rms_arcmin:>10.4f} {epoch.increase_arcmin:>+8.4f}  "
              f"{'holds' if epoch.holds else 'does not hold'}")
    if report.holds:
        print("verdict: the model still holds on every later calibration")
    else:
        failed = ", ".join(epoch.label for epoch in report.epochs if not epoch.holds)
        print(f"verdict: the model does not hold on {failed}")
    for epoch in report.epochs:
        if epoch.correction_worse:
            print(f"verdict: {epoch.worse_sentence()}")
