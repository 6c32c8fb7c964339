"""Fit an error model to a calibration and save it as a model file.

Examples:
  encal fit enc1_train.csv -o enc1.json
  encal fit enc1_train.csv -o enc1.json --method ann --hidden 80 --algorithm trainlm --encoding raw --seed 0
  encal fit enc1_train.csv -o enc1.json --method spectral --noise 0.15
  encal fit enc1_train.csv -o enc1.json --method spectral --repeat enc1_pass2.csv
  encal fit stepper.csv -o stepper.json --json

The model predicts the whole error, zero offset included, so that it corrects the readings to the
reference's zero. When that zero is arbitrary (--zero; by default when the offset exceeds 1 degree)
the offset is stated apart and the training-set statistics are of the shape about it.
"""

from .._core.number_cells import read_whole
from ._common import (activity, add_calibration_options, add_target_tolerance_option, add_zero_options, check_paths,
                      int_in_range, print_json, read_calibration_from_args, size_option)


def add_arguments(parser):
    parser.add_argument("calibration", metavar="CAL.csv", help="calibration CSV (reference_deg, encoder_deg)")
    parser.add_argument("-o", "--output", required=True, metavar="MODEL.json", help="model file to write")
    parser.add_argument("--method", default="auto", choices=["auto", "spectral", "fourier", "lut", "ann", "hybrid"],
                        help="model family (default: auto); spectral: the empirical-Bayes Fourier model "
                             "(docs/model-selection.md)")
    parser.add_argument("--noise", type=_positive_float, metavar="ARCMIN",
                        help="standard deviation of one reading's noise in arc-minutes, if known (spectral, auto)")
    parser.add_argument("--repeat", metavar="CAL2.csv",
                        help="a second pass over the same reference angles at the same zero: fitted together "
                             "with the first, the noise is estimated from the two readings at each angle; a pass "
                             "on other angles or shifted by more than the readings' scatter is refused "
                             "(spectral, auto)")
    parser.add_argument("--hidden", type=size_option("hidden"), help="hidden nodes of the network (ann)")
    parser.add_argument("--algorithm", help="training algorithm of the network, MATLAB's name (ann)")
    parser.add_argument("--encoding", choices=["raw", "periodic"],
                        help="network input: raw angle (the paper) or periodic cos/sin (default)")
    parser.add_argument("--epochs", type=size_option("epochs"), help="maximum training epochs (ann)")
    parser.add_argument("--orders", help="Fourier orders, comma-separated, e.g. 0,1,2,16 (fourier)")
    parser.add_argument("--n-orders", type=size_option("n_orders"), help="keep the N largest harmonics (fourier)")
    parser.add_argument("--interpolation", choices=["linear", "cubic"], help="lookup-table interpolation (lut)")
    parser.add_argument("--folds", type=size_option("folds", 2), metavar="K",
                        help="choose among the model families by K-fold cross-validation (the older scheme; "
                             "it may choose a weighted mean of several) instead of auto's default, the "
                             "spectral model by its evidence; any K switches, 5 included (auto; "
                             "docs/model-selection.md)")
    parser.add_argument("--at-steps", action="store_const", const=True, default=None,
                        help="the encoder will be read only at the calibrated angles (a motor's full steps): "
                             "validate the candidates there, so a per-step pattern of the reference counts "
                             "(auto; docs/model-selection.md)")
    parser.add_argument("--networks", action="store_const", const=True, default=None,
                        help="also cross-validate the hybrid and two periodic networks against the spectral "
                             "model, on calibrations of at most 400 stops; slower, and measured worse on the "
                             "real files (auto; docs/model-selection.md)")
    parser.add_argument("--no-stack", dest="stack", action="store_const", const=False, default=None,
                        help="choose one model family, never a weighted mean of several (auto)")
    parser.add_argument("--bidirectional", choices=["per-direction", "mean"],
                        help="a calibration whose direction column holds both directions of travel: one model "
                             "per direction (default) or one model of their mean (docs/bidirectional.md)")
    parser.add_argument("--seed", type=int, help="random seed (ann, auto): same seed, identical model file")
    parser.add_argument("--bits", type=int_in_range(1, 32), metavar="B",
                        help="encoder resolution in bits, recorded in the model file (default: a "
                             "'# resolution_bits: B' comment, else what the readings show when every one "
                             "is a multiple of 360/2^B degrees)")
    parser.add_argument("--budget", type=_budget, metavar="COST",
                        help="also choose the most accurate firmware deployment within this cost (e.g. 1KiB, "
                             "256entries, 40ops), the cheapest one if several stay within a tenth of an LSB "
                             "of the model; record it for 'encal export --target' and say what it gave up")
    parser.add_argument("--target", choices=["cortex-m4f", "fixed"], default=None,
                        help="the processor of --budget: cortex-m4f (float32, default) or fixed (integers)")
    parser.add_argument("--reproducible", action="store_true",
                        help="fix the date field (and the seed, 0 unless --seed is given) so the same inputs give a "
                             "byte-identical file")
    parser.add_argument("--json", action="store_true",
                        help="print one JSON object (model, seed, training-set statistics, selection table)")
    add_zero_options(parser)
    add_calibration_options(parser)
    add_target_tolerance_option(parser)
    parser.set_defaults(fit_parser=parser)


#: option -> the methods it applies to
_APPLIES_TO = {
    "hidden": ("ann", "hybrid"), "algorithm": ("ann", "hybrid"), "encoding": ("ann",),
    "epochs": ("ann", "hybrid"), "interpolation": ("lut",), "n_orders": ("fourier", "hybrid"),
    "orders": ("fourier",), "seed": ("ann", "hybrid", "auto"), "folds": ("auto",),
    "at_steps": ("auto",), "stack": ("auto",), "networks": ("auto",), "noise": ("spectral", "auto"),
    "repeat": ("spectral", "auto"),
}


def _cv_options(options):
    return any(name in options for name in ("folds", "stack", "use_grid"))


def _positive_float(text):
    import argparse
    import math

    from .._core.number_cells import not_plain_note, read_number
    from ..models.spectral import MAX_NOISE_ARCMIN

    expected = f"expected a number of arc-minutes > 0 and at most {MAX_NOISE_ARCMIN:g} (a turn)"
    try:
        value = read_number(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{expected}, got {text!r}{not_plain_note(text)}") from None
    # the lower bound depends on the data (the errors' resolution): fit_spectral checks it
    if not (math.isfinite(value) and 0 < value <= MAX_NOISE_ARCMIN):
        raise argparse.ArgumentTypeError(f"{expected}, got {text!r}")
    return value


def _options(args):
    usage_error = args.fit_parser.error  # usage and one line on stderr, exit status 2
    for name, methods in _APPLIES_TO.items():
        if getattr(args, name) is not None and args.method not in methods:
            flag = "--no-stack" if name == "stack" else "--" + name.replace("_", "-")
            usage_error(f"{flag} applies to --method {' or '.join(methods)}, not {args.method}")
    if args.orders is not None and args.n_orders is not None:
        usage_error("--orders and --n-orders both choose the Fourier orders; expected one of them")
    options = {}
    for name in ("hidden", "algorithm", "encoding", "epochs", "interpolation", "n_orders", "folds", "stack"):
        value = getattr(args, name)
        if value is not None:
            options[name] = value
    if args.bidirectional is not None:
        options["bidirectional"] = args.bidirectional
    if args.at_steps:
        options["use_grid"] = True
    if args.networks:
        options["networks"] = True
    if args.noise is not None:
        options["noise_arcmin"] = args.noise
    if args.orders is not None:
        try:
            options["orders"] = [read_whole(o) for o in args.orders.split(",") if o.strip()]  # not '1_0', '１'
        except ValueError:
            usage_error(f"--orders must be whole numbers separated by commas. Got {args.orders!r} instead.")
    return options


def _budget(text):
    import argparse

    from ..deploy.deployment import parse_budget
    from .._core.errors import InputError

    try:
        cost, value = parse_budget(text)
    except InputError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    return {"cost": cost, "value": value, "text": text}


def _choose_deployment(model, args):
    """Record in the model the deployment --budget chooses; return the line that says what it is."""
    from ..deploy.deployment import choose_deployment
    from ..deploy.compact import default_tolerance_arcmin

    bits = model.encoder.get("resolution_bits")
    chosen, report = choose_deployment(model, budget=(args.budget["cost"], args.budget["value"]),
                                       tolerance_arcmin=default_tolerance_arcmin(bits),
                                       target=args.target or "cortex-m4f")
    model.training["deployment"] = {**chosen.as_dict(), "budget": args.budget["text"]}
    within = ("within a tenth of an LSB of the model" if bits else "within 0.01 arcmin of the model")
    met = within if report["met"] else f"not {within}: the budget allows no more"
    return (f"deployment within {args.budget['text']}: {chosen.describe()} ({met}); {report['gave_up']}; "
            f"'encal export --format c --target {chosen.target}' uses it")


def _check_not_itself(repeat, calibration):
    """Refuse ``--repeat`` naming the calibration being fitted: the same readings twice are no second pass."""
    from pathlib import Path

    from .._core.errors import InputError

    if Path(repeat).exists() and Path(calibration).exists() and Path(repeat).samefile(calibration):
        raise InputError(f"--repeat {repeat} is the calibration being fitted; expected a second pass over the same "
                         "angles measured on its own, since the same readings twice carry no information about the "
                         "noise (give a known noise with --noise)")


def _identical_readings(cal, second):
    """Whether two calibrations hold the same (reference, encoder) readings, to 1e-9 degree, in any order."""
    import numpy as np

    if len(cal) != len(second) or (cal.direction is None) != (second.direction is None):
        return False
    rows = []
    for c in (cal, second):
        columns = [np.round(c.reference_deg, 9), np.round(c.encoder_deg, 9)]
        if c.direction is not None:
            columns.append(c.direction)
        table = np.column_stack(columns)
        rows.append(table[np.lexsort(table.T[::-1])])
    return bool(np.array_equal(rows[0], rows[1]))


def _with_repeat(cal, second):
    """Both passes as one calibration, each pass an epoch of its own.

    ``second`` must be a second pass at the same stops as ``cal`` (see :func:`_check_same_stops`) and at the same
    zero (see :func:`_check_same_zero`); otherwise its readings are no repeats and the noise drawn from them is wrong.
    """
    import numpy as np

    from ..data.calibration import Calibration
    from .._core.errors import InputError

    _check_same_stops(cal, second)
    _check_same_zero(cal, second)
    if (cal.direction is None) != (second.direction is None):
        has, lacks = (cal, second) if cal.direction is not None else (second, cal)
        raise InputError(f"{has.source} has a direction column but {lacks.source} has none; expected both passes "
                         "with the direction of travel of every reading, or neither")
    if (cal.reference_std_arcmin is None) != (second.reference_std_arcmin is None):
        has, lacks = (cal, second) if cal.reference_std_arcmin is not None else (second, cal)
        raise InputError(f"{has.source} has a sigma_arcmin column (its reference's uncertainty) but {lacks.source} "
                         "has none; expected both passes with it, or neither")
    direction = None if cal.direction is None else np.r_[cal.direction, second.direction]
    reference_std = None if cal.reference_std_arcmin is None else np.r_[cal.reference_std_arcmin,
                                                                          second.reference_std_arcmin]
    passes = [np.full(len(c), label) if c.epoch is None else np.char.add(f"{label}/", c.epoch)
              for label, c in (("1", cal), ("2", second))]
    return Calibration(np.r_[cal.reference_deg, second.reference_deg], np.r_[cal.encoder_deg, second.encoder_deg],
                       direction=direction, epoch=np.r_[passes[0], passes[1]], name=cal.name,
                       resolution_bits=cal.resolution_bits or second.resolution_bits, source=cal.source,
                       reading_sign=cal.reading_sign, target_tolerance_deg=cal.target_tolerance_deg,
                       reference_std_arcmin=reference_std)


def _check_same_stops(cal, second):
    """Refuse a repeat pass whose reference angles are not the stops of the calibration.

    Only readings at one reference angle (within :data:`encal.analysis.profile.ANGLE_TOLERANCE_DEG`, 1e-9 degree, as the
    spectral model groups them) are repeats; a pass on another grid
    (the test grid 1, 3, ..., 359 degrees against the training grid 0, 2, ..., 358) would be fitted as more stops
    of one calibration and its noise taken blind, under a message that says a repeat was given.
    """
    import numpy as np

    from .._core.angles import wrap180
    from .._core.errors import InputError
    from ..analysis.profile import ANGLE_TOLERANCE_DEG, distinct_angles

    stops = [distinct_angles(c.reference_deg)[0] for c in (cal, second)]

    def missing(these, those):
        """The angles of ``these`` farther than the tolerance from every angle of ``those``."""
        index = np.searchsorted(those, these) % those.size
        near = np.minimum(np.abs(wrap180(these - those[index])), np.abs(wrap180(these - those[index - 1])))
        return these[near > ANGLE_TOLERANCE_DEG]

    extra, lacking = missing(stops[1], stops[0]), missing(stops[0], stops[1])
    if extra.size or lacking.size:
        which = (f"{extra.size} of its {stops[1].size} stops ({_angles(extra)}) are not stops of {cal.source}"
                 if extra.size else
                 f"it lacks {lacking.size} of the {stops[0].size} stops of {cal.source} ({_angles(lacking)})")
        raise InputError(f"--repeat {second.source}: {which}; expected a second pass over the same reference angles "
                         "(within 1e-9 deg), since only readings at the same angle measure the noise "
                         "(give a known noise with --noise, or fit the other grid on its own)")


def _angles(values, shown=3):
    """'1, 3, 5, ... deg' for a message."""
    text = ", ".join(f"{v:g}" for v in values[:shown])
    return text + (", ..." if values.size > shown else "") + " deg"


def _check_same_zero(cal, second):
    """Refuse a repeat pass whose readings are shifted from the calibration's by more than their scatter.

    A shift ``d`` between the passes adds ``d**2 / 2`` to the variance the repeats give, so the noise estimate would
    be mostly the shift when ``|d|`` exceeds the scatter of the differences. A reference whose zero is arbitrary (a
    motor's full steps counted from power-on, docs/drift.md) moves its zero between passes by degrees: its readings
    at one reference angle are then at different shaft positions and not repeats at all. ``encal drift`` is the
    command that compares such calibrations, removing the change of zero.
    """
    import numpy as np

    from .._core.angles import ARCMIN_PER_DEG, wrap180
    from .._core.errors import InputError
    from ..analysis.profile import distinct_angles

    reference = np.r_[cal.reference_deg, second.reference_deg]
    _, group = distinct_angles(reference)
    stops = int(group.max()) + 1
    first, other = group[:len(cal)], group[len(cal):]
    base = cal.encoder_deg[0] - cal.reference_deg[0]
    means = []
    for members, c in ((first, cal), (other, second)):
        offset = wrap180(c.encoder_deg - c.reference_deg - base)
        means.append(np.bincount(members, weights=offset, minlength=stops) / np.bincount(members, minlength=stops))
    difference = (means[1] - means[0]) * ARCMIN_PER_DEG
    shift = float(difference.mean())
    scatter = float(difference.std(ddof=1))
    if abs(shift) > scatter and abs(shift) > 4.0 * scatter / np.sqrt(stops):
        raise InputError(f"--repeat {second.source}: its readings are {shift:+.4g} arcmin ({shift / 60:+.4g} deg) off "
                         f"those of {cal.source} at the same reference angles on average, more than the scatter of "
                         f"the differences ({scatter:.3g} arcmin), so the zero moved between the passes; expected a "
                         "second pass at the same zero, whose readings differ by noise only (a motor's zero is "
                         "arbitrary: compare such passes with 'encal drift', which removes the change of zero)")


def _check_noise_not_recorded(noise, cal):
    """Refuse ``--noise`` on a self-calibration's curve that records the reading noise it measured: the fit adds that
    to a new reading's band, and the two together counted the noise twice."""
    from .._core.errors import InputError
    from ..models.uncertainty import reading_noise

    recorded = reading_noise(cal)
    if noise is not None and recorded is not None:
        raise InputError(f"{cal.source}: records the reading noise its self-calibration measured ({recorded:.4g} "
                         f"arcmin), which the fit adds to a new reading's band, and --noise {noise:g} was given too; "
                         "expected one of them (leave out --noise)")


def run(args):
    from .._core.memory import release_freed_memory
    from ..data.reversal import has_both_directions
    from ..models.fitting import evaluate, fit
    from . import _fit_report

    if args.target is not None and args.budget is None:
        args.fit_parser.error("--target names the processor of --budget; expected it with --budget")
    options = _options(args)
    check_paths(inputs=[(args.calibration, "calibration"), (args.repeat, "calibration")],
                outputs=[("-o", args.output)])
    with activity("fit") as progress:
        cal = read_calibration_from_args(args.calibration, args, progress, targets=True)
        _check_noise_not_recorded(args.noise, cal)
        if args.repeat is not None:
            _check_not_itself(args.repeat, args.calibration)
            second = read_calibration_from_args(args.repeat, args, progress)
            if _identical_readings(cal, second):
                import warnings

                from .._core.errors import EncalWarning

                warnings.warn(f"--repeat {second.source}: its readings are those of {cal.source} at every reference "
                              "angle, identical; identical repeats carry no information about the noise, so it is "
                              "ignored (a copy of the file? give a second pass measured on its own, or a known noise "
                              "with --noise)", EncalWarning, stacklevel=2)
            else:
                cal = _with_repeat(cal, second)
        release_freed_memory()  # what the reading freed, before the fit's arrays (encal._core.memory)
        if args.seed is not None:
            options["rng"] = args.seed
        elif args.reproducible and args.method in _APPLIES_TO["seed"]:
            options["rng"] = 0  # a drawn seed would make two runs' files differ
        if args.method in ("spectral", "auto") and not _cv_options(options) and not has_both_directions(cal):
            from ..models.spectral import STAGES

            progress.stage(f"fitting ({args.method})", total=STAGES)
            model = fit(cal, method=args.method, progress=progress.advance, **options)
        else:
            progress.stage(f"fitting ({args.method})")
            model = fit(cal, method=args.method, **options)
        progress.stage("training-set statistics")
        fitted = evaluate(model, cal, zero=args.zero)
        model.training["zero"] = "arbitrary" if fitted.arbitrary_zero else "fixed"
        model.training["zero_offset_arcmin"] = fitted.before.offset if fitted.arbitrary_zero else None
        if args.budget is not None:
            progress.stage("choosing the deployment")
        deployment = _choose_deployment(model, args) if args.budget is not None else None
        progress.stage(f"writing {args.output}")
        model.save(args.output, reproducible=args.reproducible)
        selection = model.training.get("selection")
        progress.stage("held-out estimate")
        held_out = _fit_report.held_out(model, cal, args.method, options)
    held_out_text = _fit_report.held_out_lines(held_out)
    if args.json:
        print_json({"name": cal.name, "model_kind": model.kind, "output": str(args.output), "n_points": len(cal),
                    "seed": model.training.get("seed"), "resolution_bits": model.encoder.get("resolution_bits"),
                    "training_set": fitted.as_dict(), "zero_note": fitted.zero_sentence(), "selection": selection,
                    "held_out": held_out, "noise": _fit_report.noise(model),
                    "held_out_note": "; ".join(held_out_text) or None,
                    "deployment": str(deployment) if deployment else None})
        return 0
    _print_report(model)
    if selection is not None and selection.get("scheme") == "evidence":
        from ..models.auto import format_choice

        print(format_choice(selection))
    elif selection is not None:
        from ..models.select import format_selection

        print(format_selection(selection))
    if model.kind == "directional":
        print(f"{cal.name}: both directions of travel, one {model.forward.kind} model per direction "
              "(the mean of both when a reading's direction is not known)")
        for name, part in held_out.items():
            if part is not None and getattr(model, name).kind != "spectral":  # a spectral part's report states it
                print(f"{name}: {part['text']}")
    elif held_out_text and model.kind != "spectral":  # a spectral model's report states it
        print(held_out_text[0])
    if held_out is not None and held_out.get("mean_note"):
        print(held_out["mean_note"])
    print(_resolution_line(cal, model.encoder.get("resolution_bits")))
    shape = ""
    if fitted.arbitrary_zero:
        print(fitted.zero_sentence())
        shape = " of the shape"
    print(f"{cal.name}: {model.kind} model, {len(cal)} points; training-set RMS{shape} "
          f"{fitted.before.rms:.4g} -> {fitted.after.rms:.4g} arcmin (MAE {fitted.before.mae:.4g} -> "
          f"{fitted.after.mae:.4g}); wrote {args.output}")
    if model.range_deg is not None:  # issue 31
        from .._core.arcs import describe_range

        print(f"the calibration covers {describe_range(model.range_deg)}: the model holds there only (NaN outside "
              "in Python and the runtime; encal correct and encal export take --outside clamp|pass)")
    if deployment:
        print(deployment)
    return 0


def _print_report(model):
    """A model's own report (a spectral model's prior, noise and held-out estimate); each direction's."""
    parts = [("", model)] if model.kind != "directional" else [("forward: ", model.forward),
                                                                  ("reverse: ", model.reverse)]
    for prefix, part in parts:
        report = getattr(part, "report", None)
        if callable(report):
            print("\n".join(prefix + line for line in report().splitlines()))


def _resolution_line(cal, bits):
    if bits is None:
        return ("resolution: unknown (the readings are not all multiples of 360/2^B degrees for a B from 8 "
                "to 24; pass --bits); the model file records none")
    if cal.resolution_bits is not None:
        return f"resolution: {bits} bits (declared), recorded in the model file"
    return (f"resolution: {bits} bits (every reading is a multiple of 360/2^{bits} degrees), recorded in the "
            "model file; --bits overrides")
