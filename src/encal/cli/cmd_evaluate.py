"""Residual statistics of a model file on a calibration (ideally one it was not fitted on).

When the reference's zero is arbitrary (--zero; by default when the zero offset of the raw errors or
of the residuals exceeds 1 degree, as on a repeat calibration of a motor that started elsewhere), each
column's zero offset is stated apart and its statistics are of the shape about it.

Example:
  encal evaluate enc1.json enc1_test.csv --json
"""

from ._common import (activity, add_calibration_options, add_zero_options, check_paths, print_json,
                      read_calibration_from_args)


def add_arguments(parser):
    parser.add_argument("model", metavar="MODEL.json", help="model file written by 'encal fit'")
    parser.add_argument("calibration", metavar="CAL.csv", help="calibration CSV to evaluate on")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    add_zero_options(parser)
    add_calibration_options(parser)


def run(args):
    from ..deploy import load_model
    from ..fitting import evaluate

    check_paths(inputs=[(args.model, "model"), (args.calibration, "calibration")])
    with activity("evaluate") as progress:
        progress.stage(f"reading {args.model}")
        model = load_model(args.model)
        cal = read_calibration_from_args(args.calibration, args, progress)
        progress.stage("evaluating")
        result = evaluate(model, cal, zero=args.zero)
    if result.correction_worse:
        # a valid measurement, so exit status 0 (as drift's "does not hold"), but never a quiet one
        import warnings

        from ..errors import EncalWarning

        warnings.warn(f"{args.model} on {args.calibration}: {result.verdict()}", EncalWarning, stacklevel=2)
    if args.json:
        print_json({"name": cal.name, "model_kind": model.kind, **result.as_dict(),
                    "zero_note": result.zero_sentence(), "offset_note": result.offset_sentence()})
        return 0
    print(f"{cal.name}: {model.kind} model from {args.model} ({len(cal)} points)")
    print(result.zero_sentence())
    if result.offset_sentence():
        print(result.offset_sentence())
    print(result)
    print(f"verdict: {result.verdict()}")
    return 0
