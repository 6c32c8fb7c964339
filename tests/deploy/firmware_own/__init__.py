"""Harnesses that run encal's firmware exports through the firmwares' **own code**.

Each harness module here (one per firmware, beside the tests ``test_*.py`` that use it) compiles or
imports that firmware's run-time code from ``../shared/firmware/`` (beside this repository), with only
the hardware stubbed, and applies a table encal wrote to every code of an encoder. The firmware code
is a test fixture: it is read from shared/, never copied into the project.

A harness module exposes

- ``unavailable()``: ``None`` when the firmware's code (and any compiler it needs) is here, else
  the reason, one sentence, for ``pytest.skip``;
- ``matrix()``: an iterable of :class:`Row`, one per export x configuration of the issue's matrix.

``benchmarks/bench_firmware_own.py`` prints every harness's matrix for BENCHMARKS.md ("Firmware").
"""

from dataclasses import dataclass
from tests._paths import FIRMWARE


__all__ = ["FIRMWARE", "Row", "agrees"]


@dataclass(frozen=True)
class Row:
    """One export x configuration run through a firmware's own code.

    Attributes
    ----------
    firmware : str
    configuration : str
        What this row varies (bits, reversal, reference zero, version, sign, offset...).
    stated_rms, stated_max : float or None
        The round trip encal printed, arc-minutes; None when encal refused the export.
    measured_rms, measured_max : float or None
        The firmware's own code applying the written table, against the model's correction,
        arc-minutes, over every code; None when refused.
    refused : str
        encal's one-sentence refusal, or "" when a file was written.
    """

    firmware: str
    configuration: str
    stated_rms: float | None
    stated_max: float | None
    measured_rms: float | None
    measured_max: float | None
    refused: str = ""


def agrees(row, tolerance=0.05, floor_arcmin=1e-3):
    """True when encal refused, or stated and measured RMS agree within ``tolerance`` (relative).

    Below ``floor_arcmin`` both figures are rounding noise and count as equal.
    """
    if row.refused:
        return True
    if max(row.stated_rms, row.measured_rms) <= floor_arcmin:
        return True
    return abs(row.stated_rms - row.measured_rms) <= tolerance * max(row.stated_rms, row.measured_rms)
