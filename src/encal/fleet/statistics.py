"""Statistics of a fleet of calibrated units: mean profile, spread per harmonic order, units that stand out, drift.

Every unit's model is evaluated on a grid of encoder angles and its zero offset removed (a motor's or
a mount's zero is arbitrary); the profile's harmonics ``c_k`` (complex, arc-minutes: the term
``|c_k| cos(kθ + arg c_k)``) are what the fleet is compared on. The mean profile keeps the phases as
measured, which is meaningful on a station whose reference holds every unit the same way; the
amplitudes ``|c_k|`` do not depend on how a unit was mounted.

A unit *stands out* when its robust score exceeds :data:`STANDS_OUT`: the modified z-score of
Iglewicz and Hoaglin, ``(x - median) / (1.4826 MAD)``, of ``d^(2/3)``, ``d`` the RMS distance of its
profile from the fleet's median profile (overall), or of its amplitude at one order (per order).
Median and MAD are not dragged by the outliers they are to find, as a mean and standard deviation
are. A distance is skewed (a chi-like variable), and its own modified z flagged 1.3% of 25 Gaussian
units; its 2/3 power (Wilson and Hilferty's transform of a chi-square) is near-normal and flags 0.3
to 0.6% (200 simulated fleets of 25 units with 1, 3 and 10 dimensions of spread).
"""

import math
from dataclasses import dataclass

import numpy as np

from .._core.errors import InputError

__all__ = ["FleetStatistics", "fleet_statistics", "robust_scores", "unit_profiles", "drift_table", "STANDS_OUT",
           "GRID_POINTS", "ORDERS", "DRIFT_MOVED", "profile_uncertainty"]

#: Robust score above which a unit stands out (Iglewicz and Hoaglin's cut for the modified z-score).
STANDS_OUT = 3.5
#: Points per turn on which every model is evaluated.
GRID_POINTS = 360
#: Highest harmonic order compared across units.
ORDERS = 40
#: A unit's profile *moved* when its RMS change exceeds this many times the two epochs' profile uncertainties
#: combined (``sqrt(u_first² + u_last²)``). Unchanged repeats give a ratio near 1: 0.73 to 1.02 over 20 units of
#: ``encal.simulate``, each calibrated twice with fresh noise (``python benchmarks/bench_fleet_drift_verdict.py``).
DRIFT_MOVED = 3.0
#: 1.4826 MAD estimates the standard deviation of a normal sample.
_MAD_TO_STD = 1.4826


def robust_scores(values, axis=0):
    """Modified z-scores ``(x - median) / (1.4826 MAD)`` along ``axis``.

    A MAD of zero (over half the values equal) scores those values 0 and any other +-inf.
    """
    values = np.asarray(values, dtype=float)
    median = np.median(values, axis=axis, keepdims=True)
    scale = _MAD_TO_STD * np.median(np.abs(values - median), axis=axis, keepdims=True)
    with np.errstate(divide="ignore", invalid="ignore"):
        scores = (values - median) / scale
    return np.where(values == median, 0.0, scores)


def unit_profiles(records, points=GRID_POINTS):
    """Each record's model on ``points`` encoder angles, its mean (zero offset) removed, arc-minutes.

    Returns
    -------
    grid_deg : ndarray of shape (points,)
    profiles : ndarray of shape (len(records), points)
    """
    grid = np.arange(points) * (360.0 / points)
    profiles = np.empty((len(records), points))
    for index, record in enumerate(records):
        profile = np.asarray(record.model().predict(grid), dtype=float)
        profiles[index] = profile - profile.mean()
    return grid, profiles


def harmonics(profiles, orders=ORDERS):
    """Complex harmonics ``c_k = a_k + i b_k``, k = 1..orders, of profiles ``Σ a_k cos kθ + b_k sin kθ`` on a uniform
    grid (arc-minutes of amplitude; the fleet compares their moduli and their means across units)."""
    points = profiles.shape[-1]
    spectrum = np.fft.rfft(profiles, axis=-1) * (2.0 / points)
    return np.conj(spectrum[..., 1:min(orders, points // 2 - 1) + 1])


@dataclass
class FleetStatistics:
    """The fleet's statistics from the latest record of every unit.

    Attributes
    ----------
    records : list of Record
        The latest record of each unit, by serial number.
    grid_deg : ndarray of shape (m,)
    profiles : ndarray of shape (n, m)
        Each unit's profile (arc-minutes), zero offset removed.
    mean_profile, spread_profile, median_profile : ndarray of shape (m,)
        Mean, standard deviation and median across units at each angle (arc-minutes).
    orders : ndarray of shape (K,)
        Harmonic orders 1..K.
    coefficients : ndarray of shape (n, K), complex
        Each unit's harmonics (arc-minutes).
    amplitude_median, amplitude_mad, amplitude_mean, amplitude_std : ndarray of shape (K,)
        Of ``|c_k|`` across units (arc-minutes; the MAD unscaled).
    mean_amplitude : ndarray of shape (K,)
        ``|mean c_k|``: the order's amplitude in the mean profile (phases as measured).
    order_scores : ndarray of shape (n, K)
        Robust score of each unit's amplitude at each order.
    distance_arcmin : ndarray of shape (n,)
        RMS distance of each unit's profile from the median profile.
    overall_scores : ndarray of shape (n,)
        Robust score of that distance's 2/3 power.
    """

    records: list
    grid_deg: np.ndarray
    profiles: np.ndarray
    mean_profile: np.ndarray
    spread_profile: np.ndarray
    median_profile: np.ndarray
    orders: np.ndarray
    coefficients: np.ndarray
    amplitude_median: np.ndarray
    amplitude_mad: np.ndarray
    amplitude_mean: np.ndarray
    amplitude_std: np.ndarray
    mean_amplitude: np.ndarray
    order_scores: np.ndarray
    distance_arcmin: np.ndarray
    overall_scores: np.ndarray

    @property
    def serials(self):
        return [record.serial for record in self.records]

    def standing_out(self, threshold=STANDS_OUT):
        """The units whose overall score exceeds ``threshold``, most first: (index, score, worst order, its score)."""
        rows = []
        for index in np.flatnonzero(self.overall_scores > threshold):
            worst = int(np.nanargmax(self.order_scores[index]))
            rows.append((int(index), float(self.overall_scores[index]), int(self.orders[worst]),
                         float(self.order_scores[index, worst])))
        return sorted(rows, key=lambda row: -row[1])

    def orders_standing_out(self, threshold=STANDS_OUT):
        """Per order, how many units' amplitude scores exceed ``threshold``."""
        return (self.order_scores > threshold).sum(axis=0)


def latest_per_serial(records):
    """The latest epoch of every serial among ``records``, by serial number."""
    latest = {}
    for record in records:
        if record.serial not in latest or record.epoch > latest[record.serial].epoch:
            latest[record.serial] = record
    return [latest[serial] for serial in sorted(latest)]


def fleet_statistics(records, *, orders=ORDERS, points=GRID_POINTS):
    """The statistics of the fleet in ``records`` (the latest epoch of each serial number calibrated over the
    whole turn is used).

    Parameters
    ----------
    records : sequence of encal.store.Record
        At least 3 units.
    orders : int, default=ORDERS
    points : int, default=GRID_POINTS

    Returns
    -------
    FleetStatistics

    Raises
    ------
    InputError
        With fewer than 3 units (a median and a MAD need a few).
    """
    # a unit calibrated over an arc has no profile over the whole turn to compare (its model is NaN outside)
    every = latest_per_serial(records)
    latest = [record for record in every if record.model().range_deg is None]
    if len(latest) < 3:
        arcs = len(every) - len(latest)
        raise InputError(f"the store holds {len(latest)} unit(s) calibrated over the whole turn"
                         + (f" (and {arcs} over an arc only, whose models hold on their arc)" if arcs else "")
                         + "; expected 3 or more over the whole turn for fleet statistics (a median and its spread)")
    grid, profiles = unit_profiles(latest, points)
    coefficients = harmonics(profiles, orders)
    amplitudes = np.abs(coefficients)
    median_profile = np.median(profiles, axis=0)
    distance = np.sqrt(np.mean((profiles - median_profile) ** 2, axis=1))
    amplitude_median = np.median(amplitudes, axis=0)
    return FleetStatistics(
        records=latest, grid_deg=grid, profiles=profiles, mean_profile=profiles.mean(axis=0),
        spread_profile=profiles.std(axis=0, ddof=1), median_profile=median_profile,
        orders=np.arange(1, coefficients.shape[1] + 1), coefficients=coefficients,
        amplitude_median=amplitude_median,
        amplitude_mad=np.median(np.abs(amplitudes - amplitude_median), axis=0),
        amplitude_mean=amplitudes.mean(axis=0), amplitude_std=amplitudes.std(axis=0, ddof=1),
        mean_amplitude=np.abs(coefficients.mean(axis=0)), order_scores=robust_scores(amplitudes, axis=0),
        distance_arcmin=distance, overall_scores=robust_scores(distance ** (2.0 / 3.0)))


def profile_uncertainty(record, model=None):
    """The standard uncertainty of a record's profile, RMS over the turn (arc-minutes), and what it comes from.

    The model's own uncertainty (``σ_model(θ)``, the spectral posterior's or a bootstrap's, without a new reading's
    noise) when the model file holds it; otherwise the record's held-out estimate, which holds a new reading's noise
    as well and so overstates the profile's uncertainty (a change found larger than it is larger than the
    uncertainty still); None when the record has neither.

    Returns
    -------
    (float, str) or (None, None)
        The uncertainty and its basis, ``'posterior'`` (the model's table) or ``'held-out'``.
    """
    model = record.model() if model is None else model
    table = (getattr(model, "uncertainty", None) or {}).get("model_std_arcmin")
    if table is not None and len(table):
        return float(np.sqrt(np.mean(np.square(np.asarray(table, dtype=float))))), "posterior"
    if record.held_out_arcmin is not None:
        return float(record.held_out_arcmin), "held-out"
    return None, None


def drift_table(records, points=GRID_POINTS):
    """How the profile of each unit calibrated more than once moved from its first epoch, and whether that is more
    than the two calibrations' uncertainty.

    The store holds each epoch's model, not its raw data, so the verdict compares the change with what the models
    say of their own uncertainty (:func:`profile_uncertainty`): the profile *moved* when the RMS change from the
    first to the last epoch exceeds :data:`DRIFT_MOVED` times ``sqrt(u_first² + u_last²)``, the RMS change two
    independent calibrations of an unchanged unit would show.

    Returns
    -------
    list of dict
        One per serial with 2 or more epochs: ``serial``, ``epochs`` (their numbers), ``drift_arcmin`` (RMS
        of each epoch's profile minus the first's, zero offset removed; 0 for the first), ``largest_order``
        and ``largest_change_arcmin`` (the order whose harmonic moved most from the first to the last epoch),
        ``uncertainty_arcmin`` (``sqrt(u_first² + u_last²)``, or None), ``basis`` (``'posterior'`` when both
        models hold their uncertainty, ``'held-out'`` when either is the held-out estimate, or None) and ``verdict``
        (``'moved'``; ``'within'`` :data:`DRIFT_MOVED` times the uncertainty, not shown to move; or None without
        an uncertainty for both epochs or with a model of an arc, whose profile over the turn is not known).
    """
    by_serial = {}
    for record in records:
        by_serial.setdefault(record.serial, []).append(record)
    rows = []
    for serial in sorted(by_serial):
        history = sorted(by_serial[serial], key=lambda record: record.epoch)
        if len(history) < 2:
            continue
        _, profiles = unit_profiles(history, points)
        change = profiles - profiles[0]
        drift = [float(math.sqrt(np.mean(c**2))) for c in change]
        moved = np.abs(harmonics(profiles[-1] - profiles[0]))
        largest = int(np.argmax(moved)) if np.all(np.isfinite(moved)) else None
        (first, first_basis), (last, last_basis) = profile_uncertainty(history[0]), profile_uncertainty(history[-1])
        uncertainty = basis = verdict = None
        if first is not None and last is not None and math.isfinite(drift[-1]):
            uncertainty = float(math.hypot(first, last))
            basis = "posterior" if first_basis == last_basis == "posterior" else "held-out"
            verdict = "moved" if drift[-1] > DRIFT_MOVED * uncertainty else "within"
        rows.append({"serial": serial, "epochs": [record.epoch for record in history], "drift_arcmin": drift,
                     "largest_order": None if largest is None else largest + 1,
                     "largest_change_arcmin": None if largest is None else float(moved[largest]),
                     "uncertainty_arcmin": uncertainty, "basis": basis, "verdict": verdict})
    return rows
