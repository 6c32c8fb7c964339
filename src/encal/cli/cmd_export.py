"""Export a model for firmware: a dense per-code table, or C source.

--format table   a file with a per-code correction table for a B-bit encoder
                 (80-byte header + 2^B little-endian int16 or float32 errors;
                 see docs/deployment.md); -o is the file.
--format c       PREFIX.h and PREFIX.c with PREFIX_predict_arcmin(float),
                 PREFIX_correct_deg(float) and PREFIX_correct_counts(uint32_t);
                 -o is a folder (created if missing). The model's formula is
                 evaluated in double, or, with --table, a dense table is looked up.

The encoder resolution (--bits) defaults to the one recorded in the model file.
"""

from pathlib import Path

from ..deploy import Compensator, compile_table, save_table, write_c
from ..errors import InputError

HELP = "export a model as a dense correction table or as C source for firmware"


def add_arguments(parser):
    parser.add_argument("model", metavar="MODEL.json", help="model file written by 'encal fit'")
    parser.add_argument("--format", required=True, choices=("c", "table"),
                        help="what to write")
    parser.add_argument("-o", "--output", required=True, metavar="PATH",
                        help="table file (--format table) or folder for the C files (--format c)")
    parser.add_argument("--bits", type=int, metavar="B",
                        help="encoder resolution in bits (default: from the model file)")
    parser.add_argument("--dtype", choices=("int16", "float32"), default="int16",
                        help="storage of the table's errors (default: int16)")
    parser.add_argument("--name", default="encal", metavar="PREFIX",
                        help="C: prefix of the file names and functions (default: encal)")
    parser.add_argument("--table", action="store_true",
                        help="C: look up a dense per-code table instead of evaluating the formula")
    parser.add_argument("--constants", choices=("auto", "float", "double"), default="auto",
                        help="C: storage of the formula's constants (default: float when it "
                             "changes the model by at most 1e-4 arcmin, else double)")


def run(args):
    output = Path(args.output)
    if output.exists() and output.resolve() == Path(args.model).resolve():
        raise InputError(f"-o {output} is the model file being exported; expected a different output path "
                         "(the export would overwrite the model)")
    if args.format == "c":
        model = Path(args.model).resolve()
        for written in (output / f"{args.name}.h", output / f"{args.name}.c"):
            if written.exists() and written.resolve() == model:
                raise InputError(f"-o {output} would write {written}, the model file being exported; expected "
                                 "a different folder or --name (the export would overwrite the model)")
    compensator = Compensator(args.model)
    if args.format == "table":
        table = compile_table(compensator, args.bits, dtype=args.dtype)
        save_table(table, output)
        print(f"wrote {output}: {table.bits}-bit {table.dtype} table, {output.stat().st_size} "
              f"bytes; deviation from the model {table.quantisation_arcmin:.3g} arcmin at the "
              f"codes, up to {table.between_codes_arcmin:.3g} arcmin more between codes")
        return 0
    paths = write_c(compensator, output, prefix=args.name, bits=args.bits,
                    table=args.dtype if args.table else None, constants=args.constants)
    print(f"wrote {', '.join(map(str, paths))}")
    return 0
