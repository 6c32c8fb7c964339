"""Table 3 for one encoder: fit every model to a training calibration and compare them on a test one.

Models: Fourier series of the ten largest harmonics (the paper's), linear and
cubic lookup tables, the paper's 1:80:1 raw-angle network (trainlm), and
encal's periodic network. Statistics are of the residual
(observed − predicted error) on the test points, in arc-minutes.

Examples:
  encal compare enc1_train.csv enc1_test.csv
  encal compare enc1_train.csv enc1_test.csv --json
"""

from ._common import add_calibration_options, check_paths, print_json, read_calibration_from_args, size_option


def add_arguments(parser):
    from ..paper.studies.comparison import DEFAULT_MODELS

    parser.add_argument("train", metavar="TRAIN.csv", help="calibration the models are fitted to")
    parser.add_argument("test", metavar="TEST.csv", help="calibration the models are judged on")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.add_argument("--models", metavar="KEYS",
                        help="comma-separated subset of: " + ", ".join(spec.key for spec in DEFAULT_MODELS))
    parser.add_argument("--epochs", type=size_option("epochs"), default=1000,
                        help="epoch budget of the networks (default: 1000)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the networks' initial weights (default: 0)")
    add_calibration_options(parser)


def _models(text):
    from .._core.errors import InputError
    from ..paper.studies.comparison import DEFAULT_MODELS

    if text is None:
        return DEFAULT_MODELS
    known = {spec.key: spec for spec in DEFAULT_MODELS}
    keys = [key.strip() for key in text.split(",") if key.strip()]
    unknown = [key for key in keys if key not in known]
    if unknown or not keys:
        raise InputError(f"--models must list some of {', '.join(known)}. Got {text!r} instead.")
    return tuple(known[key] for key in keys)


def run(args):
    from .._core.errors import InputError
    from ..paper.studies.comparison import compare_models

    if args.seed < 0:
        raise InputError(f"--seed must be a whole number >= 0. Got {args.seed} instead.")
    models = _models(args.models)
    check_paths(inputs=[(args.train, "calibration"), (args.test, "calibration")])
    train = read_calibration_from_args(args.train, args)
    test = read_calibration_from_args(args.test, args)
    comparison = compare_models(train, test, models=models, epochs=args.epochs, rng=args.seed)
    if args.json:
        print_json(comparison.as_dict())
    else:
        print(comparison.table().to_text())
    return 0
