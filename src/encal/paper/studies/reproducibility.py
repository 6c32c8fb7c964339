"""Reproducibility of an error profile across calibrations (the paper's repeat epochs and second decoder).

The paper calibrates each encoder again at later epochs and finds the profiles
"near reproducible, to within the limits of the decoder resolution"; it also
finds that one resolver read by two decoders differs by about 2 arcmin, and
so calibrates each resolver-decoder pair as one unit. This study measures
both: the difference between a repeat calibration and the first one at the
same reference angles (statistics, and the share of points within one LSB),
and the residual left when the model fitted to the first calibration corrects
the repeat, which is what a user of an old calibration gets.
"""

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ..._core.angles import lsb_arcmin
from ...data.calibration import MAX_BITS
from ...reports.drift import match_profile
from ..._core.errors import InputError
from ...models.fitting import evaluate, fit
from ...models.base import Model
from ..._core.parameters import check_int, check_number, check_type, invalid
from ...analysis.profile import error_stats
from ._checks import check_calibration, check_seed
from ._fits import task_seed
from ..._core.threads import single_blas_thread

__all__ = ["RepeatRun", "Reproducibility", "reproducibility", "matched_difference"]


@dataclass(frozen=True, eq=False)
class RepeatRun:
    """A repeat calibration compared with the first.

    Attributes
    ----------
    label : str
        Name of the repeat (``'epoch2'``, ``'decoder2'``).
    reference_deg : ndarray of shape (m,)
        Reference angles present in both calibrations, degrees.
    difference_arcmin : ndarray of shape (m,)
        Error of the repeat minus error of the first calibration at those angles, arcmin.
    difference : ErrorStats
        Statistics of ``difference_arcmin``.
    within_one_lsb : float or None
        Share of the points whose difference is at most one LSB (None when the resolution is unknown).
    model_residual : ErrorStats
        Residual of the repeat after correction by the model fitted to the first calibration, arcmin.
    floor_arcmin : float or None
        Measurement floor of the repeat run, when known.
    """

    label: str
    reference_deg: np.ndarray
    difference_arcmin: np.ndarray
    difference: object
    within_one_lsb: float | None
    model_residual: object
    floor_arcmin: float | None = None


@dataclass(frozen=True, eq=False)
class Reproducibility:
    """Repeat calibrations of one encoder against its first calibration.

    Attributes
    ----------
    encoder : str
    resolution_bits : int or None
    lsb_arcmin : float or None
        One LSB, arcmin.
    model : Model
        The model fitted to the first calibration.
    first_test_residual : ErrorStats or None
        That model's residual on the first epoch's test run (for comparison), arcmin.
    runs : tuple of RepeatRun
    """

    encoder: str
    resolution_bits: int | None
    lsb_arcmin: float | None
    model: object
    first_test_residual: object
    runs: tuple

    def run(self, label):
        """The repeat with this label."""
        for run in self.runs:
            if run.label == label:
                return run
        raise KeyError(label)

    def table(self):
        """The comparison as a :class:`~encal.paper.studies.tables.Table`."""
        from .tables import reproducibility_table

        return reproducibility_table({self.encoder: self})

    def plot(self, ax=None):
        """Differences against the reference angle with the one-LSB band (see :func:`encal.figures.plot_repeats`)."""
        from ...figures import plot_repeats

        return plot_repeats(self, ax=ax)


def matched_difference(first, repeat, tolerance_deg=1e-3):
    """Error of ``repeat`` minus error of ``first`` at the reference angles both contain.

    Each point of ``repeat`` is paired with the point of ``first`` whose reference angle is nearest (round the
    circle); pairs further apart than ``tolerance_deg`` are left out. The comparison is drift's
    (:func:`encal.reports.drift.match_profile`).

    Parameters
    ----------
    first, repeat : Calibration
    tolerance_deg : float, default=1e-3
        Largest difference of reference angles (degrees, 3.6 arcsec) that counts as the same point.

    Returns
    -------
    reference_deg : ndarray of shape (m,)
        Reference angles of the paired points of ``repeat``, increasing, degrees.
    difference_arcmin : ndarray of shape (m,)

    Raises
    ------
    InputError
        If fewer than 8 points pair up.

    Examples
    --------
    >>> from encal import Calibration
    >>> ref = np.arange(0.0, 360.0, 10.0)
    >>> a, b = Calibration(ref, ref), Calibration(ref + 1e-5, ref + 1e-5 + 1 / 60)
    >>> round(float(matched_difference(a, b)[1].max()), 9)
    1.0
    """
    check_calibration(first, "first", "matched_difference")
    check_calibration(repeat, "repeat", "matched_difference")
    tolerance_deg = check_number(tolerance_deg, "tolerance_deg", "matched_difference", low=0.0, low_open=True)
    wanted = repeat.reference_deg
    expected, paired = match_profile(first.reference_deg, first.errors_arcmin, wanted, tolerance_deg)
    if np.count_nonzero(paired) < 8:
        raise InputError(f"the repeat calibration {repeat.name or ''!s} shares {np.count_nonzero(paired)} "
                         f"reference angles (within {tolerance_deg:g} deg) with the first one; expected at least "
                         "8 common angles to compare the profiles")
    reference = wanted[paired]
    difference = repeat.errors_arcmin[paired] - expected[paired]
    sort = np.argsort(reference)
    return reference[sort], difference[sort]


@single_blas_thread
def reproducibility(first, repeats, *, model=None, test=None, resolution_bits=None, floors=None, rng=0):
    """Compare repeat calibrations with the first one, and correct them with the first one's model.

    Parameters
    ----------
    first : Calibration
        The first calibration (the one a model is fitted to).
    repeats : mapping of str to Calibration
        Repeat calibrations by label (a later epoch, another decoder).
    model : Model, optional
        Model fitted to ``first``; default encal's periodic network (:func:`encal.fit` with ``method='ann'``).
    test : Calibration, optional
        The first epoch's test run, to show the model's residual without drift beside the repeats'.
    resolution_bits : int, optional
        Encoder resolution for the one-LSB share; default ``first.resolution_bits``.
    floors : mapping of str to float, optional
        Measurement floor of each repeat (arcmin), when known.
    rng : int, default=0
        Seed of the default model.

    Returns
    -------
    Reproducibility
    """
    where = "reproducibility"
    first = check_calibration(first, "first", where)
    check_type(repeats, Mapping, "repeats", where, "a mapping of labels to repeat Calibrations")
    if not repeats:
        raise invalid("repeats", where, "a mapping of labels to repeat Calibrations, at least one", repeats)
    repeats = {str(label): check_calibration(cal, f"repeats[{label}]", where) for label, cal in repeats.items()}
    if test is not None:
        test = check_calibration(test, "test", where)
    seed = check_seed(rng, where)
    if model is not None:
        check_type(model, Model, "model", where, "a Model or None")
    if resolution_bits is not None:
        resolution_bits = check_int(resolution_bits, "resolution_bits", where, low=1, high=MAX_BITS,
                                    note="or None: the first calibration's")
    floors = check_type({} if floors is None else floors, Mapping, "floors", where,
                        "a mapping of labels to arc-minutes, or None")
    floors = {label: check_number(value, f"floors[{label}]", where, low=0.0, note="arc-minutes")
              for label, value in floors.items()}
    if model is None:
        model = fit(first, "ann", rng=task_seed(seed, 12, 0), encoding="periodic")
    bits = resolution_bits if resolution_bits is not None else first.resolution_bits
    lsb = None if bits is None else lsb_arcmin(bits)
    runs = []
    for label, cal in repeats.items():
        reference, difference = matched_difference(first, cal)
        within = None if lsb is None else float(np.mean(np.abs(difference) <= lsb * (1 + 1e-9)))
        runs.append(RepeatRun(label, reference, difference, error_stats(difference), within,
                              evaluate(model, cal).after, floors.get(label)))
    return Reproducibility(
        encoder=first.name, resolution_bits=bits, lsb_arcmin=lsb, model=model,
        first_test_residual=None if test is None else evaluate(model, test).after, runs=tuple(runs))
