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
                 the firmware's own table (moteus: conf set lines; SimpleFOC:
                 calibrationLut; Klipper: the [angle] calibrate: list;
                 Mechaduino: lookup[16384]; Tinymovr: rec_table[64]); -o is
                 the file. Prints the round trip through that firmware's own
                 run-time rule against the model, on every code.
--format c --target fixed
                 int32/int16 arithmetic only: a compact integer table; angles
                 as 32-bit binary angles, codes in and out.

The encoder resolution (--bits) defaults to the one recorded in the model file.
"""

from pathlib import Path

from ..deploy import Compensator, compile_table, save_table
from .._atomic import atomic_write
from ..deploy.targets import FORMS, TARGETS, describe, write_target

FIRMWARE = ("moteus", "simplefoc", "klipper", "mechaduino", "tinymovr")
from ._common import check_paths, print_json


def add_arguments(parser):
    parser.add_argument("model", metavar="MODEL.json", help="model file written by 'encal fit'")
    parser.add_argument("--format", required=True, choices=("c", "table", *FIRMWARE),
                        help="what to write")
    parser.add_argument("-o", "--output", required=True, metavar="PATH",
                        help="table file (--format table) or folder for the C files (--format c)")
    parser.add_argument("--bits", type=int, metavar="B",
                        help="encoder resolution in bits (default: from the model file)")
    parser.add_argument("--dtype", choices=("int8", "int16", "float32"),
                        help="storage of the table's errors (dense table: int16 or float32, default int16; "
                             "compact table: default the cheapest that meets --tolerance)")
    parser.add_argument("--target", choices=TARGETS, default="host",
                        help="C: host (double), cortex-m4f (float32 only) or fixed (integers only); "
                             "default host")
    parser.add_argument("--form", choices=FORMS, default="table",
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
    parser.add_argument("--source", type=int, default=0, metavar="K",
                        help="moteus: motor_position.sources.K (default 0)")
    parser.add_argument("--full-steps", type=int, default=200, metavar="N",
                        help="klipper: full steps per turn of the stepper (default 200)")
    parser.set_defaults(export_parser=parser)
    parser.add_argument("--name", default="encal", metavar="PREFIX",
                        help="C: prefix of the file names and functions (default: encal)")
    parser.add_argument("--table", action="store_true",
                        help="C: look up a dense per-code table instead of evaluating the formula")
    parser.add_argument("--json", action="store_true",
                        help="print one JSON object naming what was written (files, bytes, table deviation)")
    parser.add_argument("--constants", choices=("auto", "float", "double"), default="auto",
                        help="C: storage of the formula's constants (default: float when it "
                             "changes the model by at most 1e-4 arcmin, else double)")


def _check_combinations(args):
    _usage_error = args.export_parser.error  # usage and one line on stderr, exit status 2
    firmware = args.format in FIRMWARE
    if firmware and (args.target != "host" or args.table or args.nodes is not None or args.dtype is not None
                     or args.tolerance is not None or args.cost is not None or args.form != "table"
                     or args.interpolation is not None):
        _usage_error(f"--format {args.format} writes that firmware's own table; --target, --table, --nodes, "
                     "--dtype, --interpolation, --tolerance, --cost and --form are for --format c")
    if args.dtype == "int8" and (args.format == "table" or args.target == "host"):
        _usage_error("--dtype int8 is for the compact tables of --format c --target cortex-m4f or fixed; "
                     "a dense table is int16 or float32")
    if args.target == "host" and (args.nodes is not None or args.tolerance is not None or args.form != "table"
                                  or args.interpolation is not None):
        _usage_error("--nodes, --interpolation, --tolerance and --form apply to --target cortex-m4f or fixed, "
                     "not host (its C evaluates the formula in double, or --table)")
    if args.interpolation is not None and args.form == "formula":
        _usage_error("--interpolation is for the compact tables (--form table), not --form formula")
    if args.target != "host" and (args.table or args.constants != "auto"):
        _usage_error(f"--table and --constants apply to --target host, not {args.target}")
    if args.cost is not None and (args.nodes is not None or args.dtype is not None or args.form != "table"
                                  or args.interpolation is not None):
        _usage_error("--cost chooses the deployment; expected it without --nodes, --dtype, --interpolation "
                     "or --form")
    if args.target == "fixed" and (args.dtype == "float32" or args.form == "formula"):
        _usage_error("--target fixed computes in integers: a compact int8 or int16 table, not "
                     f"{'--dtype float32' if args.dtype == 'float32' else '--form formula'}")


def run(args):
    _check_combinations(args)
    output = Path(args.output)
    c_files = [f"{args.name}.h", f"{args.name}.c"] if args.format == "c" else []
    check_paths(inputs=[(args.model, "model")], outputs=[] if c_files else [("-o", output)],
                folders=[("-o", output, c_files)] if c_files else [])
    compensator = Compensator(args.model)
    if args.format in FIRMWARE:
        from ..deploy.firmware import EXPORTERS

        options = {"moteus": {"source": args.source}, "klipper": {"full_steps": args.full_steps}}.get(args.format, {})
        if args.format != "klipper":
            options["bits"] = args.bits
        written = EXPORTERS[args.format](compensator, **options)
        atomic_write(output, written.text)
        if args.json:
            print_json({"format": args.format, "files": [str(output)], "bytes": output.stat().st_size,
                        "description": written.describe()})
            return 0
        print(f"wrote {output}: {written.describe()}")
        return 0
    if args.format == "table":
        if args.bits is None and compensator.encoder.get("resolution_bits") is None:
            args.export_parser.error(f"--format table has one entry per code, and {args.model} records no "
                                     "encoder resolution; pass --bits B")
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
    paths, summary = write_target(compensator, output, args.target, prefix=args.name, bits=args.bits,
                                  **{k: v for k, v in compact.items() if v is not None}, **options)
    if args.json:
        print_json({"format": "c", "target": args.target, "files": [str(p) for p in paths], "prefix": args.name,
                    "bytes": sum(Path(p).stat().st_size for p in paths), "description": describe(summary)})
        return 0
    print(f"wrote {', '.join(map(str, paths))}: {describe(summary)}")
    return 0
