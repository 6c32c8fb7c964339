"""The sweep log CSV: the commanded electrical angle and the encoder reading, for controllers other than moteus."""

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError
from ._logfile import read_columns

__all__ = ["SweepLog", "read_sweep_log"]


@dataclass(frozen=True)
class SweepLog:
    """An open-loop sweep: commanded electrical angle (electrical degrees), reading (degrees), +1 up / -1 down."""

    phase_deg_e: np.ndarray
    encoder_deg: np.ndarray
    travel: np.ndarray
    source: str = ""


def read_sweep_log(path, *, phase_column="electrical_deg", encoder_column="encoder_deg", phase_unit="deg",
                   encoder_unit="deg"):
    """Read a sweep log: columns ``electrical_deg`` and ``encoder_deg``, optionally ``direction`` (+1 / -1).

    ``phase_column`` and ``encoder_column`` name the commanded electrical angle and the encoder column where
    they are called otherwise (a header name, any case, or a column number from 1); ``phase_unit`` and
    ``encoder_unit`` give their units (deg, rad, rev or counts:B; the phase in electrical turns for rev).

    The rows are in the order of the sweep. Without ``direction``, each sample's direction is the sign of
    the commanded angle's step to it (the first sample takes the second's).

    Raises
    ------
    InputError
        As :func:`~encal.selfcal.spin_log.read_spin_log` does, and for a direction other than +1 or -1.
    """
    columns = read_columns(path, (("electrical_deg", "electrical degrees"), ("encoder_deg", "degrees")),
                           optional=(("direction", "+1 or -1"),),
                           what="sweep log (or a moteus capture beginning with 'CAL start')",
                           columns={"electrical_deg": phase_column, "encoder_deg": encoder_column},
                           units={"electrical_deg": phase_unit, "encoder_deg": encoder_unit})
    phase, reading = columns["electrical_deg"], columns["encoder_deg"]
    if "direction" in columns:
        travel = columns["direction"]
        bad = np.flatnonzero(~np.isin(travel, (1, -1)))
        if bad.size:
            raise InputError(f"{path}: data row {bad[0] + 1} has direction {travel[bad[0]]:g}, expected +1 or -1")
    else:
        step = np.sign(np.diff(phase))
        travel = np.concatenate([step[:1], step]) if step.size else np.ones(phase.size)
        travel[travel == 0] = 1
    return SweepLog(phase, reading, travel.astype(int), str(Path(path)))
