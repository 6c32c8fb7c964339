"""Calibration data: encoder readings against a reference, and its CSV form."""

from dataclasses import dataclass, field

import numpy as np

from .angles import ARCMIN_PER_DEG, wrap180, wrap360
from .errors import CalibrationError

__all__ = ["Calibration", "read_calibration", "write_calibration"]


@dataclass(frozen=True, eq=False)
class Calibration:
    """One calibration run of one encoder.

    Parameters
    ----------
    reference_deg : array-like of shape (n,)
        Reference (true) angles in degrees; wrapped to [0, 360).
    encoder_deg : array-like of shape (n,)
        Encoder readings in degrees; wrapped to [0, 360).
    direction : array-like of shape (n,) of {+1, -1}, optional
        Direction of travel at each point, for bidirectional runs.
    epoch : array-like of shape (n,) of str, optional
        Label of the calibration run each point belongs to.
    name : str, default=''
        Encoder name.
    resolution_bits : int, optional
        Encoder resolution in bits, if known.
    source : str, optional
        File the calibration was read from.
    """

    reference_deg: np.ndarray
    encoder_deg: np.ndarray
    direction: np.ndarray | None = None
    epoch: np.ndarray | None = None
    name: str = ""
    resolution_bits: int | None = None
    source: str | None = None
    metadata: dict = field(default_factory=dict)

    def __post_init__(self):
        ref = np.asarray(self.reference_deg, dtype=float).reshape(-1)
        enc = np.asarray(self.encoder_deg, dtype=float).reshape(-1)
        if ref.shape != enc.shape:
            raise CalibrationError(
                f"reference_deg has {ref.size} values but encoder_deg has {enc.size}; "
                "expected one reading per reference angle"
            )
        if not (np.all(np.isfinite(ref)) and np.all(np.isfinite(enc))):
            raise CalibrationError("calibration angles must be finite numbers (found NaN or infinity)")
        object.__setattr__(self, "reference_deg", wrap360(ref).reshape(-1))
        object.__setattr__(self, "encoder_deg", wrap360(enc).reshape(-1))
        if self.direction is not None:
            direction = np.asarray(self.direction, dtype=np.int8).reshape(-1)
            if direction.shape != ref.shape or not np.all(np.isin(direction, (-1, 1))):
                raise CalibrationError("direction must hold +1 or -1 for every point")
            object.__setattr__(self, "direction", direction)
        if self.epoch is not None:
            epoch = np.asarray(self.epoch, dtype=str).reshape(-1)
            if epoch.shape != ref.shape:
                raise CalibrationError("epoch must hold one label for every point")
            object.__setattr__(self, "epoch", epoch)

    def __len__(self):
        return self.reference_deg.size

    @property
    def errors_arcmin(self):
        """Error ``encoder - reference`` of every point, in arc-minutes, wrapped to (-10800, 10800]."""
        return wrap180(self.encoder_deg - self.reference_deg) * ARCMIN_PER_DEG

    def subset(self, index):
        """A calibration holding only the points selected by ``index`` (mask or indices)."""
        pick = lambda a: None if a is None else a[index]  # noqa: E731
        return Calibration(
            self.reference_deg[index],
            self.encoder_deg[index],
            direction=pick(self.direction),
            epoch=pick(self.epoch),
            name=self.name,
            resolution_bits=self.resolution_bits,
            source=self.source,
            metadata=dict(self.metadata),
        )
