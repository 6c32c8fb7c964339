"""Physical parameters of a simulated resolver encoder, and how they are drawn.

The distributions are those of the simulator specification
(``resolver-error-model.md`` §4.2). Every quantity is stored in internal
units: angles in radians, signal perturbations relative to the resolver's
fundamental amplitude (1 ppm = 1e-6), complex numbers for harmonics that
have an amplitude and a phase (``Im(c * exp(1j * k * theta))``).
"""

import dataclasses
from dataclasses import dataclass

import numpy as np

__all__ = [
    "RESOLUTION_BITS",
    "LSB_RAD",
    "TableParameters",
    "MountParameters",
    "ResolverParameters",
    "DecoderParameters",
    "draw_table",
    "draw_mount",
    "draw_resolver",
    "draw_decoder",
    "drift_mount",
    "drift_resolver",
]

ARCMIN = np.pi / 10800.0  # one arc-minute in radians
ARCSEC = ARCMIN / 60.0
DEGREE = np.pi / 180.0
PPM = 1e-6

RESOLUTION_BITS = 16
LSB_RAD = 2.0 * np.pi / 2**RESOLUTION_BITS

#: Highest spatial harmonic of the winding signals (the roughness floor spans 2..90).
MAX_SPATIAL_ORDER = 90

#: RMS of the balanced and unbalanced parts of the named spatial harmonics, in ppm (§4.2).
NAMED_SPATIAL_HARMONICS_PPM = {
    2: (25.0, 25.0),  # eccentricity x winding asymmetry
    3: (28.0, 16.0),  # winding distribution
    5: (14.0, 14.0),
    7: (8.0, 12.0),
    9: (6.0, 10.0),
    11: (20.0, 14.0),  # rotor slots, N_r = 12
    13: (14.0, 30.0),
    15: (90.0, 42.0),  # stator slots, N_s = 16
    17: (60.0, 12.0),
    31: (40.0, 8.0),  # 2nd stator-slot harmonic
    33: (28.0, 6.0),
    47: (30.0, 6.0),  # 3rd stator-slot harmonic
    49: (20.0, 5.0),
}
ROUGHNESS_FLOOR_PPM = 2.5

#: Orders 8k (k = 1..6) of the converter's multiplier nonlinearity.
NONLINEARITY_ORDERS = 8 * np.arange(1, 7)


@dataclass(frozen=True)
class TableParameters:
    """The rotary table that provides the reference angle.

    Attributes
    ----------
    first_harmonic, second_harmonic : complex
        Systematic error ``Im(c1 e^{j theta}) + Im(c2 e^{2j theta})``, radians.
    repeatability_rms : float
        Random error of each reading, radians RMS.
    """

    first_harmonic: complex
    second_harmonic: complex
    repeatability_rms: float


@dataclass(frozen=True)
class MountParameters:
    """How the resolver is mounted and coupled to the table.

    Attributes
    ----------
    zero_offset : float
        Encoder zero minus table zero, radians (order 0).
    eccentricity : complex
        Mount, coupling and rotor eccentricity ``Im(m1 e^{j theta})``, radians (order 1).
    tilt : complex
        Cardan error of an angularly misaligned coupling ``Im(m2 e^{2j theta})``, radians.
    """

    zero_offset: float
    eccentricity: complex
    tilt: complex


@dataclass(frozen=True, eq=False)
class ResolverParameters:
    """The resolver's signal non-idealities, relative to its fundamental amplitude.

    Attributes
    ----------
    amplitude_mismatch : float
        Transformation-ratio mismatch ``alpha = T_s / T_c - 1``.
    quadrature_error : float
        Departure of the windings from 90 degrees, radians.
    inphase_null_sin, inphase_null_cos : float
        Angle-independent coupling in phase with the carrier.
    quadrature_null_sin, quadrature_null_cos : float
        Angle-independent coupling 90 degrees out of phase with the carrier.
    phase_lead : float
        Carrier phase of the secondaries relative to the excitation, radians.
    differential_phase : float
        Carrier phase of the sin channel minus that of the cos channel, radians.
    harmonic_orders : ndarray of int, shape (m,)
        Spatial orders nu of the winding harmonics.
    positive_sequence, negative_sequence : ndarray of complex, shape (m,)
        ``P_nu`` and ``N_nu``: the envelope perturbation is
        ``sum P_nu e^{j nu theta} + N_nu e^{-j nu theta}`` (cos channel real part,
        sin channel imaginary part).
    """

    amplitude_mismatch: float
    quadrature_error: float
    inphase_null_sin: float
    inphase_null_cos: float
    quadrature_null_sin: float
    quadrature_null_cos: float
    phase_lead: float
    differential_phase: float
    harmonic_orders: np.ndarray
    positive_sequence: np.ndarray
    negative_sequence: np.ndarray


@dataclass(frozen=True, eq=False)
class DecoderParameters:
    """The resolver-to-digital converter's own systematic errors and noise.

    Attributes
    ----------
    gain_mismatch : float
        Input-channel gain mismatch ``g`` (sin gain ``1 + g/2``, cos gain ``1 - g/2``).
    offset_sin, offset_cos : float
        Offsets of the demodulated channels, relative to the signal amplitude.
    reference_phase_error : float
        Demodulation reference phase minus the resolver phase at installation, radians.
    psd_offset : float
        Offset of the phase-sensitive detector / integrator: a constant angle, radians.
    nonlinearity : ndarray of complex, shape (6,)
        Multiplier nonlinearity ``Im(kappa e^{j 8k phi})`` for k = 1..6, radians.
    noise_rms : float
        Angle noise of each reading, radians RMS.
    """

    gain_mismatch: float
    offset_sin: float
    offset_cos: float
    reference_phase_error: float
    psd_offset: float
    nonlinearity: np.ndarray
    noise_rms: float


def _complex_normal(rng, sigma, size=None):
    """Complex normal with independent N(0, sigma^2) real and imaginary parts."""
    return rng.normal(0.0, sigma, size) + 1j * rng.normal(0.0, sigma, size)


def draw_table(rng):
    """Draw a rotary table: 1" and 0.5" RMS systematic harmonics, 0.3" repeatability."""
    return TableParameters(
        first_harmonic=complex(_complex_normal(rng, 1.0 * ARCSEC / np.sqrt(2))),
        second_harmonic=complex(_complex_normal(rng, 0.5 * ARCSEC / np.sqrt(2))),
        repeatability_rms=0.3 * ARCSEC,
    )


def draw_mount(rng):
    """Draw a mounting: zero offset U(-1.3', 1.3'), eccentricity N_c(0, 0.40'), tilt from beta ~ |N(0, 0.3 deg)|."""
    zero_offset = rng.uniform(-1.3, 1.3) * ARCMIN
    eccentricity = complex(_complex_normal(rng, 0.40 * ARCMIN))
    beta = abs(rng.normal(0.0, 0.3 * DEGREE))
    tilt = beta**2 / 4.0 * np.exp(1j * rng.uniform(0.0, 2.0 * np.pi))
    return MountParameters(zero_offset, eccentricity, complex(tilt))


def _draw_spatial_harmonics(rng):
    """Positive and negative sequences of the spatial harmonics nu = 2..90 (§4.2)."""
    orders = np.arange(2, MAX_SPATIAL_ORDER + 1)
    positive = np.empty(orders.size, dtype=complex)
    negative = np.empty(orders.size, dtype=complex)
    for i, nu in enumerate(orders):
        sigma_balanced, sigma_unbalanced = NAMED_SPATIAL_HARMONICS_PPM.get(
            int(nu), (ROUGHNESS_FLOOR_PPM, ROUGHNESS_FLOOR_PPM)
        )
        balanced = _complex_normal(rng, sigma_balanced * PPM)
        unbalanced = _complex_normal(rng, sigma_unbalanced * PPM)
        # A balanced winding (cos = sin shifted by 90 deg) keeps only the sequence
        # that maps onto error order 0 mod 4; the unbalanced part takes the other.
        if nu % 4 == 3:
            positive[i], negative[i] = unbalanced, balanced
        else:
            positive[i], negative[i] = balanced, unbalanced
    return orders, positive, negative


def draw_resolver(rng):
    """Draw a resolver's fundamental-level non-idealities and spatial harmonics (§4.2)."""
    amplitude_mismatch = rng.normal(0.0, 260 * PPM)
    quadrature_error = rng.normal(0.0, 260e-6)
    inphase_null_sin, inphase_null_cos = rng.normal(0.0, 160 * PPM, 2)
    quadrature_null_sin, quadrature_null_cos = rng.normal(0.0, 1500 * PPM, 2)
    phase_lead = rng.uniform(4.0, 12.0) * DEGREE
    differential_phase = rng.normal(0.0, 0.5e-3)
    orders, positive, negative = _draw_spatial_harmonics(rng)
    return ResolverParameters(
        amplitude_mismatch=float(amplitude_mismatch),
        quadrature_error=float(quadrature_error),
        inphase_null_sin=float(inphase_null_sin),
        inphase_null_cos=float(inphase_null_cos),
        quadrature_null_sin=float(quadrature_null_sin),
        quadrature_null_cos=float(quadrature_null_cos),
        phase_lead=float(phase_lead),
        differential_phase=float(differential_phase),
        harmonic_orders=orders,
        positive_sequence=positive,
        negative_sequence=negative,
    )


def draw_decoder(rng):
    """Draw an R/D converter: gain mismatch, offsets, reference phase, PSD offset, nonlinearity (§4.2)."""
    gain_mismatch = rng.normal(0.0, 220 * PPM)
    offset_sin, offset_cos = rng.normal(0.0, 90 * PPM, 2)
    reference_phase_error = rng.normal(0.0, 3.0 * DEGREE)
    psd_offset = rng.normal(0.0, 0.10 * ARCMIN)
    k = np.arange(1, NONLINEARITY_ORDERS.size + 1)
    nonlinearity = _complex_normal(rng, 6.0 * PPM / k)
    return DecoderParameters(
        gain_mismatch=float(gain_mismatch),
        offset_sin=float(offset_sin),
        offset_cos=float(offset_cos),
        reference_phase_error=float(reference_phase_error),
        psd_offset=float(psd_offset),
        nonlinearity=nonlinearity,
        noise_rms=0.30 * LSB_RAD,
    )


def drift_mount(mount, rng):
    """The mounting one epoch later: the zero creeps by N(0, 0.04') (thermal, mechanical)."""
    return dataclasses.replace(mount, zero_offset=mount.zero_offset + rng.normal(0.0, 0.04 * ARCMIN))


def drift_resolver(resolver, rng):
    """The resolver one epoch later.

    Every coefficient is scaled by its own factor ``1 + N(0, 1 %)`` (temperature
    coefficients of winding resistance and permeability) and the phase lead
    moves by N(0, 0.5 deg), which changes the leakage through the decoder's
    fixed reference phase.
    """
    def scaled(value):
        factor = 1.0 + rng.normal(0.0, 0.01, np.shape(value))
        return value * factor if np.ndim(value) else float(value * factor)

    return dataclasses.replace(
        resolver,
        amplitude_mismatch=scaled(resolver.amplitude_mismatch),
        quadrature_error=scaled(resolver.quadrature_error),
        inphase_null_sin=scaled(resolver.inphase_null_sin),
        inphase_null_cos=scaled(resolver.inphase_null_cos),
        quadrature_null_sin=scaled(resolver.quadrature_null_sin),
        quadrature_null_cos=scaled(resolver.quadrature_null_cos),
        differential_phase=scaled(resolver.differential_phase),
        positive_sequence=scaled(resolver.positive_sequence),
        negative_sequence=scaled(resolver.negative_sequence),
        phase_lead=resolver.phase_lead + rng.normal(0.0, 0.5 * DEGREE),
    )
