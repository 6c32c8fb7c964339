"""A simulated magnetic encoder (AS5047 class): eccentricity, 2nd-4th harmonics, noise, quantisation."""

from dataclasses import dataclass

import numpy as np

from ..._core.angles import ARCMIN_PER_DEG, wrap180, wrap360

__all__ = ["MagneticEncoder", "draw_magnetic_encoder"]


@dataclass(frozen=True)
class MagneticEncoder:
    """A magnetic encoder whose error is a function of the magnet's angle.

    The magnet sits at ``rotor + turn_deg``; the encoder reads
    ``magnet + error(magnet)/60 + noise``, rounded to ``2**bits`` counts per turn.

    Parameters
    ----------
    harmonics : tuple of (int, float, float)
        ``(order, amplitude_arcmin, phase_rad)``: ``error(m) = sum A cos(k m + phase)``. Order 1 is the
        eccentricity error (magnet off the sensor's axis), orders 2-4 the field's distortion.
    noise_arcmin : float, default=2.0
        RMS of the reading noise (white), arc-minutes.
    bits : int or None, default=14
        Resolution; None reads the exact angle.
    turn_deg : float, default=0.0
        Angle of the magnet on the rotor, degrees (turning the magnet changes it).
    """

    harmonics: tuple
    noise_arcmin: float = 2.0
    bits: int | None = 14
    turn_deg: float = 0.0

    def error_at_magnet(self, magnet_deg):
        """Error in arc-minutes as a function of the magnet angle (degrees)."""
        magnet = np.radians(np.asarray(magnet_deg, dtype=float))
        total = np.zeros(magnet.shape)
        for order, amplitude, phase in self.harmonics:
            total = total + amplitude * np.cos(order * magnet + phase)
        return total

    def error_at_reading(self, reading_deg):
        """The true error ``reading - magnet`` in arc-minutes as a function of the noise-free reading (degrees).

        This is what a calibration measures and a model predicts: the error as a function of the reading.
        """
        reading = np.asarray(reading_deg, dtype=float)
        magnet = reading.copy()
        for _ in range(60):  # fixed point of magnet = reading - error(magnet)/60; contracts fast
            magnet = reading - self.error_at_magnet(magnet) / ARCMIN_PER_DEG
        return wrap180(reading - magnet) * ARCMIN_PER_DEG

    def read(self, rotor_deg, rng=None):
        """Readings in degrees [0, 360) at rotor angles ``rotor_deg`` (noise from ``rng``)."""
        magnet = np.asarray(rotor_deg, dtype=float) + self.turn_deg
        reading = magnet + self.error_at_magnet(magnet) / ARCMIN_PER_DEG
        if self.noise_arcmin > 0:
            rng = np.random.default_rng(rng)
            reading = reading + rng.normal(0.0, self.noise_arcmin / ARCMIN_PER_DEG, reading.shape)
        return wrap360(self.quantise(reading))

    def quantise(self, angle_deg):
        """``angle_deg`` rounded to whole counts (unchanged when ``bits`` is None)."""
        if self.bits is None:
            return np.asarray(angle_deg, dtype=float)
        counts = 2.0 ** self.bits
        return np.round(np.asarray(angle_deg, dtype=float) * counts / 360.0) * (360.0 / counts)

    def turned(self, turn_deg):
        """The same encoder with its magnet turned to ``turn_deg`` on the rotor."""
        return MagneticEncoder(self.harmonics, self.noise_arcmin, self.bits, turn_deg)


def draw_magnetic_encoder(rng=None, eccentricity_deg=1.0, noise_arcmin=2.0, bits=14):
    """A random AS5047-class encoder.

    Order 1 has amplitude ``eccentricity_deg`` (in degrees), orders 2, 3 and 4 have 15-30 %, 3-8 % and
    5-15 % of it, orders 5-8 under 2 %; phases are uniform.

    Parameters
    ----------
    rng : int or numpy.random.Generator, optional
    eccentricity_deg : float, default=1.0
        Amplitude of the first harmonic, degrees.
    noise_arcmin : float, default=2.0
        Reading noise RMS, arc-minutes.
    bits : int or None, default=14

    Returns
    -------
    MagneticEncoder
    """
    rng = np.random.default_rng(rng)
    first = eccentricity_deg * ARCMIN_PER_DEG
    shares = {1: (1.0, 1.0), 2: (0.15, 0.30), 3: (0.03, 0.08), 4: (0.05, 0.15),
              5: (0.0, 0.02), 6: (0.0, 0.02), 7: (0.0, 0.02), 8: (0.0, 0.02)}
    harmonics = tuple((order, float(first * rng.uniform(low, high)), float(rng.uniform(0, 2 * np.pi)))
                      for order, (low, high) in shares.items())
    return MagneticEncoder(harmonics, noise_arcmin=noise_arcmin, bits=bits)
