"""Error statistics and harmonic analysis of one calibration.

Prints n, MAE, RMS, STD (RMS about the mean), min, max and peak-to-peak of
the error (encoder - reference) in arc-minutes (and in LSB when the
encoder's resolution is known), then the harmonic orders of largest
amplitude of the error as a function of the encoder angle.
With --json, prints one JSON object instead.
"""

import json

import numpy as np

from ..angles import lsb_arcmin, resolution_of_readings
from ..profile import error_stats, harmonics, remove_offset, zero_offset_arcmin, zero_sentence
from ._common import (activity, add_calibration_options, add_zero_options, check_paths, nonnegative_int,
                      read_calibration_from_args)

def add_arguments(parser):
    parser.add_argument("calibration", metavar="CAL.csv", help="calibration CSV file")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.add_argument("--top", metavar="N", type=nonnegative_int, default=10,
                        help="list the N harmonic orders of largest amplitude (default 10; 0 lists all)")
    add_zero_options(parser)
    add_calibration_options(parser)


def run(args):
    check_paths(inputs=[(args.calibration, "calibration")])
    with activity("profile") as progress:
        cal = read_calibration_from_args(args.calibration, args, progress)
        progress.stage("statistics")
        stats = error_stats(cal, zero=args.zero)
        offset = zero_offset_arcmin(cal.errors_arcmin)
        arbitrary = stats.offset is not None
        shape = remove_offset(cal.errors_arcmin, offset) if arbitrary else cal.errors_arcmin
        from ..fitting import calibrated_arc

        arc = calibrated_arc(cal)
        if arc is None:
            progress.stage("harmonics")
            analysis = harmonics(cal.encoder_deg, shape)
            top = analysis.as_list(args.top or None)
        else:  # harmonics are of the whole turn: over an arc they are not defined (issue 31)
            analysis, top = None, None
        note = zero_sentence(args.zero, offset, arbitrary)
        bits, inferred = cal.resolution_bits, False
        if bits is None:
            progress.stage("resolution")
            bits = resolution_of_readings(cal.encoder_deg)
            inferred = bits is not None
    if args.json:
        print(json.dumps({"name": cal.name, "resolution_bits": bits, "resolution_inferred": inferred,
                          **stats.as_dict(),
                          "zero": "arbitrary" if arbitrary else "fixed", "zero_offset_arcmin": offset,
                          "zero_note": note, "harmonics": top,
                          **({} if arc is None else {"range_deg": list(arc), "harmonics_note": _arc_note(arc)})}))
    else:
        print(_report(cal, stats, analysis, top, note, bits, inferred))
    return 0


def _report(cal, stats, analysis, top, note, bits, inferred):
    lsb = lsb_arcmin(bits) if bits is not None else None
    how = " (inferred from the readings)" if inferred else ""
    resolution = f"; {bits}-bit encoder{how}, 1 LSB = {lsb:.4f} arcmin" if bits is not None else ""
    lines = [f"{cal.name or cal.source or 'calibration'}: {stats.n} points{resolution}", note, ""]
    lines.append(f"{'statistic':<22}{'arcmin':>10}" + (f"{'LSB':>10}" if lsb else ""))
    for label, value in stats.rows():
        if label == "n":
            lines.append(f"{'n':<22}{value:>10d}")
        else:
            in_lsb = lsb and not label.startswith("zero offset")  # the offset is not the encoder's error
            lines.append(f"{label:<22}{value:>10.3f}" + (f"{value / lsb:>10.2f}" if in_lsb else ""))
    if analysis is None:
        from ..fitting import calibrated_arc

        return "\n".join(lines + ["", _arc_note(calibrated_arc(cal))])
    of_what = "the shape (zero offset removed)" if stats.offset is not None else "the error"
    lines += ["", f"largest harmonics of {of_what} vs encoder angle "
                  f"({len(top)} of orders 0..{analysis.max_order})"]
    lines.append(f"{'order':>5}{'amplitude/arcmin':>19}{'phase/deg':>12}")
    phase = np.degrees(analysis.phase_rad)
    for entry in top:
        k = entry["order"]
        lines.append(f"{k:>5d}{entry['amplitude_arcmin']:>19.3f}{phase[k]:>12.1f}")
    return "\n".join(lines)




def _arc_note(arc):
    from ..arcs import describe_range

    return (f"the calibration covers one arc, {describe_range(list(arc))}: harmonics of the shaft angle are "
            "defined over the full turn only, so none are computed (the statistics above are over the arc)")
