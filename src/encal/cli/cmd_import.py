"""Read a firmware's calibration output or correction table into encal.

  encal import moteus-compare FILE -o CAL.csv     utils/compare_encoders.py -o output (revolutions)
  encal import moteus-cal FILE -o CAL.csv         a raw 'CAL start' ... 'CAL done' capture [--pole-pairs P]
  encal import klipper FILE -o CAL.csv            a calibrate list: the option, an [angle] section, or
                                                  printer.cfg's #*# SAVE_CONFIG block (one angle per full step)
  encal import mechaduino FILE -o CAL.csv         a lookup[16384] table (every count against its angle)
  encal import simplefoc FILE -o MODEL.json       a calibrationLut[] [--firmware-version 1.0.8|1.0.9|uint16]
  encal import tinymovr FILE -o MODEL.json --bits B   a rec_table[64] (native ticks of the B-bit sensor)
  encal import moteus FILE -o MODEL.json          compensation_table lines (an existing correction) [--source K]

Calibrations can be fitted, profiled and compared; an existing correction becomes a
model file that 'encal evaluate' scores on a calibration, beside encal's own models.
"""

from ._common import check_paths, int_in_range

CALIBRATIONS = ("moteus-compare", "moteus-cal", "klipper", "mechaduino")
CORRECTIONS = ("moteus", "simplefoc", "tinymovr")


def add_arguments(parser):
    parser.add_argument("kind", choices=CALIBRATIONS + CORRECTIONS, help="what the file is")
    parser.add_argument("input", metavar="FILE", help="the firmware's file")
    parser.add_argument("-o", "--output", required=True, metavar="PATH",
                        help="calibration CSV (calibrations) or model file (corrections) to write")
    parser.add_argument("--pole-pairs", type=int_in_range(1), metavar="P",
                        help="moteus-cal: motor pole pairs (default: from the capture)")
    parser.add_argument("--source", type=int_in_range(0, 2), metavar="K",
                        help="moteus: the table of motor_position.sources.K (required when the file holds several)")
    parser.add_argument("--bits", type=int_in_range(6, 24), metavar="B",
                        help="tinymovr: sensor resolution in bits")
    parser.add_argument("--firmware-version", choices=("1.0.8", "1.0.9", "uint16"), metavar="V",
                        help="simplefoc: the Arduino-FOC-drivers version whose table it is (1.0.8 adds it, 1.0.9 "
                             "and uint16 subtract it); default what the file says, else refused")
    parser.set_defaults(import_parser=parser)


def run(args):
    from ..data.calibration import Calibration, write_calibration
    from ..deploy import firmware

    if args.kind == "tinymovr" and args.bits is None:
        args.import_parser.error("tinymovr tables are in ticks: --bits is required")
    if args.firmware_version is not None and args.kind != "simplefoc":
        args.import_parser.error(f"--firmware-version is for simplefoc tables, not {args.kind}")
    check_paths(inputs=[(args.input, "capture" if args.kind == "moteus-cal" else "firmware")],
                outputs=[("-o", args.output)])
    readers = {"moteus-compare": firmware.read_compare_encoders, "klipper": firmware.read_klipper,
               "mechaduino": firmware.read_mechaduino,
               "moteus-cal": lambda path: firmware.read_cal_capture(path, pole_pairs=args.pole_pairs),
               "simplefoc": lambda path: firmware.read_simplefoc(path, firmware_version=args.firmware_version),
               "moteus": lambda path: firmware.read_moteus_conf(path, source=args.source),
               "tinymovr": lambda path: firmware.read_tinymovr(path, bits=args.bits)}
    result = readers[args.kind](args.input)
    if args.kind in CALIBRATIONS:
        comments = [f"read by encal import {args.kind} from {args.input}"]
        reverse = ""
        if result.reading_sign == -1:  # the raw readings, to be read back with --reverse (a CSV holds no sign)
            result = Calibration(result.reference_deg, -result.encoder_deg, name=result.name,
                                 resolution_bits=result.resolution_bits, metadata=result.metadata)
            comments.append("the encoder counts against the reference: read this file with --reverse")
            reverse = "; the encoder counts against the reference: fit it with --reverse"
        write_calibration(args.output, result, comments=comments)
        print(f"wrote {args.output}: {len(result)} points{reverse}")
    else:
        result.save(args.output)
        # The firmwares' tables hold no zero offset (their own calibrations leave it out, and so does encal's
        # export): scored at a fixed zero, the reference's constant counted as error and a good table as harmful.
        print(f"wrote {args.output}: the {args.kind} correction as a model file (kind {result.kind}); the table holds "
              f"no zero offset, so score it about its own zero: encal evaluate {args.output} CAL.csv --zero arbitrary")
    return 0
