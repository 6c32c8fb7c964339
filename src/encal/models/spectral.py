"""The empirical-Bayes spectral model: a Fourier series up to the grid's Nyquist order, shrunk by evidence.

``ε(θ) = a_0 + Σ_{ν=1..K} a_ν cos νθ + b_ν sin νθ`` with independent Gaussian priors on the
coefficients whose variance is a decaying background ``A ν^-β`` (``β ≥ 1``) plus "lines" on the
orders where a line raises the marginal likelihood by more than about 3 nats; white noise of
variance ``σ²``; ``K`` the Nyquist order of the calibration's stops (twice that when the stops
are off a regular grid, where the orders above it are only partly aliased). Every hyperparameter is
chosen by type-II maximum likelihood (``σ`` too, unless the noise is known); the model's
prediction is the posterior mean, its uncertainty the posterior standard deviation, with or
without the noise of a new reading. See docs/model-selection.md for what each prior assumes.

Two paths compute the same thing: on a uniform complete grid with the same number of readings
at every node the columns are orthogonal and everything is O(n log n) (one FFT); on any other
grid the Gram matrix of the Fourier features comes from trigonometric moments in O(n) per order
and each likelihood evaluation costs O(K³).

The model is stored like a Fourier series (``orders``, ``cos``, ``sin``: the posterior mean)
with its posterior standard deviation on a grid as the model file's ``uncertainty``.
"""

import math
import time

import numpy as np

from .._core.angles import ARCMIN_PER_DEG, model_input, resolution_of_readings, wrap360
from .._core.errors import InputError
from ..analysis.profile import (ANGLE_TOLERANCE_DEG, angles_and_grid, distinct_angles, identifiable_order,
                                profile_arrays, uniform_grid)
from . import _evidence
from .base import in_chunks
from .._core.parameters import check_bool
from ..numerics.trigsums import SeriesEvaluator, trig_moments, trig_series
from .fourier import MAX_ORDER, FourierModel

__all__ = ["SpectralModel", "fit_spectral", "repeat_noise",
           "DEFAULT_MAX_ORDER_IRREGULAR", "BLIND_PRIOR"]

#: Highest order of the Fourier-feature path when the caller names none (its cost is O(K³) per
#: likelihood evaluation); the FFT path has no cap below the Nyquist order.
DEFAULT_MAX_ORDER_IRREGULAR = 200
#: How the blind fit splits the flat level (see ``_evidence.split_average``): 'b10-80', the default, was chosen
#: for its worst encoder over every suite of benchmarks/bench_worlds.py; the others are the variants its
#: --blind option measures (docs/model-selection.md, "The blind split").
BLIND_SPLITS = ("b10-80", "uniform", "noise", "half", "gcv", "u60", "u70", "u80")
DEFAULT_BLIND_SPLIT = "b10-80"
BLIND_SPLIT = DEFAULT_BLIND_SPLIT
#: The default split in words (in :data:`BLIND_PRIOR`; a benchmark's other rule is named instead).
_BLIND_SPLIT_WORDS = ("under a two-point prior (0.1 or 0.8 of it profile, the posteriors averaged by their "
                      "evidence)")
#: What the blind fit assumes about the split of a flat spectrum between signal and noise.
BLIND_PRIOR = ("blind: the flat level of the spectrum, which one run cannot split between profile and noise, "
               f"is split {_BLIND_SPLIT_WORDS}, the noise never below the quantisation's LSB/sqrt(12) when the "
               "readings show the resolution")
#: Added to the blind prior when the stops are off a regular grid (safeguard 5).
BLIND_BEYOND_NYQUIST = ("; the stops being off a regular grid, the series then runs past the Nyquist order with "
                        "the split's mean noise held fixed")
#: Most orders stored in the model file; beyond, the smallest posterior-mean terms are dropped.
STORED_ORDERS_LIMIT = 4096
#: Repeated readings closer than this (arcmin) are identical: the rounding of doubles, not noise.
IDENTICAL_ARCMIN = 1e-9
#: Fewest readings beyond the stops for the noise to be estimated from repeated readings.
MIN_REPEAT_DOF = 10
#: Highest order up to which a line needs the plain 3 nats (see ``threshold_nats`` of fit_spectral).
_THRESHOLD_ORDER = 90
#: Highest order scanned for lines above the cap of the Fourier-feature path (see ``_orders_above_cap``).
SCAN_LIMIT = 4096
#: Most orders above the cap carried as columns, and most added per round of the scan.
MAX_EXTRA_ORDERS = 160
EXTRA_PER_ROUND = 80
#: Scans of the residual (each followed by a refit when it finds orders).
SCAN_ROUNDS = 2
#: Largest posterior-std grid (points per revolution).
_STD_GRID_LIMIT = 3600
#: Largest peak-to-peak stray of the readings from the grid's nodes, in codes, for which a quantised encoder's
#: rounding on a regular grid is one coherent pattern (see ``_quantisation_orders``).
COHERENT_SWING_CODES = 4.0
#: Harmonics of the rounding pattern whose orders (each with this many on either side) carry no line.
_ROUNDING_HARMONICS = 3
_ROUNDING_WIDTH = 2
#: Model the rounding's sidebands (``_rounding_variance``) on a uniform grid of a quantised encoder.
ROUNDING_SPECTRUM = True
_ROUNDING_HARMONICS_SPECTRUM = 3
_SMOOTH_ORDER = 32
#: Most readings for which the rounding's spectrum is computed when the encoder angles show no grid (on the
#: reference's grid, or on stops off any grid).
ROUNDING_GRID_MAX_READINGS = 10_000
#: Then model the rounding's realised pattern at the stops (``_realised_rounding``), and refit.
REALISED_ROUNDING = True
_REALISED_HARMONICS = 40
#: Least uncertainty of the estimated unrounded reading, in codes (see ``_realised_rounding``).
_MIN_TAU_CODES = 0.04
#: A line whose removal leaves the readings this close to as likely in their codes (nats) is the rounding's.
_CELL_TIE_NATS = 0.5
#: Below this alias coherence of the reference stops (see ``_alias_coherence``) the orders above the
#: Nyquist order are not copies of those below, and the series runs on (safeguard 5).
ALIAS_COHERENCE = 0.99
#: How far the series runs on such a grid, in multiples of the Nyquist order (one band of aliases).
BEYOND_NYQUIST = 2
#: Evidence (nats) a line above the Nyquist order needs beyond the threshold: it competes with its alias.
BEYOND_NYQUIST_NATS = 3.0


class SpectralModel(FourierModel):
    """The posterior mean of the spectral model: a Fourier series, with its posterior uncertainty.

    Parameters are those of :class:`~encal.models.fourier.FourierModel` (``orders``, ``cos``,
    ``sin`` in arc-minutes); :attr:`uncertainty` holds the posterior standard deviation of the
    profile on a grid and the noise standard deviation.

    Examples
    --------
    >>> model = SpectralModel([0, 1], cos=[0.5, 0.0], sin=[0.0, 2.0])
    >>> float(model.predict(90.0))
    2.5
    """

    kind = "spectral"
    _series = None  # the SeriesEvaluator of the coefficients, made on first use
    evaluation_width = 4  # the evaluator's few arrays per angle, not one term per order

    def _predict(self, theta_deg):
        if self.orders.size == 0:
            return np.zeros(theta_deg.shape)
        if self._series is None:
            highest = int(self.orders.max())
            complex_coefficients = np.zeros(highest + 1, dtype=complex)
            np.add.at(complex_coefficients, self.orders, self.cos - 1j * self.sin)
            self._series = SeriesEvaluator(complex_coefficients)
        return self._series(np.radians(theta_deg))

    def predict(self, theta_enc_deg, return_std=False, direction=None, include_noise=True):
        """Posterior mean of the error, and with ``return_std=True`` its posterior standard deviation.

        Parameters
        ----------
        theta_enc_deg : float or array-like
            Encoder readings in degrees.
        return_std : bool, default=False
            Also return the posterior standard deviation (arc-minutes).
        direction : {+1, -1} or array-like of them, optional
            Direction of travel into each reading: checked and ignored (one profile serves both), as
            for every model of one profile (:meth:`Model.predict <encal.models.base.Model.predict>`).
        include_noise : bool, default=True
            With the noise of a new reading (the spread of ``measured - predicted`` at a new
            reading), or without it (the uncertainty of the profile itself).

        Returns
        -------
        mean : float or ndarray
            Arc-minutes.
        std : float or ndarray
            Only with ``return_std=True``.
        """
        mean = super().predict(theta_enc_deg, direction=direction)
        if not check_bool(return_std, "return_std", "predict"):
            return mean
        if self.uncertainty is None:
            raise InputError("return_std=True needs the model's posterior uncertainty, which this model "
                             "does not hold")
        theta = model_input(np.asarray(theta_enc_deg, dtype=float), self.reading_sign)
        table = np.asarray(self.uncertainty["model_std_arcmin"], dtype=float)
        grid = np.arange(table.size) * float(self.uncertainty["grid_step_deg"])
        profile_std = np.interp(wrap360(theta), grid, table, period=360.0)
        noise = float(self.uncertainty["noise_std_arcmin"]) if include_noise else 0.0
        std = np.sqrt(profile_std**2 + noise**2).reshape(theta.shape)
        return mean, np.where(np.isnan(mean), np.nan, std)[()]  # NaN outside a calibrated arc (issue 31)

    def expected_rms_between_points(self):
        """The posterior's expected RMS error of a correction at angles not calibrated, arc-minutes.

        ``sqrt(mean(σ_profile(θ)²) + σ²)`` over the circle: the error a new reading leaves after
        correction, under the model's own prior (None without the posterior).
        """
        if self.uncertainty is None:
            return None
        table = np.asarray(self.uncertainty["model_std_arcmin"], dtype=float)
        return float(np.sqrt(np.mean(table**2) + float(self.uncertainty["noise_std_arcmin"]) ** 2))

    def report(self):
        """What the fit assumed and found, as lines of text for a terminal."""
        t = self.training
        if "noise" not in t:
            return f"spectral model, {self.orders.size} orders"
        lines = t.get("lines", [])
        shown = ", ".join(map(str, lines[:12])) + (", ..." if len(lines) > 12 else "")
        background = t["background"]
        text = [f"spectral model ({t['path']} path): orders 0..{t['max_order']} from {t['stops']} stops; "
                f"background {background['amplitude_arcmin2']:.3g} nu^-{background['exponent']:.2f} arcmin^2; "
                f"{len(lines)} line(s) admitted by more than {t['threshold_nats']:.3g} nats"
                + (f": {shown}" if lines else "")]
        if t.get("nyquist_term_arcmin"):
            text.append(f"Nyquist order {t['stops'] // 2} (the alternation from one stop to the next): amplitude "
                        f"{t['nyquist_term_arcmin']:.3g} arcmin, estimated and left out of the correction (unknown "
                        "between the stops)")
        if "beyond_nyquist" in t:
            beyond = t["beyond_nyquist"]
            text.append(f"orders {beyond['from_order']}-{t['max_order']}: past the Nyquist order, a line needs "
                        f"{beyond['line_nats']:.3g} nats (the stops are off a regular grid, alias coherence "
                        f"{t['alias_coherence']:.2f}: these orders are only partly copies of those below)")
        if t.get("orders_above_cap"):
            above = t["orders_above_cap"]
            text.append(f"orders {_ranges(above['orders'])}: above the cap of {above['cap']} (off a uniform grid), "
                        "carried because the residual's periodogram showed them")
        if t.get("rounding_orders"):
            text.append(f"orders {_ranges(t['rounding_orders'])}: no line (where the rounding of the readings to whole "
                        "codes lands on this grid)")
        if t.get("rounding_lines"):
            text.append(f"orders {_ranges(t['rounding_lines'])}: taken as the rounding's pattern, not lines (the "
                        "readings lie in their codes as well without them), and refitted with the rounding's realised "
                        "spectrum")
        sigma = t["noise"]["std_arcmin"]
        split = t["noise"].get("split")
        # the held-out estimate uses a new reading's noise: said whenever it is not sigma (issue 28: an estimate
        # of 0.070 printed below a stated noise of 0.078, the flat level, with nothing said)
        new_reading = split.get("mean_noise_std_arcmin", sigma) if split else sigma
        floored = (f" (the spectrum's flat level, noise and flat signal together; a new reading's noise is taken as "
                   f"{new_reading:.4g} arcmin, the mean of the split between them)"
                   if not math.isclose(new_reading, sigma, rel_tol=1e-3) else "")
        text.append(f"noise: sigma {sigma:.4g} arcmin{floored}; prior: {t['prior']}")
        scatter = t["noise"].get("repeat_std_arcmin")
        if scatter is not None and scatter < sigma:
            text.append(f"the repeated readings' scatter, {scatter:.3g} arcmin, is below the quantisation's "
                        f"LSB/sqrt(12) and was raised to it: the repeats miss the rounding to whole codes, the same at "
                        "every reading of one angle and different from one angle to the next")
        if t["noise"].get("identical_repeats_dropped"):
            text.append(f"{t['noise']['identical_repeats_dropped']} repeated readings identical to the first at "
                        "their angle were left out: identical repeats carry no information about the noise")
        bits = self.encoder.get("resolution_bits") or t.get("readings_resolution_bits")
        if bits:
            quantum = 21600.0 / 2**bits / math.sqrt(12.0)
            text.append(f"sigma / (LSB/sqrt(12)) = {sigma:.4g} / {quantum:.4g} = {sigma / quantum:.2f} "
                        f"({bits}-bit encoder): "
                        f"{_noise_meaning(sigma / quantum, t['noise']['source'], 'readings_resolution_bits' in t)}")
        expected = self.expected_rms_between_points()
        if expected is not None:
            from .uncertainty import included_text

            included = included_text(self.uncertainty.get("reference_std_rms_arcmin"),
                                     self.uncertainty.get("reading_noise_arcmin"))
            text.append(f"held-out estimate (posterior, readings at angles not calibrated): RMS "
                        f"{expected:.4g} arcmin after correction" + (f", including {included}" if included else ""))
        return "\n".join(text)

    def __repr__(self):
        name = self.encoder.get("name") or "unnamed encoder"
        return f"<SpectralModel {self.orders.size} orders up to {int(self.orders.max(initial=0))} for {name}>"


def _ranges(orders):
    """'43-45, 88-90' for [43, 44, 45, 88, 89, 90]."""
    runs = []
    for order in orders:
        if runs and order == runs[-1][1] + 1:
            runs[-1][1] = order
        else:
            runs.append([order, order])
    return ", ".join(f"{first}-{last}" if last > first else f"{first}" for first, last in runs)


#: Blind, a noise below this fraction of the quantisation's (``1/1.2``, the mirror of the band called consistent
#: with it), of readings that are not whole codes of the resolution declared, is of readings smoother than whole
#: codes: a self-calibration's output of a 14-bit encoder gave 0.001. (Readings in whole codes can show a flat level
#: of 0.8 of it: the rounding of a smooth profile over a few codes is not white.)
_SMOOTHER_THAN_CODES = 1.0 / 1.2


def _noise_meaning(ratio, source, shows_codes=True):
    """What the noise's ratio to the quantisation noise says, in a sentence.

    Independent noises add in variance: a reading noise ``s`` on top of the rounding to whole codes
    (``q = LSB/sqrt(12)``) gives ``ratio**2 = 1 + (s/q)**2``. Below 1.2 the reading noise is under two
    thirds of ``q`` (the rounding is over 70 % of the variance): the noise is consistent with the
    quantisation alone. From 2 on it is over 1.7 ``q`` (over 75 % of the variance): the reading noise
    dominates. Between, both contribute and the sentence gives the other part, ``sqrt(ratio**2 - 1)``
    times ``q``. Below 1, with the noise supplied or from repeats (blind, the noise is kept at ``q`` or
    above when the readings show the resolution): a reading's rounding is the same each time the
    encoder stops at one angle, so repeats barely differ and miss it. Blind and well below 1 with a resolution
    declared that the readings do not show (``shows_codes`` False): the readings are smoother than whole codes.
    """
    if ratio < 1.0 and source != "blind":
        measured = "the noise given" if source == "supplied" else "the scatter of the repeated readings"
        return (f"below the quantisation alone: {measured} leaves out the rounding to whole codes, which is the "
                "same at every reading of one angle, and a reading at any other angle carries it (LSB/sqrt(12))")
    if ratio < _SMOOTHER_THAN_CODES and not shows_codes:
        return ("below the quantisation: these readings vary less than whole codes would make them (averages, "
                "or a self-calibration's smoothed output), so sigma is not a new reading's noise, which carries "
                "the rounding to whole codes (LSB/sqrt(12)) as well")
    if ratio < 1.2:
        return "consistent with the encoder's quantisation alone; little finer is left to calibrate"
    if ratio < 2.0:
        other = math.sqrt(ratio**2 - 1.0)
        if source == "blind":
            return (f"comparable to the quantisation: a part of about {other:.1f} LSB/sqrt(12) adds to the rounding "
                    "to whole codes, reading noise or structure finer than the calibration's spacing that one pass "
                    "cannot tell from noise; a second pass over the same angles (--repeat) or a known noise "
                    "(--noise) would separate them")
        return (f"comparable to the quantisation: reading noise of about {other:.1f} LSB/sqrt(12) adds to the "
                "rounding to whole codes, both contribute")
    if source == "blind":
        return ("well above the quantisation: reading noise, or structure finer than the calibration's spacing "
                "that one pass cannot tell from noise; a second pass over the same angles (--repeat) or a known "
                "noise (--noise) would separate them")
    return "well above the quantisation: the reading noise of this encoder and its electronics"


def repeat_noise(reference_deg, error_arcmin):
    """Noise standard deviation from repeated readings at the same reference angle (a stop, a pass).

    Parameters
    ----------
    reference_deg : array-like of shape (n,)
        Reference angles in degrees; readings at one angle (within 1e-9°) are repeats.
    error_arcmin : array-like of shape (n,)
        Errors in arc-minutes.

    Returns
    -------
    (float or None, int)
        The pooled within-stop standard deviation in arc-minutes (None when fewer than
        :data:`MIN_REPEAT_DOF` degrees of freedom), and its degrees of freedom ``n - stops``.
    """
    error = np.asarray(error_arcmin, dtype=float).reshape(-1)
    _, group = distinct_angles(wrap360(np.asarray(reference_deg, dtype=float).reshape(-1)))
    return _repeat_noise_of_stops(group, error)


def _repeat_noise_of_stops(group, error):
    """:func:`repeat_noise` given each reading's stop (``distinct_angles``'s groups of the reference angles)."""
    stops = int(group.max()) + 1
    dof = error.size - stops
    if dof < MIN_REPEAT_DOF:
        return None, dof
    counts = np.bincount(group, minlength=stops)
    means = np.bincount(group, weights=error, minlength=stops) / counts
    return float(np.sqrt(np.sum((error - means[group]) ** 2) / dof)), dof


# -- the design: columns, Gram matrix, projections -----------------------------------------------

def _columns(highest, regular_points, phase_rad, extra=()):
    """Orders, shifts and line eligibility of the columns ``cos(ν θ - ψ)``.

    On a regular grid of an even number ``N`` of stops, the Nyquist order ``N / 2`` has one
    column, ``cos(N/2 (θ - φ))``, its sine pinned to zero (safeguard 3). That column may carry a
    line: it is ±1 at the nodes and 0 at the midpoints, and a stepper's per-step pattern seen by
    every other step lands there, which without a line of its own would be counted as noise.
    """
    orders, shifts, lineable = [0], [0.0], [False]
    for k in range(1, highest + 1):
        if regular_points is not None and regular_points % 2 == 0 and 2 * k == regular_points:
            orders.append(k)
            shifts.append(k * phase_rad)
            lineable.append(True)
            continue
        orders += [k, k]
        shifts += [0.0, 0.5 * math.pi]
        lineable += [True, True]
    for k in extra:
        orders += [k, k]
        shifts += [0.0, 0.5 * math.pi]
        lineable += [True, True]
    return np.array(orders, dtype=int), np.array(shifts), np.array(lineable, dtype=bool)


def _uniform_nodes(theta_deg, angles=None):
    """``(phase_rad, node_index, nodes)`` when the readings lie exactly on a uniform grid with the same
    number of readings at every node, else None. ``angles``: :func:`~encal.analysis.profile.angles_and_grid` of
    the readings, when known."""
    distinct, group, sampling = angles_and_grid(theta_deg) if angles is None else angles
    nodes = distinct.size
    if nodes < 2:
        return None
    counts = np.bincount(group, minlength=nodes)
    if np.any(counts != counts[0]):
        return None
    if sampling.phase_rad is None:  # uniform_grid(distinct) is None
        return None
    first = float(wrap360(np.degrees(sampling.phase_rad)))  # uniform_grid(distinct)[0]
    spacing = 360.0 / nodes
    position = (distinct - first) / spacing
    if np.max(np.abs(position - np.round(position))) * spacing > ANGLE_TOLERANCE_DEG:
        return None
    index = np.mod(np.round(position).astype(int), nodes)
    return math.radians(first), index[group], nodes


def _fft_design(error, uniform, orders, shifts, lineable):
    phase, node, nodes = uniform
    sums = np.bincount(node, weights=error, minlength=nodes)
    highest = int(orders.max())
    moments = np.exp(1j * np.arange(highest + 1) * phase) * (np.fft.ifft(sums) * nodes)[: highest + 1]
    projection = np.real(np.exp(-1j * shifts) * moments[orders])
    n = error.size
    gram = np.full(orders.size, 0.5 * n)
    gram[orders == 0] = n
    if nodes % 2 == 0:
        gram[2 * orders == nodes] = n  # the single Nyquist column is ±1 at the nodes
    return _evidence.Design(orders, shifts, gram, projection, float(error @ error), n, lineable)


def _general_design(theta_rad, error, orders, shifts, lineable):
    highest = int(orders.max())
    weights = trig_moments(theta_rad, np.ones(theta_rad.size), 2 * highest)
    moments = trig_moments(theta_rad, error, highest)
    projection = np.real(np.exp(-1j * shifts) * moments[orders])
    difference = orders[:, None] - orders[None, :]
    total = orders[:, None] + orders[None, :]
    s_diff = np.where(difference >= 0, weights[np.abs(difference)], np.conj(weights[np.abs(difference)]))
    # the shifts take a few values: each phase factor is computed once per pair of values and gathered
    distinct, which = np.unique(shifts, return_inverse=True)
    pair = (which[:, None], which[None, :])
    gram = 0.5 * np.real(np.exp(-1j * (distinct[:, None] - distinct[None, :]))[pair] * s_diff
                         + np.exp(-1j * (distinct[:, None] + distinct[None, :]))[pair] * weights[total])
    gram = 0.5 * (gram + gram.T)
    return _evidence.Design(orders, shifts, gram, projection, float(error @ error), error.size, lineable)


def _reference_stops(theta, error):
    """``(reference, distinct, group)``: the reference angles, the distinct ones (degrees, increasing) and the stop of
    each reading (``distinct_angles``'s groups).

    One sort of the reference angles serves every check of the stops in a fit (the identical repeats, the stops'
    encoder angles, the repeats' noise, the alias coherence): on 10^6 readings each sort is tens of milliseconds.
    """
    reference = wrap360(theta - error / ARCMIN_PER_DEG)
    return (reference, *distinct_angles(reference))


def _stops(theta, group):
    """The mean encoder angle (degrees) at each stop, ``group`` each reading's stop."""
    stops = int(group.max()) + 1
    if stops == theta.size:  # a reading at every stop (random or time-sampled reference angles): its own angle
        alone = np.empty(stops)
        alone[group] = theta
        return alone
    phasor = np.bincount(group, weights=np.cos(np.radians(theta)), minlength=stops) \
        + 1j * np.bincount(group, weights=np.sin(np.radians(theta)), minlength=stops)
    return wrap360(np.degrees(np.angle(phasor)))


# -- the fit --------------------------------------------------------------------------------------

def fit_spectral(theta_enc_deg, error_arcmin, *, noise_arcmin=None, max_order=None,
                 threshold_nats=None, path="auto", progress=None):
    """Fit the empirical-Bayes spectral model.

    Parameters
    ----------
    theta_enc_deg : array-like of shape (n,)
        Encoder angles in degrees.
    error_arcmin : array-like of shape (n,)
        Errors ``encoder - reference`` in arc-minutes.
    noise_arcmin : float, optional
        Standard deviation of one reading's noise, in arc-minutes, when known (from the
        encoder's data sheet, a repeat pass, repeated readings). Default: from repeated
        readings at the same reference angle when the calibration has at least
        :data:`MIN_REPEAT_DOF` of them, else blind (:data:`BLIND_PRIOR`).
    max_order : int, optional
        Highest order of the series. Default: the Nyquist order of the stops, ``⌊m/2⌋`` for
        ``m`` distinct reference angles, capped at :data:`DEFAULT_MAX_ORDER_IRREGULAR` on the
        Fourier-feature path (a dense calibration off a uniform grid); when the stops are off a
        regular grid (alias coherence below :data:`ALIAS_COHERENCE`), :data:`BEYOND_NYQUIST` times
        that, within the same cap, a line past the Nyquist order needing :data:`BEYOND_NYQUIST_NATS`
        more (safeguard 5; blind, the noise is then the blind split's mean noise of the series up to
        the Nyquist order, held fixed). A ``max_order`` given is never exceeded.
    threshold_nats : float, optional
        Evidence (nats) a line must add to be kept. Default: 3 nats up to order 90, and
        ``3 + ln(K / 90)`` for a highest order ``K`` (the Nyquist order, past which safeguard 5
        adds its own) above it, so that the expected number of
        false lines on pure noise (about 0.4 per fit at ``K = 90``) does not grow with ``K``.
    path : {'auto', 'fft', 'features'}, default='auto'
        ``'auto'``: the FFT path when the encoder angles are a uniform grid with the same number
        of readings at each node, else the Fourier-feature path. ``'features'`` forces the
        general path (for checks); ``'fft'`` refuses data it does not apply to.
    progress : callable, optional
        Called with no argument after each of the fit's 3 stages (the design, the hyperparameters,
        the posterior), for a progress bar (:class:`encal._core.progress.Progress` ``.advance``).

    Returns
    -------
    SpectralModel
        With ``uncertainty`` (posterior standard deviation) and ``training`` recording the
        prior, the noise and where it came from, the background, the lines and the evidence.

    Raises
    ------
    InputError
        If an option is invalid or the calibration has fewer than 3 stops.
    """
    return _fit_spectral(theta_enc_deg, error_arcmin, noise_arcmin=noise_arcmin, max_order=max_order,
                         threshold_nats=threshold_nats, path=path, progress=progress)


def _fit_spectral(theta_enc_deg, error_arcmin, *, noise_arcmin, max_order, threshold_nats, path, progress,
                  _extra_orders=(), _start=None, _scan_round=0, _seed_orders=()):
    """:func:`fit_spectral`, and its refit with the orders above the cap that the residual showed.

    Parameters
    ----------
    _extra_orders : sequence of int
        Internal: orders above the cap carried as columns (see :func:`_orders_above_cap`).
    _start : encal.models._evidence.Hyper, optional
        Internal: where the hyperparameter search starts (the fit before those orders were added).
    _scan_round : int
        Internal: how many scans above the cap came before this fit (at most :data:`SCAN_ROUNDS`).
    _seed_orders : sequence of int
        Internal: the orders the last scan found, where the search starts with a line when the evidence at
        ``_start`` asks for one (:func:`encal.models._evidence.seed_lines`).
    """
    start = time.perf_counter()
    # the angles as given when they are in [0, 360) already (no copy: the fit only reads them)
    theta, error = profile_arrays(theta_enc_deg, error_arcmin, "fit_spectral", copy=False)
    if path not in ("auto", "fft", "features"):
        raise InputError(f"The 'path' parameter of fit_spectral must be 'auto', 'fft' or 'features'. "
                         f"Got {path!r} instead.")
    if noise_arcmin is not None:
        _check_noise(noise_arcmin, error)
    if threshold_nats is not None and not (isinstance(threshold_nats, (int, float)) and threshold_nats >= 0):
        raise InputError(f"The 'threshold_nats' parameter of fit_spectral must be a number >= 0. "
                         f"Got {threshold_nats!r} instead.")
    reference, reference_distinct, group = _reference_stops(theta, error)
    theta, error, identical = _without_identical_repeats(theta, error, group)
    if identical:
        reference, reference_distinct, group = _reference_stops(theta, error)
    threshold_given = threshold_nats
    stop_angles = _stops(theta, group)
    m = stop_angles.size
    if m < 3:
        raise InputError(f"fit_spectral expects readings at 3 or more distinct reference angles; got {m}")
    bits = resolution_of_readings(theta)
    quantisation_var = (ARCMIN_PER_DEG * 360.0 / 2**bits) ** 2 / 12.0 if bits else 0.0
    noise_var, noise_source, repeat_dof, repeat_std = _known_noise(noise_arcmin, reference, error, quantisation_var,
                                                                    group)
    del group  # (before the coherence's temporaries, 40 bytes a stop, the fit's peak on random stops)
    coherence = _alias_coherence(reference, reference_distinct)
    grid = uniform_grid(stop_angles)
    # The rounding's pattern follows the reference's grid, which the encoder angles may leave by more than a
    # quarter of its spacing (a dense grid, a large profile): then the reference's nodes are its grid, when
    # the pattern lands on an order a fit can reach and the readings are few enough (its variance costs
    # readings x orders: 8 and 15 times the fit on 10^5 and 10^6 readings).
    rounding_grid = grid
    if grid is None and bits and theta.size <= ROUNDING_GRID_MAX_READINGS and _rounding_reachable(bits, m):
        rounding_grid = uniform_grid(reference_distinct)
    del reference_distinct  # (before the encoder angles' sort: 8 bytes a reading)
    del stop_angles  # (8 bytes a stop)
    regular_points = m if grid is not None else None
    phase = math.radians(grid[0]) if grid is not None else 0.0
    # the encoder angles' sort, for the uniform nodes and the scan above the cap (which sorts them itself after
    # a fit on the Fourier-feature path, when it scans at all)
    angles = angles_and_grid(theta) if path != "features" else None
    uniform = _uniform_nodes(theta, angles) if angles is not None else None
    stable_order = angles[2].stable_order if angles is not None else None  # identifiable_order(theta)
    del angles  # (the groups: 8 bytes a reading)
    if uniform is not None and uniform[2] != m:
        uniform = None
    if path == "fft" and uniform is None:
        raise InputError("fit_spectral(path='fft') expects encoder angles on a uniform grid with the same "
                         "number of readings at every node")
    nyquist = m // 2
    if max_order is None:
        highest = nyquist if uniform is not None else min(nyquist, DEFAULT_MAX_ORDER_IRREGULAR)
    else:
        if isinstance(max_order, bool) or not isinstance(max_order, (int, np.integer)) or max_order < 1:
            raise InputError(f"The 'max_order' parameter of fit_spectral must be an int >= 1. "
                             f"Got {max_order!r} instead.")
        highest = min(int(max_order), nyquist)
    if highest < nyquist:
        regular_points = None  # no Nyquist column below the cap

    beyond = max_order is None and uniform is None and highest == nyquist and coherence < ALIAS_COHERENCE
    first_pass = first_prior = None
    if beyond and noise_var is None:
        # Blind, the flat level would absorb the orders past Nyquist: the noise is the blind split's mean
        # noise of the series up to Nyquist, then held fixed; the search starts from that fit's prior.
        first_pass = fit_spectral(theta, error, max_order=nyquist, threshold_nats=threshold_nats, path=path)
        noise_var = first_pass.training["noise"]["split"]["mean_noise_std_arcmin"] ** 2
        first = first_pass.training
        first_prior = _evidence.Hyper(first["background"]["amplitude_arcmin2"], first["background"]["exponent"],
                                      noise_var, dict(zip(first["lines"], first["line_variances_arcmin2"])))
    if beyond:
        # Safeguard 5: off a regular grid the orders above Nyquist are only partly aliased, and the
        # series runs on to them (the noise known or fixed by the first pass).
        highest = min(BEYOND_NYQUIST * nyquist, max(DEFAULT_MAX_ORDER_IRREGULAR, nyquist))
        regular_points = None
    if threshold_nats is None:
        threshold_nats = _evidence.LINE_THRESHOLD_NATS + max(0.0, math.log(nyquist if beyond else highest)
                                                             - math.log(_THRESHOLD_ORDER))

    offset = float(np.mean(error))
    centred = error - offset
    capped = max_order is None and uniform is None and not beyond and highest < nyquist
    extra = sorted(int(k) for k in _extra_orders if k > highest)
    orders, shifts, lineable = _columns(highest, regular_points, phase, extra)
    rounding_orders = _quantisation_orders(bits, rounding_grid, theta)
    lineable &= ~np.isin(orders, rounding_orders)
    if uniform is not None:
        design = _fft_design(centred, uniform, orders, shifts, lineable)
    else:
        design = _general_design(np.radians(theta), centred, orders, shifts, lineable)
    if ROUNDING_SPECTRUM and bits and (rounding_grid is not None or theta.size <= ROUNDING_GRID_MAX_READINGS):
        # (off any grid too, up to ROUNDING_GRID_MAX_READINGS readings: jittered stops leave the pattern partly
        # coherent, and a 12-bit encoder on 1,800-3,600 stops jittered by ±0.4 spacings got 1-4 false lines near 496)
        design.rounding = _rounding_variance(bits, theta, error, reference, orders, m,
                                             picked=extra if noise_var is None else None)
    reference_bits = resolution_of_readings(reference) if capped else None  # for the scan above the cap
    del centred, reference  # (the scan above the cap, the fit's peak, needs neither: 16 bytes a reading)
    if beyond:
        design.nyquist, design.beyond_nyquist_nats = nyquist, BEYOND_NYQUIST_NATS
    if extra:
        design.picked = np.array(extra, dtype=int)
    _advance(progress)
    if _start is not None and _seed_orders:
        # Without lines there the background rose to explain the new orders' power, the lines below the cap fell
        # under it and were dropped (for the rest of that search), and the optimiser took seven times its usual steps.
        _start = _evidence.seed_lines(design, _start, _seed_orders, threshold_nats)
    hyper, post = _evidence.fit_hyperparameters(design, noise_var=noise_var, threshold=threshold_nats,
                                                start=first_prior if _start is None else _start)
    post = _evidence.signal_part(design, hyper.variances(design), hyper.noise_var, post)
    rounding_lines = []
    if design.rounding is not None and REALISED_ROUNDING:
        # Lines that the codes show to be the rounding's pattern: refit with its realised spectrum (issue 27).
        realised, rounding_lines = _realised_rounding(bits, theta, error - offset, design, hyper, post, m,
                                                      blind=noise_var is None)
    if rounding_lines:
        design.rounding = realised
        restart = _evidence.Hyper(hyper.amplitude, hyper.exponent, hyper.noise_var,
                                  {k: v for k, v in hyper.lines.items() if k not in rounding_lines})
        hyper, post = _evidence.fit_hyperparameters(design, noise_var=noise_var, threshold=threshold_nats,
                                                    start=restart)
        post = _evidence.signal_part(design, hyper.variances(design), hyper.noise_var, post)
    _advance(progress)
    split = None
    if first_pass is not None:
        split = first_pass.training["noise"]["split"]
    elif noise_source == "blind":
        # σ̂ stays the flat level (all of it noise), the figure to hold against LSB/√12; a new
        # reading's predictive noise is the mixture's mean noise.
        post, mean_noise_var = _evidence.split_average(design, hyper, quantisation_var, rule=BLIND_SPLIT)
        split = {"rule": BLIND_SPLIT, "fractions": _evidence.split_fractions(BLIND_SPLIT).tolist(),
                 "mean_noise_std_arcmin": math.sqrt(mean_noise_var),
                 "floor_arcmin": math.sqrt(quantisation_var)}

    cap = highest
    highest = int(orders.max())
    cos = np.zeros(highest + 1)
    sin = np.zeros(highest + 1)
    np.add.at(cos, orders, post.mean * np.cos(shifts))
    np.add.at(sin, orders, post.mean * np.sin(shifts))
    cos[0] += offset
    nyquist_term = 0.0
    unseen = None
    if regular_points is not None and regular_points % 2 == 0:
        # Estimated, so that it is not counted as noise, but not part of the correction: between the
        # nodes its value is unknown (safeguard 3), and read in encoder angles its cosine leaks into
        # the midpoints. A stepper's alternate full steps (the reference's own error) land here.
        nyquist_term = math.hypot(cos[regular_points // 2], sin[regular_points // 2])
        cos[regular_points // 2] = sin[regular_points // 2] = 0.0
        column = int(np.flatnonzero(orders == regular_points // 2)[0])
        unseen = (regular_points // 2, float(shifts[column]), float(post.mean[column]),
                  float(hyper.variances(design)[column]))
    kept, dropped_rms = _stored_orders(cos, sin, math.sqrt(hyper.noise_var))
    # blind, σ̂ is the flat level (all of it noise), the figure to hold against LSB/√12
    sigma = math.sqrt(hyper.noise_var) if first_pass is None else first_pass.training["noise"]["std_arcmin"]
    training = {
        "select": "evidence",
        "path": "fft" if design.diagonal else "fourier-features",
        "max_order": int(highest),
        "stops": int(m),
        "alias_coherence": coherence,
        **({"beyond_nyquist": {"from_order": nyquist + 1, "line_nats": float(threshold_nats + BEYOND_NYQUIST_NATS)}}
           if beyond else {}),
        "prior": _prior_text(noise_source) + (BLIND_BEYOND_NYQUIST if first_pass is not None else ""),
        "noise": {"source": noise_source, "std_arcmin": sigma,
                  **({"repeat_dof": int(repeat_dof)} if repeat_dof is not None else {}),
                  **({"repeat_std_arcmin": repeat_std} if repeat_std is not None else {}),
                  **({"identical_repeats_dropped": identical} if identical else {}),
                  **({"split": split} if split is not None else {})},
        "background": {"amplitude_arcmin2": hyper.amplitude, "exponent": hyper.exponent},
        "lines": [int(k) for k in sorted(hyper.lines)],
        "line_variances_arcmin2": [hyper.lines[k] for k in sorted(hyper.lines)],
        "log_evidence_nats": post.log_evidence,
        "threshold_nats": float(threshold_nats),
        "dropped_rms_arcmin": dropped_rms,
        "nyquist_term_arcmin": nyquist_term,
        "rounding_orders": [int(k) for k in rounding_orders],
        **({"rounding_lines": rounding_lines} if rounding_lines else {}),
        "time_s": time.perf_counter() - start,
    }
    if noise_arcmin is not None:
        training["noise_arcmin"] = float(noise_arcmin)
    if bits is not None:
        training["readings_resolution_bits"] = bits
    model = SpectralModel(kept, cos[kept], sin[kept], training=training)
    predictive_sigma = sigma if split is None else split["mean_noise_std_arcmin"]
    model.uncertainty = _posterior_std(design, post, highest, predictive_sigma, unseen)
    if capped and len(extra) < MAX_EXTRA_ORDERS and _scan_round < SCAN_ROUNDS:
        # The cap is the cost's, not the data's: orders above it that the residual's periodogram shows
        # clearly (a stepper's detent at 200 and its sidebands) are carried as columns, and the fit repeated.
        # The prediction a chunk of angles at a time, as Model.predict (the same numbers: the evaluator's value
        # at an angle does not depend on the others); its temporaries of 10^6 angles at once were the fit's peak.
        residual = error - in_chunks(model._predict, theta, model.evaluation_width)
        found = _orders_above_cap(theta, residual, cap, nyquist, extra, reference_bits, stable_order=stable_order)
        del residual
        if found:
            _advance(progress)
            return _fit_spectral(theta, error, noise_arcmin=noise_arcmin, max_order=None,
                                 threshold_nats=threshold_given,
                                 path=path, progress=None, _extra_orders=extra + found, _start=hyper,
                                 _scan_round=_scan_round + 1, _seed_orders=found)
    if extra:
        model.training["orders_above_cap"] = {"cap": int(cap), "orders": extra}
    _advance(progress)
    return model


#: Largest known noise, in arc-minutes: a turn (a reading's noise beyond it is no angle's; 1e300 overflowed).
MAX_NOISE_ARCMIN = 21600.0


def noise_resolution_arcmin(error_arcmin):
    """The smallest known noise that means something for these errors (arc-minutes): their float resolution.

    The larger of the spacing of double-precision numbers at 360 degrees (a reading within a turn, in
    arc-minutes: 3.4e-12) and at the largest error (arc-minutes). A noise below it is below what the
    numbers hold; 1e-300 broke the evidence's logarithms.
    """
    largest = float(np.max(np.abs(error_arcmin), initial=0.0))
    return max(60.0 * float(np.spacing(360.0)), float(np.spacing(largest)))


def _check_noise(noise_arcmin, error_arcmin):
    """Refuse a known noise that is not a finite number from the errors' resolution to a turn."""
    low = noise_resolution_arcmin(error_arcmin)
    if isinstance(noise_arcmin, bool) or not isinstance(noise_arcmin, (int, float, np.integer, np.floating)) \
            or not low <= noise_arcmin <= MAX_NOISE_ARCMIN:
        raise InputError(f"The 'noise_arcmin' parameter of fit_spectral must be a number of arc-minutes from "
                         f"{low:.3g} (the resolution of these errors in double precision) to "
                         f"{MAX_NOISE_ARCMIN:g} (a turn). Got {noise_arcmin!r} instead.")


def _orders_above_cap(theta_deg, residual_arcmin, cap, nyquist, known, reference_bits=None, stable_order=None):
    """Orders above ``cap`` where the residual of a capped fit has a line the data identify, sorted.

    The scan runs to the highest order the readings identify stably (``identifiable_order``: the
    largest gap between them shorter than half a period), at most :data:`SCAN_LIMIT` and the Nyquist
    order of the stops. On readings spread over the circle an order's periodogram of white noise,
    ``|Σ r_i e^{-i k θ_i}|² / n``, is exponential with mean ``σ²`` (estimated robustly, the median over
    the scan divided by ln 2); an order counts when it exceeds ``σ²`` by the factor ``ln N + 3`` (about
    0.05 false orders per scan of ``N`` orders). At most :data:`EXTRA_PER_ROUND` orders per round, the
    strongest first. ``stable_order``: ``identifiable_order(theta_deg)`` when the fit knows it already.
    """
    top = min(identifiable_order(theta_deg) if stable_order is None else stable_order, SCAN_LIMIT, nyquist)
    if reference_bits:
        # A reference read in whole codes of B bits rounds by a sawtooth of 2^B cycles a turn, which the
        # readings' spacing aliases onto every order (a 12-bit reference read 10,000 times a turn put lines at
        # multiples of 16 and near 1808): above the cap its orders cannot be told from the encoder's, and the
        # scan is not made (fitted, they left 0.69 arcmin RMS off the truth, against 0.051 without them).
        return []
    if top <= cap + 1:
        return []
    moments = trig_moments(np.radians(theta_deg), residual_arcmin, top)[cap + 1:]
    power = np.abs(moments) ** 2 / residual_arcmin.size
    level = float(np.median(power)) / math.log(2.0)
    if not level > 0:
        return []
    cut = level * (math.log(power.size) + _evidence.LINE_THRESHOLD_NATS)
    orders = np.arange(cap + 1, top + 1)
    strong = [int(k) for k in orders[np.argsort(power)[::-1]] if k not in known][:EXTRA_PER_ROUND]
    return sorted(k for k in strong if power[k - cap - 1] > cut)


def _known_noise(noise_arcmin, reference_deg, error_arcmin, quantisation_var=0.0, group=None):
    """``(variance, source, repeat_dof, repeat_std)`` of the noise: supplied, from repeated readings, or blind
    (``(None, 'blind', None, None)``).

    The scatter of repeated readings is used as the noise only down to the quantisation's ``LSB/sqrt(12)``
    (``quantisation_var``, arcmin², when the readings show the resolution; ``repeat_std`` is then the scatter
    itself): a reading's rounding to a whole code is the same every time the encoder stops at one angle, so the
    repeats miss it, but it differs from stop to stop and to the profile it is noise. Used as is, a scatter of
    0.01 arcmin on a 14-bit encoder (LSB/sqrt(12) = 0.38 arcmin) had the model follow the rounding of every stop.
    """
    if noise_arcmin is not None:
        return float(noise_arcmin) ** 2, "supplied", None, None
    if group is None:
        repeat_std, repeat_dof = repeat_noise(reference_deg, error_arcmin)
    else:  # the stops already found (``_reference_stops``)
        repeat_std, repeat_dof = _repeat_noise_of_stops(group, np.asarray(error_arcmin, dtype=float).reshape(-1))
    if repeat_std is not None and repeat_std > IDENTICAL_ARCMIN:
        return max(repeat_std**2, quantisation_var), "repeated readings", repeat_dof, repeat_std
    return None, "blind", None, None


def _without_identical_repeats(theta, error, group=None):
    """``(theta, error, dropped)``: when every repeated reading equals the first at its angle (to
    :data:`IDENTICAL_ARCMIN`), the repeats carry no information (a file given as its own repeat, rows copied)
    and only the first of each is kept; otherwise the readings as they are and ``dropped`` 0.

    Kept, identical repeats made the flat level of the spectrum, which blind is the noise, zero (1.7e-7 arcmin for
    a calibration given as its own ``--repeat``) and the model follow every reading.
    """
    if group is None:  # the stops, as _reference_stops finds them
        group = _reference_stops(theta, error)[2]
    stops = int(group.max()) + 1
    if stops == theta.size:  # no repeats
        return theta, error, 0
    # each stop's first reading (np.unique's return_index, without its sort)
    first = np.full(stops, theta.size)
    np.minimum.at(first, group, np.arange(theta.size))
    if np.any(np.abs(error - error[first[group]]) > IDENTICAL_ARCMIN):
        return theta, error, 0
    kept = np.sort(first)
    return theta[kept], error[kept], int(theta.size - kept.size)


def _alias_coherence(reference_deg, distinct=None):
    """``|mean exp(i N θ_j)|`` over the distinct reference angles ``θ_j``: 1 when they lie on a uniform grid.

    At stops ``θ_j = 2πj/N + δ_j`` an order ``N - k`` equals order ``k`` up to the phase ``N δ_j``;
    the coherence is about ``E cos(N δ)``, the correlation of an order with its alias at the stops.
    ``N`` is the number of stops, or the nodes of the grid their smallest gap suggests when that is
    more (a grid with nodes missing, such as a cross-validation fold's). A uniform grid of stops (a
    stepper, a dividing head) gives 1 however far the encoder's readings stray from it (by the error
    itself); a jittered or random set of stops less (±1° on a 5° grid: about 0.76).
    """
    if distinct is None:
        distinct, _ = distinct_angles(reference_deg)
    theta = np.radians(distinct)  # (increasing already: distinct_angles sorts them)
    gaps = np.diff(np.r_[theta, theta[0] + 2.0 * math.pi])
    nodes = {distinct.size, int(round(2.0 * math.pi / max(float(gaps.min()), 1e-12)))}
    del gaps
    del theta
    coherence = []
    for n in nodes:
        if n >= distinct.size:
            # N θ_j in turns, less its whole turns, before the cosine and sine: random stops suggest a grid of about
            # 10^12 nodes, whose phases of 10^12 radians the cosine reduces slowly
            total = 0j
            for start in range(0, distinct.size, _COHERENCE_BLOCK):
                turns = distinct[start:start + _COHERENCE_BLOCK] * (n / 360.0)
                turns -= np.round(turns)
                turns *= 2.0 * math.pi
                total += complex(np.cos(turns).sum(), np.sin(turns).sum())
            coherence.append(abs(total) / distinct.size)
    return max(coherence)


#: Stops per block of :func:`_alias_coherence` (its temporaries, 8 bytes a stop each, stay small).
_COHERENCE_BLOCK = 1 << 16


#: Stages after which fit_spectral calls ``progress``.
STAGES = 3


def _advance(progress):
    if progress is not None:
        progress()


def _quantisation_orders(bits, grid, theta):
    """Orders where a quantised encoder's rounding lands on a regular grid as a line, or none.

    A reading of a ``bits``-bit encoder is rounded to a whole code. At the ``N`` stops of a regular
    grid the rounding error is a sawtooth of the position in codes, which advances ``2^bits / N``
    codes from one stop to the next, so its ``h``-th harmonic appears at order ``h 2^bits mod N``
    (folded into ``0..N/2``): 44 for a 12-bit encoder at 2° steps. While the readings stray from the
    grid's nodes (by the error, and by the reference's own jitter) over only a few codes
    (:data:`COHERENT_SWING_CODES`) the pattern stays coherent, spread by that swing over the
    neighbouring orders, and looks like a line; but it is no part of the profile, and between the
    stops the rounding has another phase. Those orders carry no line (the background still covers
    them). When the readings swing over many codes the pattern is spread over all orders like
    noise, and no order is excluded.

    Parameters
    ----------
    bits : int or None
        Resolution the readings show (:func:`encal._core.angles.resolution_of_readings`).
    grid : ndarray or None
        Nodes of the regular grid of the stops (degrees), None off a regular grid.
    theta : ndarray
        The readings, degrees.

    Returns
    -------
    ndarray of int
        The orders, sorted (empty when the rounding is no coherent pattern).
    """
    if not bits or grid is None:
        return np.zeros(0, dtype=int)
    stops = grid.size
    spacing = 360.0 / stops
    position = wrap360(theta - grid[0]) / spacing
    stray_codes = (position - np.round(position)) * spacing * 2**bits / 360.0
    if np.ptp(stray_codes) > COHERENT_SWING_CODES:
        return np.zeros(0, dtype=int)
    excluded = set()
    for harmonic in range(1, _ROUNDING_HARMONICS + 1):
        order = harmonic * 2**bits % stops
        order = min(order, stops - order)
        excluded.update(range(max(order - _ROUNDING_WIDTH, 1), order + _ROUNDING_WIDTH + 1))
    return np.array(sorted(k for k in excluded if k <= stops // 2), dtype=int)


def _rounding_reachable(bits, stops):
    """True when a ``bits``-bit encoder's rounding at ``stops`` regular stops lands on an order up to
    :data:`SCAN_LIMIT` (harmonics 1 to :data:`_ROUNDING_HARMONICS`, folded as in :func:`_quantisation_orders`)."""
    folded = [min(h * 2**bits % stops, stops - h * 2**bits % stops) for h in range(1, _ROUNDING_HARMONICS + 1)]
    return min(folded) <= SCAN_LIMIT


def _rounding_harmonics(stops):
    """How many harmonics of the rounding's sawtooth could make a line at ``stops`` stops.

    Harmonic ``h`` carries ``(q/πh)²/2`` of the sawtooth's ``q²/12``; were the rounding white over the ``m``
    stops, each column would hold ``q²/12 / (m/2)``. A pair of columns whose power is ``x`` times its noise
    gains ``x - 1 - ln x`` nats from a line, so a harmonic can make one, even with all its power on one order
    and no other noise, only while ``(q/πh)²/2`` exceeds ``x₃`` times that share, ``x₃ ≈ 5.7`` the ratio at which
    the gain is the 3-nat threshold: ``h² < 3m / (π² x₃)`` (3 at 180 stops, 9 at 1,800, 13 at 3,600), at least
    :data:`_ROUNDING_HARMONICS_SPECTRUM` and at most :data:`_REALISED_HARMONICS`. With a profile of a few codes the
    high harmonics stay coherent: the 4th of a 12-bit encoder at 1,800 stops (16384 mod 1800 = 184) put 4 false
    lines at orders 175-190 when only the first 3 were modelled.
    """
    low, high = 1.0, 100.0  # x₃: x - 1 - ln x = the threshold, on the branch x > 1 (bisection)
    for _ in range(60):
        middle = 0.5 * (low + high)
        if middle - 1.0 - math.log(middle) < _evidence.LINE_THRESHOLD_NATS:
            low = middle
        else:
            high = middle
    harmonics = int(math.sqrt(3.0 * stops / (math.pi**2 * low)))
    return min(max(harmonics, _ROUNDING_HARMONICS_SPECTRUM), _REALISED_HARMONICS)


def _rounding_share(spectrum, quantum, stops, orders, picked=None):
    """What of the rounding's power the noise holds at each of ``orders`` (arc-minutes² per column).

    Parameters
    ----------
    spectrum : ndarray
        The rounding's power per column at orders ``0..`` (with ``picked``, at least to the stops' Nyquist order
        ``m/2`` or :data:`SCAN_LIMIT`, the highest order the scan above the cap reads, whichever is lower).
    quantum : float
        The code, arc-minutes.
    stops : int
        The number of stops ``m``.
    orders : ndarray of int
        The orders asked for.
    picked : sequence of int, optional
        Blind (the noise estimated), the orders the scan above the cap picked (see :func:`_orders_above_cap`).

    Notes
    -----
    The noise holds the rounding's variance ``q²/12`` (the convention of :func:`_known_noise`); were the rounding
    white over the ``m`` stops, each column would hold ``q²/12 / (m/2)`` of it, however many columns are fitted.
    (Divided by the highest order fitted, as before, the capped fit's 200 orders each had 9 times that share taken
    out on 3,600 stops.) Blind, the noise is the flat level of the residual. At the orders the scan above the cap
    picked, the residual has shown power far above that level; on a dense sweep it is the rounding, concentrated
    by a profile of a few codes on bands of orders (4096 mod 3600 = 496 and its sidebands, for a 12-bit encoder
    on 3,600 stops). There the noise holds only the rounding's own flat level (the median of its spectrum over
    ``ln 2``), and the band's whole power goes to the columns: with the white share taken out there too, 11-12
    false lines stayed on such sweeps.
    """
    nyquist = max(stops // 2, 1)
    share = np.full(orders.shape, quantum**2 / 12.0 / nyquist)
    if picked is not None and len(picked):
        # the flat level over the orders the scan reads, as the scan's own (10^5 orders of a dense sweep of 2·10^5
        # stops doubled the fit's CPU)
        floor = float(np.median(spectrum[1:min(nyquist, SCAN_LIMIT) + 1])) / math.log(2.0)
        share = np.where(np.isin(orders, picked), np.minimum(share, floor), share)
    return share


def _rounding_variance(bits, theta_deg, error_arcmin, reference_deg, orders, stops, picked=None):
    """Variance per column that a quantised encoder's rounding, spread by the profile, puts on each order.

    A reading ``x`` of a ``bits``-bit encoder is rounded to a whole code: an error
    ``q saw(x/q) = Σ_h (-1)^{h+1} q/(πh) sin(2πh x/q)``. At the stops the unrounded reading is the reference
    plus the profile, so each harmonic ``h`` is a phase-modulated carrier ``exp(2πi h x/q)``: where the profile
    swings over a few codes its power lands on a band of orders around ``h 2^bits`` (folded), the
    sidebands of the modulation, and there it looks like a line, while at a new reading the rounding has
    another phase. With ``x`` estimated from the reference and the profile's low orders (up to
    :data:`_SMOOTH_ORDER`, projected), the expected power of the rounding at each order (averaged over the
    unknown sub-code offset; harmonics ``h = 1..``:func:`_rounding_harmonics`) beyond the share the noise holds
    (:func:`_rounding_share`; ``stops`` the number of stops, ``picked`` blind the orders the scan above the cap
    picked) is returned per column: it joins the prior variance so that the evidence explains it, and the
    posterior of the profile leaves it out.

    Returns
    -------
    ndarray of shape (P,)
        Arc-minutes squared, per column of ``orders`` (0 for order 0).
    """
    highest = int(orders.max())
    # the share at picked orders needs the rounding's spectrum over the orders a fit sees (see _rounding_share)
    spectrum_top = max(highest, min(stops // 2, SCAN_LIMIT)) if picked is not None and len(picked) else highest
    n = error_arcmin.size
    reference = np.radians(reference_deg)
    # the profile's strong low orders, projected (the stops spread over the circle): what moves the readings
    top = max(1, min(_SMOOTH_ORDER, highest // 2))
    coefficients = 2.0 * np.conj(trig_moments(reference, error_arcmin - np.mean(error_arcmin), top)) / n
    coefficients[0] = np.mean(error_arcmin)
    smooth = trig_series(coefficients, reference)
    codes = (reference_deg + smooth / ARCMIN_PER_DEG) * (2**bits / 360.0)
    theta = np.radians(theta_deg)
    quantum = ARCMIN_PER_DEG * 360.0 / 2**bits
    expected = np.zeros(spectrum_top + 1)
    # (past ROUNDING_GRID_MAX_READINGS readings the first three only: each harmonic costs readings x orders)
    harmonics = _rounding_harmonics(stops) if n <= ROUNDING_GRID_MAX_READINGS else _ROUNDING_HARMONICS_SPECTRUM
    for h in range(1, harmonics + 1):
        carrier = 2.0 * math.pi * h * codes
        cos_sum = trig_moments(theta, np.cos(carrier), spectrum_top)
        sin_sum = trig_moments(theta, np.sin(carrier), spectrum_top)
        spread = np.abs(cos_sum + 1j * sin_sum) ** 2 + np.abs(cos_sum - 1j * sin_sum) ** 2
        expected += 0.5 * (quantum / (math.pi * h)) ** 2 * spread / n**2
    orders_up = np.arange(highest + 1)
    excess = np.maximum(expected[:highest + 1] - _rounding_share(expected, quantum, stops, orders_up, picked), 0.0)
    excess[0] = 0.0
    return excess[orders]


def _realised_rounding(bits, theta_deg, centred_arcmin, design, hyper, post, stops, blind=False):
    """The rounding's variance per column from its realised pattern at the stops, and the lines it explains.

    The rounding to whole codes is a known function of the unrounded reading ``x``: ``round(x) - x``.
    :func:`_rounding_variance` averages its power over the sub-code offset, but at one run the pattern
    is one draw, whose sidebands scatter about that average (up to 4 times it on a 12-bit encoder at
    2° steps, where 7 false lines over 8 encoders stayed). Here ``x`` is estimated as the reading
    minus the error plus the first fit's profile at each reading; ``τ``, the uncertainty of that estimate,
    smooths the sawtooth (each harmonic ``h`` damped by ``exp(-2π²h²τ²/q²)``). ``τ`` is the reading noise
    above the rounding (``σ̂² - q²/12``), but at least :data:`_MIN_TAU_CODES` codes: the profile's
    posterior standard deviation would overstate it, as the Gaussian model counts the rounding as noise
    (0.55-0.67 arcmin against 0.15 of noise on the 12-bit encoders of ``tests/test_spectral.py``, where 5
    false lines of 8 encoders stayed; with ``τ`` fixed at 0.08, 0.2, 0.5 and 1 arcmin: 1, 0, 3, 21).

    A line of the first fit may itself be the rounding's pattern: to first order, an estimate of ``x``
    that holds it predicts a rounding without it, so the two explanations fit the errors equally well.
    What tells them apart is that ``x`` lies in its reading's code: ``|error - profile| <= q/2`` up to the
    noise. A line is taken as the rounding's (left out of ``x``) when the readings' log-likelihood of
    that, ``Σ log[Φ((e + q/2 - p)/τ) - Φ((e - q/2 - p)/τ)]``, is higher without it.

    Parameters
    ----------
    bits : int
    theta_deg, centred_arcmin : ndarray
        The readings and their errors less ``offset_arcmin`` (the order-0 part, fitted apart).
    design, hyper, post : the first fit (``post`` the profile's part, :func:`_evidence.signal_part`).
    stops : int
        The number of stops; ``blind``: whether the noise is estimated (see :func:`_rounding_share`, which is
        given the design's ``picked`` orders then).

    Returns
    -------
    (ndarray of shape (P,) or None, list of int)
        The rounding's variance per column beyond its white share (arc-minutes²; the design's
        ``rounding``) and the first fit's lines taken as the rounding's pattern; None and [] when no
        line is (the expected pattern is kept then: alone, the realised one added a false line at order
        62 to a 12-bit encoder of the physics world whose readings swing over many codes, M12-10).
    """
    from scipy.special import log_ndtr

    quantum = ARCMIN_PER_DEG * 360.0 / 2**bits
    theta = np.radians(theta_deg)
    highest = int(design.orders.max())

    def series(keep):  # the posterior mean's columns ``keep`` at the readings
        coefficients = np.zeros(highest + 1, dtype=complex)
        np.add.at(coefficients, design.orders[keep], post.mean[keep] * np.exp(-1j * design.shifts[keep]))
        return trig_series(coefficients, theta)

    profile = series(np.ones(design.orders.size, dtype=bool))
    reading_var = max(hyper.noise_var - quantum**2 / 12.0, 0.0)
    tau = math.sqrt(max(reading_var, (_MIN_TAU_CODES * quantum) ** 2))

    def in_codes(p):  # log-likelihood that each unrounded reading lies in its code
        upper = log_ndtr((centred_arcmin + 0.5 * quantum - p) / tau)
        lower = log_ndtr((centred_arcmin - 0.5 * quantum - p) / tau)
        return float(np.sum(upper + np.log1p(-np.exp(np.minimum(lower - upper, -1e-12)))))

    taken = []
    base = in_codes(profile)
    for order in sorted(hyper.lines):
        line = series(design.orders == order)
        if in_codes(profile - line) >= base - _CELL_TIE_NATS:
            taken.append(int(order))
            profile = profile - line
            base = in_codes(profile)
    if not taken:
        return None, taken
    codes = (theta_deg - (centred_arcmin - profile) / ARCMIN_PER_DEG) * (2**bits / 360.0)
    pattern = np.zeros_like(codes)
    for h in range(1, _REALISED_HARMONICS + 1):
        damping = math.exp(-2.0 * (math.pi * h * tau / quantum) ** 2)
        if damping < 1e-4:
            break
        pattern -= (-1) ** (h + 1) * quantum / (math.pi * h) * damping * np.sin(2.0 * math.pi * h * codes)
    spectrum_top = max(highest, min(stops // 2, SCAN_LIMIT)) if blind and design.picked is not None else highest
    per_column = 2.0 * np.abs(trig_moments(theta, pattern, spectrum_top)) ** 2 / theta.size**2
    orders_up = np.arange(highest + 1)
    excess = np.maximum(per_column[:highest + 1]
                        - _rounding_share(per_column, quantum, stops, orders_up, design.picked if blind else None), 0.0)
    excess[0] = 0.0
    return excess[design.orders], taken


def _prior_text(source):
    if source == "supplied":
        return "noise supplied by the user; background, lines by maximum likelihood"
    if source == "repeated readings":
        return "noise from repeated readings at the same reference angle; background, lines by maximum likelihood"
    if BLIND_SPLIT != DEFAULT_BLIND_SPLIT:  # a benchmark's variant (bench_worlds.py --blind)
        return BLIND_PRIOR.replace(_BLIND_SPLIT_WORDS, f"by the rule {BLIND_SPLIT!r} (a benchmark's variant)")
    return BLIND_PRIOR


def _stored_orders(cos, sin, sigma):
    """Orders kept in the model file and the RMS (arcmin) of the posterior-mean terms left out.

    Every order is kept up to :data:`STORED_ORDERS_LIMIT` orders; a longer series (a dense
    calibration on the FFT path) keeps its largest terms while the RMS left out stays below
    a thousandth of the noise, and never more than that limit (nor an order above the
    model file's largest, :data:`~encal.models.fourier.MAX_ORDER`).
    """
    orders = np.arange(cos.size)
    power = 0.5 * (cos**2 + sin**2)
    power[0] = cos[0] ** 2
    allowed = orders <= MAX_ORDER
    if cos.size <= STORED_ORDERS_LIMIT:
        return orders, 0.0
    ranked = np.argsort(np.where(allowed, power, -1.0))[::-1]
    tail = np.cumsum(power[ranked][::-1])[::-1]  # power of ranked[i:] for each i
    budget = (1e-3 * sigma) ** 2
    count = int(np.argmax(np.r_[tail[1:], 0.0] <= budget)) + 1
    count = min(max(count, 1), STORED_ORDERS_LIMIT, int(allowed.sum()))
    kept = np.sort(ranked[:count])
    dropped = float(np.sqrt(max(power.sum() - power[kept].sum(), 0.0)))
    return kept, dropped


def _posterior_std(design, post, highest, sigma, nyquist=None):
    """The model file's uncertainty: posterior std of the profile on a uniform grid, and the noise.

    ``nyquist``: ``(order, shift, value, prior variance)`` of a regular grid's Nyquist column, left out
    of the correction (safeguard 3). The profile then misses ``value · cos(order θ - shift)``, known, and
    the sine of that order, which the grid cannot see and which has the column's prior variance: both
    count in the model's uncertainty, ``value² cos² + prior sin²``, the second between the nodes.
    """
    points = int(min(max(360, 4 * highest), _STD_GRID_LIMIT))
    theta = 2.0 * math.pi * np.arange(points) / points
    if design.diagonal:
        # Σ_j v_j cos²(ν_j θ - ψ_j) = ½ Σ v_j + ½ Re Σ v_j e^{-2iψ_j} e^{2iν_j θ}, exactly on the grid.
        spectrum = np.zeros(points, dtype=complex)
        np.add.at(spectrum, (2 * design.orders) % points, post.covariance * np.exp(-2j * design.shifts))
        variance = 0.5 * post.covariance.sum() + 0.5 * np.real(np.fft.ifft(spectrum) * points)
    else:
        features = np.cos(np.multiply.outer(theta, design.orders) - design.shifts)
        variance = np.sum((features @ post.covariance) * features, axis=1)
    for deviation in post.spread if post.spread is not None else ():
        # Σ_j d_j cos(ν_j θ - ψ_j) on the grid, by one FFT of the terms folded onto it
        terms = np.zeros(points, dtype=complex)
        np.add.at(terms, design.orders % points, deviation * np.exp(-1j * design.shifts))
        variance = variance + np.real(np.fft.ifft(terms) * points) ** 2
    if nyquist is not None:
        order, shift, value, prior = nyquist
        phase = order * theta - shift
        variance = variance + value**2 * np.cos(phase) ** 2 + prior * np.sin(phase) ** 2
    return {
        "method": "posterior",
        "grid_step_deg": 360.0 / points,
        "model_std_arcmin": [float(v) for v in np.sqrt(np.maximum(variance, 0.0))],
        "noise_std_arcmin": float(sigma),
    }
