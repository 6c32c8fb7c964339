"""Export a model for firmware: a dense per-code table, or C source.

--format table   a file with a per-code correction table for a B-bit encoder
                 (80-byte header + 2^B little-endian int16 or float32 errors;
                 see docs/deployment.md); -o is the file.
--format c       PREFIX.h and PREFIX.c with PREFIX_predict_arcmin(float),
                 PREFIX_correct_deg(float) and PREFIX_correct_counts(uint32_t);
                 -o is a folder (created if missing). The model's formula is
                 evaluated in double, or, with --table, a dense table is looked up.
--format c --target cortex-m4f
                 float32 only (no double anywhere): a compact table of N nodes
                 (a power of two, the fewest that meet --tolerance; --nodes,
                 --dtype int8|int16|float32, --interpolation linear|cubic), or
                 --form formula for a Fourier series. Angle functions and code functions (PREFIX_error_lsb,
                 PREFIX_correct_code, PREFIX_correct_counts).
--format moteus|simplefoc|klipper|mechaduino|tinymovr
                 the firmware's own table (moteus: --restore-config lines; SimpleFOC:
                 calibrationLut; Klipper: the [angle] calibrate: list;
                 Mechaduino: lookup[16384]; Tinymovr: rec_table[64]); -o is
                 the file. Prints the round trip through that firmware's own
                 run-time rule against the model, on every code. SimpleFOC:
                 --firmware-version 1.0.8|1.0.9|uint16 (default 1.0.9).
                 Klipper and Mechaduino need --step-zero DEG: the reference
                 angle of a full step at driver phase 0 (their tables follow the
                 stepper's phase). Klipper also needs --step-direction 1|-1:
                 whether the stepper's positive steps raise or lower the
                 reference angle.
--format c --target fixed
                 int32/int16 arithmetic only: a compact integer table; angles
                 as 32-bit binary angles, codes in and out.

The encoder resolution (--bits) defaults to the one recorded in the model file. An option given with a
--format it does not apply to (_APPLIES_TO below) is a usage error, never silently ignored.
"""

from pathlib import Path

from ..deploy import Compensator, compile_table, save_table
from .._core.atomic import atomic_write
from ..deploy.targets import FORMS, TARGETS, describe, write_target

FIRMWARE = ("moteus", "simplefoc", "klipper", "mechaduino", "tinymovr")
SIMPLEFOC_VERSIONS = ("1.0.8", "1.0.9", "uint16")
from .._core.errors import InputError
from ._common import check_paths, print_json
from ._serial import add_serial_options, model_input, model_or_serial


def add_arguments(parser):
    parser.add_argument("model", metavar="MODEL.json", nargs="?",
                        help="model file written by 'encal fit' (or --serial)")
    add_serial_options(parser)  # issue 32: the unit's latest model in the calibration store
    parser.add_argument("--format", required=True, choices=("c", "table", *FIRMWARE),
                        help="what to write")
    parser.add_argument("-o", "--output", required=True, metavar="PATH",
                        help="table file (--format table) or folder for the C files (--format c)")
    parser.add_argument("--bits", type=int, metavar="B",
                        help="encoder resolution in bits (default: from the model file)")
    parser.add_argument("--dtype", choices=("int8", "int16", "float32"),
                        help="storage of the table's errors (dense table: int16 or float32, default int16; "
                             "compact table: default the cheapest that meets --tolerance)")
    parser.add_argument("--target", choices=TARGETS,
                        help="C: host (double), cortex-m4f (float32 only) or fixed (integers only); "
                             "default host")
    parser.add_argument("--form", choices=FORMS,
                        help="C for cortex-m4f: a compact table (every kind; default) or the formula "
                             "(a Fourier series)")
    parser.add_argument("--nodes", type=int, metavar="N",
                        help="C for cortex-m4f/fixed: nodes of the compact table, a power of two "
                             "(default: the fewest that meet --tolerance)")
    parser.add_argument("--interpolation", choices=("linear", "cubic"),
                        help="C for cortex-m4f/fixed: between the compact table's nodes, linear or a "
                             "cubic B-spline (fewer nodes for the same error, about twice the "
                             "operations); default the smaller table in bytes that meets --tolerance")
    parser.add_argument("--tolerance", type=float, metavar="ARCMIN",
                        help="C for cortex-m4f/fixed: pick the cheapest deployment (--cost) whose "
                             "deployed error against the model stays within ARCMIN, and say what it "
                             "gave up (default tolerance: a tenth of an LSB)")
    parser.add_argument("--cost", choices=("bytes", "entries", "operations"),
                        help="C for cortex-m4f/fixed: what 'cheapest' means for --tolerance "
                             "(default: operations per reading, then bytes)")
    parser.add_argument("--source", type=int, metavar="K",
                        help="moteus: motor_position.sources.K (default 0)")
    parser.add_argument("--sign", type=int, choices=(1, -1), metavar="{1,-1}",
                        help="moteus: motor_position.sources.K.sign of the source (default 1): the table is indexed "
                             "by offset_value = wrap((raw + offset) * sign)")
    parser.add_argument("--offset", type=float, metavar="COUNTS",
                        help="moteus: motor_position.sources.K.offset of the source, counts (default 0)")
    parser.add_argument("--conf", metavar="FILE",
                        help="moteus: a 'conf enumerate' dump of the device: the sign, offset and cpr of source K "
                             "and the commutation source are read from it")
    parser.add_argument("--moteus-style", choices=("restore", "console"),
                        help="moteus: 'restore' (default) writes lines for moteus_tool --restore-config FILE (no "
                             "'conf set'; comments); 'console' writes 'conf set' lines to send at a console")
    parser.add_argument("--full-steps", type=int, metavar="N",
                        help="klipper: full steps per turn of the stepper (default 200)")
    parser.add_argument("--firmware-version", choices=SIMPLEFOC_VERSIONS, metavar="V",
                        help="simplefoc: the Arduino-FOC-drivers CalibratedSensor the table is for: 1.0.8 (adds a "
                             "float LUT of 128), 1.0.9 (subtracts a float LUT of 200; default) or uint16 (subtracts "
                             "a uint16 LUT of 200, pull request #75 after 1.0.9)")
    parser.add_argument("--step-zero", type=_finite_degrees, metavar="DEG",
                        help="klipper, mechaduino: the reference angle, degrees, of a full step at driver phase 0 "
                             "(electrical zero); the table is written from it (required: both firmwares tie the "
                             "table to the stepper's phase)")
    parser.add_argument("--step-direction", type=int, choices=(1, -1), metavar="{1,-1}",
                        help="klipper: which way the stepper's positive full steps (a positive FORCE_MOVE, dir_pin "
                             "included) turn the reference: 1 raise its angle, -1 lower it (required: the "
                             "calibration does not say, and the wrong way is a list two full steps out of phase)")
    parser.set_defaults(export_parser=parser)
    parser.add_argument("--name", metavar="PREFIX",
                        help="C: prefix of the file names and functions (default: encal)")
    parser.add_argument("--table", action="store_true", default=None,
                        help="C: look up a dense per-code table instead of evaluating the formula")
    parser.add_argument("--json", action="store_true",
                        help="print one JSON object naming what was written (files, bytes, table deviation)")
    parser.add_argument("--outside", choices=("clamp", "pass"),
                        help="a model calibrated over an arc (every format): the correction of the rest of the "
                             "turn, the nearer end's (clamp) or none (pass); refused without it")
    parser.add_argument("--constants", choices=("auto", "float", "double"),
                        help="C: storage of the formula's constants (default: float when it "
                             "changes the model by at most 1e-4 arcmin, else double)")


#: option (its argparse dest) -> the --formats it applies to. Given with another format it is a usage error, not
#: silently ignored: each option here defaults to None (so that "given" shows), and its documented default, if
#: any, is in _DEFAULTS. A new format-specific option is one line here.
_APPLIES_TO = {
    "dtype": ("c", "table"),
    "target": ("c",), "form": ("c",), "nodes": ("c",), "interpolation": ("c",), "tolerance": ("c",),
    "cost": ("c",), "name": ("c",), "table": ("c",), "constants": ("c",),
    "source": ("moteus",), "sign": ("moteus",), "offset": ("moteus",), "conf": ("moteus",),
    "moteus_style": ("moteus",),
    "firmware_version": ("simplefoc",),
    "full_steps": ("klipper",), "step_zero": ("klipper", "mechaduino"),
    "step_direction": ("klipper",),  # Mechaduino's calibrate() fixes it: forward steps must count the encoder up
}
#: the defaults of the options above, applied once the formats are checked
_DEFAULTS = {"target": "host", "form": "table", "name": "encal", "table": False, "constants": "auto",
             "source": 0, "moteus_style": "restore", "full_steps": 200}


def _check_applies(args):
    """Refuse an option given with a --format it does not apply to; then set the defaults of those not given."""
    for name, formats in _APPLIES_TO.items():
        if getattr(args, name, None) is not None and args.format not in formats:
            shown = " or ".join(", ".join(formats).rsplit(", ", 1)) if len(formats) > 1 else formats[0]
            args.export_parser.error(f"--{name.replace('_', '-')} applies to --format {shown}, not {args.format}")
    args.given = {name for name in _APPLIES_TO if getattr(args, name, None) is not None}
    for name, value in _DEFAULTS.items():
        if getattr(args, name, None) is None:
            setattr(args, name, value)
def _finite_degrees(text):
    """argparse type: a finite angle in degrees."""
    import argparse
    import math

    from .._core.number_cells import not_plain_note, read_number

    try:
        value = read_number(text)
    except ValueError:
        value = math.nan
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"expected a finite angle in degrees, got {text!r}{not_plain_note(text)}")
    return value


def _check_combinations(args):
    _usage_error = args.export_parser.error  # usage and one line on stderr, exit status 2
    _check_applies(args)
    # --step-zero (issue 26): Klipper's and Mechaduino's tables are tied to the stepper's phase
    if args.step_zero is None and args.format in ("klipper", "mechaduino"):
        _usage_error(f"--format {args.format} needs --step-zero DEG: the reference angle of a full step at driver "
                     "phase 0 (electrical zero), as the table is tied to the stepper's phase (0 for a model fitted "
                     "to a calibration imported from that firmware)")
    if args.step_direction is None and args.format == "klipper":
        _usage_error("--format klipper needs --step-direction 1 or -1: which way the stepper's positive full steps "
                     "(a positive FORCE_MOVE, dir_pin included) turn the reference, 1 if they raise its angle, -1 if "
                     "they lower it (1 for a model fitted to a calibration imported from Klipper)")
    if args.dtype == "int8" and (args.format == "table" or args.target == "host"):
        _usage_error("--dtype int8 is for the compact tables of --format c --target cortex-m4f or fixed; "
                     "a dense table is int16 or float32")
    if args.target == "host" and (args.nodes is not None or args.tolerance is not None or args.form != "table"
                                  or args.interpolation is not None):
        _usage_error("--nodes, --interpolation, --tolerance and --form apply to --target cortex-m4f or fixed, "
                     "not host (its C evaluates the formula in double, or --table)")
    if args.form == "formula" and (args.interpolation is not None or args.nodes is not None or args.dtype is not None
                                   or args.tolerance is not None):
        _usage_error("--interpolation, --nodes, --dtype and --tolerance are for the compact tables (--form table), "
                     "not --form formula (the series itself)")
    if args.format == "c" and args.target == "host" and not args.table and args.dtype is not None:
        _usage_error("--dtype is the storage of a table (--table, or --target cortex-m4f or fixed); the host "
                     "formula has none")
    if args.table and "constants" in args.given:
        _usage_error("--constants is the storage of the host formula's constants; --table stores a table "
                     "(--dtype)")
    if args.target != "host" and (args.table or args.constants != "auto"):
        _usage_error(f"--table and --constants apply to --target host, not {args.target}")
    if args.cost is not None and (args.nodes is not None or args.dtype is not None or args.form != "table"
                                  or args.interpolation is not None):
        _usage_error("--cost chooses the deployment; expected it without --nodes, --dtype, --interpolation "
                     "or --form")
    if args.target == "fixed" and (args.dtype == "float32" or args.form == "formula"):
        _usage_error("--target fixed computes in integers: a compact int8 or int16 table, not "
                     f"{'--dtype float32' if args.dtype == 'float32' else '--form formula'}")


def _moteus_options(args):
    """export_moteus's options: --source, --moteus-style, and the sign, offset and cpr (--sign, --offset,
    --bits, or those of source K in the --conf dump)."""
    from ..deploy.firmware.moteus import NODES, OLD_NODES, read_moteus_source_config

    options = {"source": args.source, "style": args.moteus_style,
               "sign": 1 if args.sign is None else args.sign, "offset": 0.0 if args.offset is None else args.offset}
    if args.conf is None:
        return options
    if args.sign is not None or args.offset is not None:
        args.export_parser.error("--conf reads the sign and offset of the source from the dump; expected it without "
                                 "--sign and --offset")
    device = read_moteus_source_config(args.conf, source=args.source)
    missing = [key for key in ("sign", "offset") if key not in device]
    if missing:  # fuzz5: a dump without the sign line was exported for sign 1, a mirrored table on a sign -1 source
        raise InputError(f"{args.conf}: no motor_position.sources.{args.source}.{missing[0]} line; expected the sign "
                         "and offset of the source, as 'conf enumerate' writes them (or --sign and --offset without "
                         "--conf)")
    if device["table_entries"] == OLD_NODES:
        raise InputError(f"{args.conf}: source {args.source} has a 32-entry compensation_table, firmware before "
                         f"0x0109; expected firmware 0x0109 or later ({NODES} int8 entries and a scale), which is "
                         "what encal writes: upgrade the firmware first")
    if "bits" in device:
        if args.bits is not None and args.bits != device["bits"]:
            raise InputError(f"--bits {args.bits} but {args.conf} gives source {args.source} a cpr of "
                             f"2^{device['bits']}; expected the same resolution (leave out --bits)")
        args.bits = device["bits"]
    options.update({key: device[key] for key in ("sign", "offset", "commutation_source") if key in device})
    return options
#: the exports that need the encoder resolution, and why (the others leave the code functions out, or assume one)
_NEEDS_RESOLUTION = {
    "table": "--format table has one entry per code",
    "c --table": "--format c --table looks up one entry per code",
    "tinymovr": "--format tinymovr works in ticks of the sensor (6 to 24 bits)",
}


def _outside(args, compensator):
    """The model for the export of a model calibrated over an arc: --outside's rule (issue 31, encal._core.arcs)."""
    from .._core.arcs import periodic_for_export, refuse_arc

    if compensator.model.range_deg is None:
        args.export_parser.error(f"--outside applies to a model calibrated over an arc; {args.model} covers the "
                                 "full turn")
    if args.outside is None:
        refuse_arc(compensator, f"--format {args.format}")
    model = Compensator(periodic_for_export(compensator.model, args.outside))
    model.source = compensator.source
    args.arc_range = list(compensator.model.range_deg)
    return model


def _check_resolution(args, compensator):
    """A usage error (naming --bits) for an export that needs the resolution that neither --bits nor the model gives."""
    export = "c --table" if args.format == "c" and args.table else args.format
    if export in _NEEDS_RESOLUTION and args.bits is None and compensator.encoder.get("resolution_bits") is None:
        args.export_parser.error(f"{_NEEDS_RESOLUTION[export]}, and {args.model} records no encoder resolution; "
                                 "pass --bits B")


def run(args):
    status = _export(args)
    if getattr(args, "bits_mismatch", None):  # said once the export is written, so a refusal stays one line
        import warnings

        from .._core.errors import EncalWarning

        warnings.warn(EncalWarning(args.bits_mismatch))
    return status


def _export(args):
    _check_combinations(args)
    output = Path(args.output)
    c_files = [f"{args.name}.h", f"{args.name}.c"] if args.format == "c" else []
    check_paths(inputs=[model_input(args), (getattr(args, "conf", None), "firmware")],
                outputs=[] if c_files else [("-o", output)],
                folders=[("-o", output, c_files)] if c_files else [])
    compensator = Compensator(model_or_serial(args, args.export_parser))
    if compensator.model.range_deg is not None or args.outside is not None:
        compensator = _outside(args, compensator)
    recorded = compensator.encoder.get("resolution_bits")
    if args.bits is not None and recorded is not None and args.bits != recorded:
        args.bits_mismatch = (f"--bits {args.bits} differs from the {recorded} bits {args.model} records for its "
                              f"encoder: the export maps {args.bits}-bit codes to angles, right only if the encoder "
                              f"on the device has {args.bits} bits")
    _check_resolution(args, compensator)
    if args.format in FIRMWARE:
        from ..deploy.firmware import EXPORTERS

        options = {"moteus": _moteus_options(args), "klipper": {"full_steps": args.full_steps}}.get(args.format, {})
        options["bits"] = args.bits
        if args.format == "simplefoc" and args.firmware_version is not None:
            options["firmware_version"] = args.firmware_version
        if args.format in ("klipper", "mechaduino"):
            options["step_zero_deg"] = args.step_zero
        if args.format == "klipper":
            options["step_direction"] = args.step_direction
        written = EXPORTERS[args.format](compensator, **options)
        atomic_write(output, written.text)
        if args.json:
            print_json({"format": args.format, "files": [str(output)], "bytes": output.stat().st_size,
                        "description": written.describe()})
            return 0
        print(f"wrote {output}: {written.describe()}")
        return 0
    if args.format == "table":
        table = compile_table(compensator, args.bits, dtype=args.dtype or "int16")
        save_table(table, output)
        if args.json:
            print_json({"format": "table", "files": [str(output)], "bits": int(table.bits), "dtype": table.dtype,
                        "bytes": output.stat().st_size, "quantisation_arcmin": float(table.quantisation_arcmin),
                        "between_codes_arcmin": float(table.between_codes_arcmin)})
            return 0
        print(f"wrote {output}: {table.bits}-bit {table.dtype} table, {output.stat().st_size} "
              f"bytes; deviation from the model {table.quantisation_arcmin:.3g} arcmin at the "
              f"codes, up to {table.between_codes_arcmin:.3g} arcmin more between codes")
        return 0
    if args.target == "host":
        options = {"table": (args.dtype or "int16") if args.table else None, "constants": args.constants}
        compact = {}
    else:
        options = {}
        compact = {"nodes": args.nodes, "tolerance_arcmin": args.tolerance, "form": args.form,
                   "dtype": args.dtype, "cost": args.cost, "interpolation": args.interpolation}
        chooses = (args.nodes is None and args.dtype is None and args.form == "table"
                   and args.interpolation is None)
        if chooses and args.tolerance is not None and args.cost is None:
            compact["cost"] = "operations"
    if getattr(args, "arc_range", None) is None:
        paths, summary = write_target(compensator, output, args.target, prefix=args.name, bits=args.bits,
                                      **{k: v for k, v in compact.items() if v is not None}, **options)
    else:  # issue 31: the header states the calibrated range and tests it
        from .._core.atomic import write_file_set
        from .._core.arcs import with_range_in_header
        from ..deploy.targets import export_target

        files, summary = export_target(compensator, args.target, prefix=args.name, bits=args.bits,
                                       **{k: v for k, v in compact.items() if v is not None}, **options)
        files = with_range_in_header(files, args.name, args.target, args.arc_range, args.outside,
                                     bits=args.bits if args.bits is not None else compensator.encoder.get(
                                         "resolution_bits"), reading_sign=compensator.reading_sign)
        paths = write_file_set(output, files)
    if args.json:
        print_json({"format": "c", "target": args.target, "files": [str(p) for p in paths], "prefix": args.name,
                    "bytes": sum(Path(p).stat().st_size for p in paths), "description": describe(summary)})
        return 0
    print(f"wrote {', '.join(map(str, paths))}: {describe(summary)}")
    return 0
