"""Error statistics and harmonic analysis of one calibration.

Prints n, MAE, RMS, STD (RMS about the mean), min, max and peak-to-peak of
the error (encoder - reference) in arc-minutes (and in LSB when the
encoder's resolution is known), then the harmonic orders of largest
amplitude of the error as a function of the encoder angle.
A calibration with readings in both directions of travel (a direction column) also gets the ISO 230-2
values of its axis (reversal, systematic deviation, repeatability, accuracy), as encal report gives them:
the statistics pool both directions.
With --json, prints one JSON object instead.
"""

import json

import numpy as np

from .._core.angles import lsb_arcmin, resolution_of_readings
from ..analysis.profile import error_stats, harmonics, remove_offset, zero_offset_arcmin, zero_sentence
from ._common import (activity, add_calibration_options, add_target_tolerance_option, add_zero_options, check_paths,
                      nonnegative_int, read_calibration_from_args)


def add_arguments(parser):
    parser.add_argument("calibration", metavar="CAL.csv", help="calibration CSV file")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.add_argument("--top", metavar="N", type=nonnegative_int, default=10,
                        help="list the N harmonic orders of largest amplitude (default 10; 0 lists all)")
    add_zero_options(parser)
    add_target_tolerance_option(parser)
    add_calibration_options(parser)


def run(args):
    check_paths(inputs=[(args.calibration, "calibration")])
    with activity("profile") as progress:
        cal = read_calibration_from_args(args.calibration, args, progress, targets=True)
        progress.stage("statistics")
        stats = error_stats(cal, zero=args.zero)
        offset = zero_offset_arcmin(cal.errors_arcmin)
        arbitrary = stats.offset is not None
        shape = remove_offset(cal.errors_arcmin, offset) if arbitrary else cal.errors_arcmin
        from ..models.fitting import calibrated_arc

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
        axis = _iso230_2(cal, bits, progress)
    if args.json:
        print(json.dumps({"name": cal.name, "resolution_bits": bits, "resolution_inferred": inferred,
                          **stats.as_dict(),
                          "zero": "arbitrary" if arbitrary else "fixed", "zero_offset_arcmin": offset,
                          "zero_note": note, "harmonics": top,
                          **({} if arc is None else {"range_deg": list(arc), "harmonics_note": _arc_note(arc)}),
                          **_iso_json(axis)}))
    else:
        print(_report(cal, stats, analysis, top, note, bits, inferred))
        if isinstance(axis, str):
            print(f"\nISO 230-2: none ({axis})")
        elif axis is not None:
            print("\n" + _iso_text(axis))
    return 0


def _iso230_2(cal, bits, progress):
    """The ISO 230-2 analysis of a calibration with both directions of travel, its reason when none of its
    reference angles is a target approached both ways (a log of continuous angles), else None. With a
    ``--target-tolerance`` the user asked for targets: a tolerance that matches none is refused, as by
    ``encal report``."""
    from dataclasses import replace

    from .._core.errors import CalibrationError
    from ..data.reversal import has_both_directions, reversal

    if not has_both_directions(cal):
        return None
    progress.stage("ISO 230-2")
    try:
        analysis = reversal(cal)
    except CalibrationError as exc:
        if cal.target_tolerance_deg is not None:
            raise
        return str(exc)
    return analysis if bits is None or analysis.resolution_bits is not None else replace(analysis, resolution_bits=bits)


def _iso_json(axis):
    if axis is None:
        return {}
    if isinstance(axis, str):
        return {"iso230_2": None, "iso230_2_note": axis}
    return {"iso230_2": {**axis.as_dict(), "caption": axis.caption(), "targets": axis.per_target()}}


#: The ISO 230-2 values printed, with their symbols.
_ISO_ROWS = (("reversal value B", "reversal_value"), ("mean reversal value B̄", "mean_reversal_value"),
             ("systematic deviation E↑", "systematic_deviation_forward"),
             ("systematic deviation E↓", "systematic_deviation_reverse"),
             ("systematic deviation E", "systematic_deviation"),
             ("mean bidirectional deviation M", "mean_bidirectional_deviation"),
             ("repeatability R↑", "repeatability_forward"), ("repeatability R↓", "repeatability_reverse"),
             ("repeatability R", "repeatability"), ("accuracy A↑", "accuracy_forward"),
             ("accuracy A↓", "accuracy_reverse"), ("accuracy A", "accuracy"))


def _iso_text(analysis):
    lsb = lsb_arcmin(analysis.resolution_bits) if analysis.resolution_bits is not None else None
    # arc-seconds too: ISO 230-2 states a rotary axis' values in them, and 0.01 arcsec is finer than 0.001 arcmin
    from ..data.reversal import DEVIATION_SIGN_NOTE

    lines = [f"ISO 230-2, both directions of travel (the statistics above pool them): {analysis.caption()}",
             f"({DEVIATION_SIGN_NOTE})", f"{'value':<32}{'arcmin':>10}{'arcsec':>10}" + (f"{'LSB':>10}" if lsb else "")]
    for label, name in _ISO_ROWS:
        value = getattr(analysis, name)
        label = label.ljust(32 + label.count("\u0304"))  # a combining bar takes no column of its own
        if value is None:  # repeatability and accuracy need two approaches each way at every target
            lines.append(f"{label}{'-':>10}   (needs 2 approaches each way at every target)")
        else:
            lines.append(f"{label}{value:>10.3f}{value * 60.0:>10.2f}" + (f"{value / lsb:>10.2f}" if lsb else ""))
    return "\n".join(lines)


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
        from ..models.fitting import calibrated_arc

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
    from .._core.arcs import describe_range

    return (f"the calibration covers one arc, {describe_range(list(arc))}: harmonics of the shaft angle are "
            "defined over the full turn only, so none are computed (the statistics above are over the arc)")
