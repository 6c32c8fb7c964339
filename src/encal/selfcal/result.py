"""The result of a self-calibration: the recovered error, its uncertainty, and what was not separable."""

from dataclasses import dataclass, field

import numpy as np

from .._core.angles import ARCMIN_PER_DEG
from ..data.calibration import READING_NOISE_KEY, Calibration

__all__ = ["SelfCalibration"]

#: Points of the calibration grid written by default (every degree of the encoder reading).
DEFAULT_POINTS = 360


@dataclass(frozen=True)
class SelfCalibration:
    """An encoder error profile recovered without a precision reference.

    Attributes
    ----------
    method : {'spin', 'sweep', 'steps'}
        How the reference was made.
    series : HarmonicSeries
        The recovered error as a Fourier series of the encoder reading, arc-minutes, with the covariance
        of its coefficients. The constant is not part of it: without a reference the zero is arbitrary.
    removed_orders : tuple of int
        Orders the method cannot separate from the reference's own error and left out of ``series``.
    confounded : str
        One paragraph saying what the method cannot separate.
    details : dict
        Method-specific findings (speeds and speed ripple, lag, turn angle, the stepper's error, ...).
    name : str
        Name of the encoder (the input's stem).
    reading_sign : {1, -1}
        -1 when the input counted against its reference and was read negated (``--reverse``): ``series`` is
        then a function of the negated reading, and :meth:`write` writes the readings as the encoder gave them,
        to be fitted with ``--reverse`` like the input.
    reading_noise_arcmin : float or None
        The standard deviation of one reading about the recovered profile, arc-minutes, measured from the log
        where the method can (``spin``: the readings' scatter about each run's fit; ``sweep``: the readings it
        repeats at one commanded angle in one direction, :func:`~encal.selfcal.sweep.repeat_noise_arcmin`); None
        where it cannot (a sweep that commands no angle twice in one direction; ``steps``, whose points are the
        firmware's means of several reads). It is not part of ``sigma_arcmin`` (the profile's uncertainty): a new
        reading adds it.
    """

    method: str
    series: object
    removed_orders: tuple = ()
    confounded: str = ""
    details: dict = field(default_factory=dict)
    name: str = ""
    reading_sign: int = 1
    reading_noise_arcmin: float | None = None

    def error_arcmin(self, encoder_deg):
        """The recovered error in arc-minutes at encoder readings ``encoder_deg`` (degrees)."""
        return self.series.evaluate(encoder_deg)

    def sigma_arcmin(self, encoder_deg):
        """Standard uncertainty (one sigma) of :meth:`error_arcmin` in arc-minutes."""
        return self.series.sigma(encoder_deg)

    def grid(self, points=DEFAULT_POINTS):
        """Encoder readings ``0, 360/points, ...`` in degrees."""
        return np.arange(points) * (360.0 / points)

    def calibration(self, points=DEFAULT_POINTS):
        """The recovered error as a :class:`~encal.data.calibration.Calibration` on a uniform grid of readings.

        ``reference_deg = encoder_deg - error/60``, so a model fitted to it (``encal fit``) predicts the
        recovered error; its zero offset is zero.
        """
        encoder = self.grid(points)
        reference = encoder - self.error_arcmin(encoder) / ARCMIN_PER_DEG
        metadata = {"selfcal": self.method, "removed_orders": list(self.removed_orders)}
        if self.reading_noise_arcmin is not None:
            metadata[READING_NOISE_KEY] = float(self.reading_noise_arcmin)
        return Calibration(reference, encoder, name=self.name, reading_sign=self.reading_sign, metadata=metadata,
                           reference_std_arcmin=self.sigma_arcmin(encoder))

    def write(self, path, points=DEFAULT_POINTS, resolution_bits=None):
        """Write the calibration CSV (atomically) with the columns ``error_arcmin`` and ``sigma_arcmin``.

        The comment lines say the method, the orders left out and what could not be separated.
        """
        from ..data.calibration import write_calibration

        cal = self.calibration(points)
        encoder = cal.encoder_deg
        comments = [f"encal selfcal {self.method}: encoder error recovered without a precision reference",
                    "error_arcmin = encoder - reference; sigma_arcmin = its standard uncertainty (1 sigma)"]
        if self.reading_noise_arcmin is not None:
            # read back by read_calibration into the metadata: encal fit takes it as a new reading's noise
            comments.append(f"{READING_NOISE_KEY}: {self.reading_noise_arcmin:.6g}")
        if self.reading_sign == -1:
            # The series is of the negated reading (the input was read with --reverse). Written as it stands, a
            # plain `encal fit` took the negated grid for raw readings: the table corrected the mirrored angle
            # with the wrong sign (6.8 arcmin RMS made 12.4). The raw readings are written instead, so the file
            # reads back only with --reverse, as its input did.
            comments.append("the encoder counts against the reference: encoder_deg holds its readings as it gave "
                            "them; fit with --reverse (error_arcmin is of the negated reading, as --reverse reads it)")
        cal = Calibration(cal.reference_deg, np.mod(self.reading_sign * encoder, 360.0), name=cal.name,
                          resolution_bits=resolution_bits)
        if "step_zero_deg" in self.details:
            comments.append(_step_zero_text(self.details["step_zero_deg"]))
        if self.removed_orders:
            comments.append("orders left out (not separable): " + _orders_text(self.removed_orders))
        comments += [f"not separable: {line}" for line in _wrap(self.confounded)]
        write_calibration(path, cal, comments=comments, extra_columns={
            "error_arcmin": [float(v) for v in self.error_arcmin(encoder)],
            "sigma_arcmin": [float(v) for v in self.sigma_arcmin(encoder)],
        })

    def plot(self, ax=None, truth_arcmin=None):
        """Plot the recovered error with its +-2 sigma band against the reading; returns the axes.

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Axes to draw on; new ones by default.
        truth_arcmin : callable, optional
            The true error (arcmin) as a function of the reading (degrees), drawn for comparison.
        """
        if ax is None:
            import matplotlib.pyplot as plt

            ax = plt.figure(figsize=(7, 3.5)).add_subplot()
        grid = self.grid(720)
        error, sigma = self.error_arcmin(grid), self.sigma_arcmin(grid)
        ax.fill_between(grid, error - 2 * sigma, error + 2 * sigma, alpha=0.3, label="±2σ")
        ax.plot(grid, error, label=f"recovered ({self.method})")
        if truth_arcmin is not None:
            truth = np.asarray(truth_arcmin(grid), dtype=float)
            ax.plot(grid, truth - truth.mean(), "--", label="true")
        ax.set_xlabel("encoder reading / deg")
        ax.set_ylabel("error / arcmin")
        ax.set_xlim(0, 360)
        ax.legend(loc="best")
        return ax

    def summary(self, top=8):
        """A few lines of text: the largest recovered harmonics with +-2 sigma, what is not separable."""
        grid = self.grid()
        error = self.error_arcmin(grid)
        sigma = self.sigma_arcmin(grid)
        lines = [f"{self.name or 'encoder'}: self-calibration by {self.method}; recovered error RMS "
                 f"{np.sqrt(np.mean(error ** 2)):.4g} arcmin, peak-to-peak {np.ptp(error):.4g} arcmin, "
                 f"uncertainty RMS {np.sqrt(np.mean(sigma ** 2)):.3g} arcmin (1 sigma)"]
        series = self.series
        order = np.argsort(series.amplitude_arcmin)[::-1][:top]
        lines.append(f"{'order':>5}{'amplitude/arcmin':>18}{'+-2 sigma':>11}")
        for i in order:
            lines.append(f"{series.orders[i]:>5d}{series.amplitude_arcmin[i]:>18.3f}"
                         f"{2 * series.amplitude_sigma_arcmin[i]:>11.3f}")
        if self.reading_noise_arcmin is not None:
            lines.append(f"reading noise (one reading about the profile, measured from the log): "
                         f"{self.reading_noise_arcmin:.3g} arcmin RMS")
        for key, value in self.details.items():
            if key == "step_zero_deg":
                lines.append(_step_zero_text(value))
            elif isinstance(value, (str, int, float, np.floating)):
                shown = f"{value:.4g}" if isinstance(value, (float, np.floating)) else value
                lines.append(f"{key.replace('_', ' ')}: {shown}")
        if self.removed_orders:
            lines.append("orders left out: " + _orders_text(self.removed_orders))
        if self.confounded:
            lines.append("not separable: " + self.confounded)
        if self.reading_sign == -1:
            lines.append("the encoder counts against the reference: fit the calibration written with --reverse")
        return "\n".join(lines)


def _step_zero_text(step_zero_deg):
    """The sentence on where the stepper's full step 0 lies in the calibration written (``steps`` only)."""
    return (f"the stepper's full step 0 (the first calibration's reference 0 deg) is at reference {step_zero_deg:.4f} "
            f"deg here: export a model of this calibration to mechaduino or klipper with --step-zero "
            f"{step_zero_deg:.4f} (where the first calibration itself takes 0)")


def _orders_text(orders):
    orders = list(orders)
    return ", ".join(map(str, orders[:20])) + (f", ... ({len(orders)} orders)" if len(orders) > 20 else "")


def _wrap(text, width=100):
    words, lines, line = text.split(), [], ""
    for word in words:
        if line and len(line) + 1 + len(word) > width:
            lines.append(line)
            line = word
        else:
            line = f"{line} {word}".strip()
    return lines + ([line] if line else [])
