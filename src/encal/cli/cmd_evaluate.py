"""Residual statistics of a model file on a calibration (ideally one it was not fitted on).

Example:
  encal evaluate enc1.json enc1_test.csv --json
"""

from ._common import add_calibration_options, print_json, read_calibration_from_args

HELP = "residual statistics of a model on a calibration"

_ROWS = (("n", "n", "{:d}"), ("MAE", "mae", "{:.4f}"), ("RMS", "rms", "{:.4f}"), ("STD", "std", "{:.4f}"),
         ("min", "min", "{:+.4f}"), ("max", "max", "{:+.4f}"), ("max |e|", "max_abs", "{:.4f}"))


def add_arguments(parser):
    parser.add_argument("model", metavar="MODEL.json", help="model file written by 'encal fit'")
    parser.add_argument("calibration", metavar="CAL.csv", help="calibration CSV to evaluate on")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    add_calibration_options(parser)


def run(args):
    from ..deploy import load_model
    from ..fitting import evaluate

    model = load_model(args.model)
    cal = read_calibration_from_args(args.calibration, args)
    result = evaluate(model, cal)
    if args.json:
        print_json({"name": cal.name, "model_kind": model.kind, **result.as_dict()})
        return 0
    print(f"{cal.name}: {model.kind} model from {args.model} ({len(cal)} points, arcmin)")
    print(f"{'':10s}{'before':>12s}{'after':>12s}")
    for label, attr, fmt in _ROWS:
        before, after = getattr(result.before, attr), getattr(result.after, attr)
        print(f"{label:10s}{fmt.format(before):>12s}{fmt.format(after):>12s}")
    return 0
