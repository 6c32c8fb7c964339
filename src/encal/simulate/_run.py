"""One simulated calibration run, with the noise-free truth at the same points."""

from dataclasses import dataclass

import numpy as np

from .._core.angles import ARCMIN_PER_DEG, wrap180, wrap360
from ..data.calibration import Calibration
from .._core.errors import InputError
from ._parameters import LSB_RAD, RESOLUTION_BITS
from ._signal import approach_directions, converter_angle, hysteresis_codes

__all__ = ["TRAINING_GRID_DEG", "TEST_GRID_DEG", "SimulatedRun", "calibration_run", "measurement_floor"]

#: The paper's training grid, 0, 2, ..., 358 degrees.
TRAINING_GRID_DEG = np.arange(0.0, 360.0, 2.0)
#: The paper's test grid, 1, 3, ..., 359 degrees.
TEST_GRID_DEG = np.arange(1.0, 360.0, 2.0)
TRAINING_GRID_DEG.flags.writeable = False
TEST_GRID_DEG.flags.writeable = False


@dataclass(frozen=True, eq=False)
class SimulatedRun:
    """A simulated calibration and the systematic error it measures.

    Attributes
    ----------
    calibration : Calibration
        What a user would record: table angle (``reference_deg``) and the
        16-bit encoder reading (``encoder_deg``), in visiting order.
    noise_free_error_arcmin : ndarray of shape (n,)
        The error the same encoder, epoch and decoder would show at the same
        points with no per-reading randomness (table repeatability and signal
        noise zero) and with quantisation replaced by its mean effect, a
        shift of half an LSB against the direction of travel. Arc-minutes.
    epoch : int
        Epoch index of the run (0 is the first calibration).
    decoder : int
        Decoder index of the run (0 is the original converter).
    """

    calibration: Calibration
    noise_free_error_arcmin: np.ndarray
    epoch: int
    decoder: int

    @property
    def name(self):
        """Encoder name."""
        return self.calibration.name

    @property
    def errors_arcmin(self):
        """Measured error ``encoder - reference`` at every point, arc-minutes."""
        return self.calibration.errors_arcmin


def _angle_list(angles_deg):
    angles = np.asarray(angles_deg, dtype=float)
    if angles.ndim != 1 or angles.size == 0 or not np.all(np.isfinite(angles)):
        raise InputError(
            "calibration_run expects a non-empty 1-D list of finite angles in degrees; "
            f"got an array of shape {angles.shape}"
            + ("" if np.all(np.isfinite(angles)) else " holding NaN or infinity")
        )
    return wrap360(angles)


def calibration_run(encoder, angles_deg, epoch=0, decoder=0, rng=None, label=None):
    """Simulate one calibration of ``encoder`` on the rotary table.

    The table visits ``angles_deg`` in the given order (each step the short
    way round) and the decoder's 16-bit register is read at rest at each one
    (spec §4.1, steps 1-8).

    Parameters
    ----------
    encoder : SimulatedEncoder
        The encoder to calibrate.
    angles_deg : array-like of shape (n,)
        Table angles in degrees, in visiting order.
    epoch : int, default=0
        Epoch index; each later epoch adds one drift of the mount and resolver.
    decoder : int, default=0
        Decoder index; ``d > 0`` reads the same resolver with another converter.
    rng : numpy.random.Generator, int or None, default=None
        Source of the per-reading randomness (table repeatability, signal noise).
    label : str, optional
        Epoch label stored in the calibration; default ``'epoch<epoch+1>'``,
        with ``'-decoder<decoder+1>'`` appended for another decoder.

    Returns
    -------
    SimulatedRun

    Examples
    --------
    >>> from encal.simulate import draw_encoder
    >>> run = calibration_run(draw_encoder(3), TRAINING_GRID_DEG, rng=0)
    >>> len(run.calibration), run.calibration.resolution_bits
    (180, 16)
    """
    angles = _angle_list(angles_deg)
    state = encoder.state(epoch, decoder)
    if label is None:
        label = f"epoch{epoch + 1}" + (f"-decoder{decoder + 1}" if decoder else "")
    command = np.deg2rad(angles)
    directions = approach_directions(command)

    measured = converter_angle(state, command, np.random.default_rng(rng))
    codes = hysteresis_codes(measured, directions[0])
    encoder_deg = codes * (360.0 / 2**RESOLUTION_BITS)

    mean_reading = converter_angle(state, command, None) - 0.5 * LSB_RAD * directions
    noise_free = wrap180(np.rad2deg(mean_reading) - angles) * ARCMIN_PER_DEG

    calibration = Calibration(
        reference_deg=angles,
        encoder_deg=encoder_deg,
        epoch=np.full(angles.size, str(label)),
        name=encoder.name,
        resolution_bits=RESOLUTION_BITS,
        metadata={"simulated": True, "epoch_index": int(epoch), "decoder_index": int(decoder)},
    )
    return SimulatedRun(calibration, noise_free, int(epoch), int(decoder))


def measurement_floor(run):
    """RMS of the measured minus the noise-free error of a run, arc-minutes.

    This is the part of the run's error that no function of the angle can
    predict: table repeatability, signal noise, and the quantisation's
    departure from its mean effect. A model that predicted the noise-free
    error exactly would leave this RMS on the run, so it is the best RMS any
    model can reach on data it was not fitted to (a model fitted to the run
    itself can go lower only by fitting its noise). About 0.14' for the
    specification's noise: sqrt(0.30**2 + 1/12) LSB.

    Parameters
    ----------
    run : SimulatedRun

    Returns
    -------
    float
        Arc-minutes.
    """
    if not isinstance(run, SimulatedRun):
        raise InputError(f"The 'run' parameter of measurement_floor must be a SimulatedRun (from encal.simulate_fleet "
                         f"or demo_fleet: it needs the noise-free error). Got {type(run).__name__} instead.")
    difference = wrap180((run.errors_arcmin - run.noise_free_error_arcmin) / ARCMIN_PER_DEG)
    return float(np.sqrt(np.mean(np.square(difference * ARCMIN_PER_DEG))))
