"""Calibrate an encoder without a precision reference, from the motor it sits on.

  encal selfcal spin LOG.csv [LOG2.csv ...] --pole-pairs 7 -o CAL.csv
      a log of (time_s, encoder_deg) while the motor spins at a constant drive; two or more speeds
      (files, or a 'run' column) separate the speed ripple from the encoder error
  encal selfcal sweep CAPTURE.txt --pole-pairs 21 -o CAL.csv
      a moteus raw calibration capture ('CAL start', lines 'dir phase encoder', 'CAL done'), or a CSV
      of the commanded electrical angle: electrical_deg, encoder_deg[, direction]
  encal selfcal steps A.csv [B.csv] -o CAL.csv
      full-step calibrations of a stepper (reference_deg = the full steps); with B, taken after turning
      the magnet on the rotor, the stepper's own error is separated (the shift method)
  encal selfcal dual LOG.csv --ratio N --motor-cal M.csv --output-cal O.csv
      a log of both encoders of a geared joint (motor_deg, output_deg): each calibrates the other through
      the gear (issue 31; docs/in-place.md)

The output is a calibration CSV (reference_deg, encoder_deg on a grid of readings, with the columns
error_arcmin and sigma_arcmin) for 'encal fit', 'encal profile' and 'encal report'. The summary printed
says the recovered harmonics with +-2 sigma and what the method cannot separate.
See docs/self-calibration.md.
"""

from pathlib import Path

import numpy as np

from .._core.errors import InputError
from .._core.number_cells import read_whole
from ._common import add_calibration_options, check_paths, int_in_range, size_option


def add_arguments(parser):
    methods = parser.add_subparsers(dest="method", metavar="METHOD", required=True)
    spin = methods.add_parser("spin", help="constant-drive spin(s): the rotor's inertia is the reference")
    spin.add_argument("logs", nargs="+", metavar="LOG.csv", help="spin log(s): time_s, encoder_deg[, run]")
    spin.add_argument("--pole-pairs", type=size_option("pole_pairs"), metavar="P",
                      help="motor pole pairs: with one speed, multiples of P are left out (torque ripple)")
    spin.add_argument("--slots", type=size_option("slots"), metavar="S",
                      help="motor slots: with one speed, multiples of S are left out too")
    spin.add_argument("--ripple-orders", metavar="K,...",
                      help="more orders to leave out with one speed, e.g. 1 for an unbalanced load")
    sweep = methods.add_parser("sweep", help="open-loop electrical-angle sweep (moteus raw capture)")
    sweep.add_argument("capture", metavar="CAPTURE", help="moteus raw capture (CAL start ... CAL done), or a CSV "
                                                         "with electrical_deg, encoder_deg[, direction]")
    sweep.add_argument("--pole-pairs", type=size_option("pole_pairs"), metavar="P", required=True,
                       help="motor pole pairs")
    sweep.add_argument("--slots", type=size_option("slots"), metavar="S",
                       help="also leave out multiples of the slot count (a motor with unequal slots)")
    sweep.add_argument("--skip", type=int_in_range(0), default=4, metavar="N",
                       help="samples left out at the start while the rotor settles (default 4)")
    steps = methods.add_parser("steps", help="full steps of a stepper; two calibrations with the magnet turned "
                                              "separate the stepper's error")
    steps.add_argument("calibrations", nargs="+", metavar="CAL.csv", help="one or two full-step calibrations")
    steps.add_argument("--turn", type=float, metavar="DEG",
                       help="the magnet's turn on the rotor from the first to the second calibration, if known")
    steps.add_argument("--step-shift", type=int, metavar="M",
                       help="full steps between the two calibrations' starts, if known")
    steps.add_argument("--stepper-csv", metavar="FILE",
                       help="also write the stepper's error at each full step (two calibrations)")
    steps.add_argument("--single-reads", action="store_true",
                       help="each point of the two calibrations is one reading of the encoder, not a mean of several "
                            "(as Mechaduino's and Klipper's routines take): the reading noise their difference "
                            "measures is then a new reading's, and is written for encal fit")
    add_calibration_options(steps)
    _add_log_options(spin, ("--time-col", "time_s", "the time column (seconds)"), unit_options=("--enc-unit",))
    _add_log_options(sweep, ("--ref-col", "electrical_deg", "the commanded electrical angle column"),
                     unit_options=("--ref-unit", "--enc-unit"))
    _add_dual(methods)
    for sub, default in ((spin, 32), (sweep, 32), (steps, 16)):
        sub.add_argument("-o", "--output", required=True, metavar="CAL.csv", help="calibration CSV to write")
        sub.add_argument("--max-order", type=int_in_range(1, 180), default=default, metavar="K",
                         help=f"highest harmonic order recovered (default {default})")
        sub.add_argument("--points", type=int_in_range(8, 100000), default=360, metavar="N",
                         help="readings in the calibration written (a uniform grid; default 360)")
        sub.add_argument("--bits", type=int_in_range(1, 32), metavar="B",
                         help="encoder resolution in bits, recorded in the calibration (sweep: default 16, the "
                              "capture's counts)")


def _add_log_options(parser, first_column, unit_options):
    """Column and unit options of a log (spin, sweep CSV), next to those of the calibration options."""
    from ._common import angle_unit_argument

    option, default, what = first_column
    parser.add_argument(option, metavar="NAME", default=default,
                        help=f"{what}: its header name or number from 1 (default {default})")
    parser.add_argument("--enc-col", metavar="NAME", default="encoder_deg",
                        help="the encoder column: its header name or number from 1 (default encoder_deg)")
    for unit_option in unit_options:
        column = "the commanded electrical angle" if unit_option == "--ref-unit" else "the encoder column"
        parser.add_argument(unit_option, metavar="UNIT", type=angle_unit_argument, default=None,
                            help=f"unit of {column}: deg (default), rad, rev or counts:B")
    parser.add_argument("--unit", metavar="UNIT", type=angle_unit_argument, default=None,
                        help="unit of " + ("both angle columns, unless --ref-unit or --enc-unit says otherwise"
                                           if len(unit_options) > 1 else "the encoder column (as --enc-unit)"))


def _unit(args, name):
    return getattr(args, name, None) or getattr(args, "unit", None) or "deg"


def run(args):
    if args.method == "dual":
        return _dual(args)
    inputs = {"spin": getattr(args, "logs", None), "sweep": [getattr(args, "capture", None)],
              "steps": getattr(args, "calibrations", None)}[args.method]
    kind = "calibration" if args.method == "steps" else "capture"
    check_paths(inputs=[(path, kind) for path in inputs],
                outputs=[("-o", args.output), ("--stepper-csv", getattr(args, "stepper_csv", None))])
    if args.method == "spin":
        from ..selfcal.spin import spin
        from ..selfcal.spin_log import read_spin_log

        logs = [log for path in args.logs for log in read_spin_log(path, time_column=args.time_col,
                                                                   encoder_column=args.enc_col,
                                                                   encoder_unit=_unit(args, "enc_unit"))]
        result = spin(logs, pole_pairs=args.pole_pairs, slots=args.slots, max_order=args.max_order,
                      ripple_orders=_orders(args.ripple_orders), name=Path(args.logs[0]).stem)
    elif args.method == "steps":
        result = _steps(args)
    else:
        result = _sweep(args)
    from .._core.atomic import atomic_file_set

    bits = args.bits if args.bits is not None or args.method != "sweep" else 16
    with atomic_file_set():
        result.write(args.output, points=args.points, resolution_bits=bits)
        if getattr(args, "stepper_csv", None) is not None:
            _write_stepper(args.stepper_csv, result.details)
    print(result.summary())
    print(f"wrote {args.output}: {args.points} readings; fit it with 'encal fit {args.output} -o MODEL.json'")
    return 0


def _sweep(args):
    from ..selfcal.moteus_capture import read_moteus_capture
    from ..selfcal.sweep import sweep, sweep_capture
    from ..selfcal.sweep_log import read_sweep_log

    from .._core.arcs import arc_of

    options = {"max_order": args.max_order, "slots": args.slots, "skip": args.skip}
    if _starts_with_cal(args.capture):
        given = [option for option, value in (("--ref-col", args.ref_col != "electrical_deg"),
                                               ("--enc-col", args.enc_col != "encoder_deg"),
                                               ("--ref-unit", args.ref_unit), ("--enc-unit", args.enc_unit),
                                               ("--unit", args.unit)) if value]
        if given and getattr(args, "_parser", None) is not None:
            args._parser.error(f"{' and '.join(given)} name{'s' if len(given) == 1 else ''} a column or unit of a "
                               f"sweep CSV; {args.capture} is a moteus capture (CAL start ... CAL done), whose "
                               "columns are fixed")
        capture = read_moteus_capture(args.capture)
        if arc_of(capture.encoder_deg, 30.0) is None:
            return sweep_capture(capture, args.pole_pairs, **options)
        # a sweep back and forth over an arc (issue 31)
        phase, reading, travel = capture.phase_deg_e, capture.encoder_deg, capture.travel
    else:
        log = read_sweep_log(args.capture, phase_column=args.ref_col, encoder_column=args.enc_col,
                             phase_unit=_unit(args, "ref_unit"), encoder_unit=_unit(args, "enc_unit"))
        phase, reading, travel = log.phase_deg_e, log.encoder_deg, log.travel
        if arc_of(reading, 30.0) is None:
            return sweep(phase, reading, travel, args.pole_pairs, name=Path(args.capture).stem,
                         where=str(args.capture), **options)
    from ..selfcal.arc_sweep import arc_sweep

    return arc_sweep(phase, reading, travel, args.pole_pairs, skip=args.skip, name=Path(args.capture).stem,
                     where=str(args.capture), points=args.points)


def _starts_with_cal(path):
    """True if the first non-blank line of ``path`` begins with 'CAL' (a moteus capture), or it cannot be read."""
    try:
        with open(path, "rb") as handle:
            for line in handle:
                if line.strip():
                    return line.lstrip().startswith(b"CAL")
    except OSError:
        return True  # the capture reader names the problem
    return True


def _steps(args):
    from ..selfcal.steps import steps
    from ._common import read_calibration_from_args

    if len(args.calibrations) > 2:
        raise InputError(f"steps takes one or two calibrations; got {len(args.calibrations)}")
    if len(args.calibrations) == 1 and args.single_reads and getattr(args, "_parser", None) is not None:
        args._parser.error("--single-reads needs a second calibration: one calibration's tooth errors are confounded "
                           "with its noise")
    if len(args.calibrations) == 1 and (args.turn is not None or args.step_shift is not None
                                        or args.stepper_csv is not None):
        raise InputError("--turn, --step-shift and --stepper-csv need a second calibration (after turning the magnet)")
    calibrations = [read_calibration_from_args(path, args) for path in args.calibrations]
    result = steps(*calibrations, turn_deg=args.turn, step_shift=args.step_shift, max_order=args.max_order,
                   name=Path(args.calibrations[0]).stem, single_reads=args.single_reads)
    if args.bits is None:
        from ..models.fitting import resolution_bits

        args.bits = resolution_bits(calibrations[0])  # declared, else shown by whole codes (a real Mechaduino's)
    return result


def _write_stepper(path, details):
    """The stepper's error at each full step of the first calibration, as a CSV."""
    from .._core.atomic import atomic_open

    error, sigma = details["stepper_error_arcmin"], details["stepper_sigma_arcmin"]
    model, model_sigma = details["stepper_model_arcmin"], details["stepper_model_sigma_arcmin"]
    n = len(error)
    with atomic_open(path, "w", newline="\n") as handle:
        handle.write("step,reference_deg,stepper_error_arcmin,sigma_arcmin,model_arcmin,model_sigma_arcmin\n")
        for k in range(n):
            handle.write(f"{k},{k * 360.0 / n!r},{error[k]:.6g},{sigma[k]:.6g},{model[k]:.6g},{model_sigma[k]:.6g}\n")


def _orders(text):
    if not text:
        return ()
    try:
        orders = tuple(read_whole(cell) for cell in text.split(",") if cell.strip())
    except ValueError:
        raise InputError(f"--ripple-orders must be whole numbers separated by commas. Got {text!r} instead.") from None
    if any(order < 1 for order in orders):
        raise InputError(f"--ripple-orders must be orders >= 1. Got {text!r} instead.")
    return orders


def _add_dual(methods):
    dual = methods.add_parser("dual", help="two encoders of a geared joint (motor and output) calibrate each other")
    dual.add_argument("log", metavar="LOG.csv", help="log of both encoders: motor_deg, output_deg (time order)")
    dual.add_argument("--ratio", type=float, required=True, metavar="N",
                      help="gear ratio: motor turns per output turn (negative when the output turns the other way)")
    dual.add_argument("--motor-cal", required=True, metavar="M.csv", help="calibration CSV of the motor encoder")
    dual.add_argument("--output-cal", required=True, metavar="O.csv", help="calibration CSV of the output encoder")
    dual.add_argument("--pinion-teeth", type=int_in_range(1, 100000), metavar="Z",
                      help="teeth of the gear on the motor shaft: the mesh orders (multiples of Z) are left out of "
                           "the motor's profile, as they hold the gear's tooth-mesh error too")
    dual.add_argument("--max-order", type=int_in_range(1, 180), default=30, metavar="K",
                      help="highest harmonic order recovered on each shaft (default 30)")
    dual.add_argument("--points", type=int_in_range(8, 100000), default=360, metavar="N",
                      help="readings in each calibration written (a uniform grid; default 360)")
    dual.add_argument("--json", action="store_true", help="print one JSON object")


def _dual(args):
    import json

    from .._core.atomic import atomic_file_set
    from ..selfcal.dual import dual, read_dual_log

    check_paths(inputs=[(args.log, "capture")], outputs=[("--motor-cal", args.motor_cal),
                                                         ("--output-cal", args.output_cal)])
    if Path(args.motor_cal).resolve() == Path(args.output_cal).resolve():
        raise InputError(f"--motor-cal and --output-cal are both {args.motor_cal}; expected two files")
    motor, output, name = read_dual_log(args.log)
    try:
        result = dual(motor, output, args.ratio, motor_orders=args.max_order, output_orders=args.max_order,
                      pinion_teeth=args.pinion_teeth, name=name)
    except InputError as exc:  # the library's sentence is about arrays: say which file they came from
        raise InputError(f"{args.log}: {exc}") from None
    with atomic_file_set():
        result.motor.write(args.motor_cal, points=args.points)
        result.output.write(args.output_cal, points=args.points)
    if args.json:
        grid = result.motor.grid(args.points)
        print(json.dumps({"ratio": result.ratio, "ratio_estimated": result.ratio_estimated,
                          "output_turns": result.output_turns, "residual_rms_arcmin": result.noise_arcmin,
                          "confounded": [{"motor_order": j, "output_order": k} for j, k in result.confounded],
                          "motor_removed_orders": list(result.motor.removed_orders),
                          **{f"{shaft}_rms_arcmin": _rms(getattr(result, shaft).error_arcmin(grid))
                             for shaft in ("motor", "output")},
                          "files": [str(args.motor_cal), str(args.output_cal)]}))
        return 0
    print(result.summary())
    print(f"wrote {args.motor_cal} and {args.output_cal}: {args.points} readings each; fit each with "
          "'encal fit CAL.csv -o MODEL.json'")
    return 0


def _rms(values):
    return float(np.sqrt(np.mean(np.square(values))))
