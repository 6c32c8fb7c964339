"""The default choice of ``fit(method='auto')``: the empirical-Bayes spectral model.

Interleaved k-fold cross-validation cannot see orders between ``n/4`` and ``n/2`` of a grid of ``n``
stops: a held-out point sits between neighbours two steps apart, so content in that band counts
as pure error, and CV scores a smooth series against an interpolating table unfairly
(docs/model-selection.md). The decision between smooth and interpolating belongs to the spectrum:
the empirical-Bayes spectral model (:mod:`encal.models.spectral`) covers every order up to the
Nyquist order and lets the evidence decide, order by order, how much of each to keep. It is the
answer of ``auto``: O(n log n) on a uniform grid, O(n) plus O(K³) elsewhere.

Networks are not tried by default. A network or the hybrid follows a local defect that a decaying
spectrum shrinks, but cross-validating them against the spectral model made auto worse where it
was measured (docs/model-selection.md): with ``networks=True`` they are cross-validated over
interleaved folds and one replaces the spectral model only if its CV RMS is lower by more than
:data:`NETWORK_MARGIN`.

Passing ``candidates``, ``folds``, ``tolerance``, ``use_grid`` or ``stack`` asks for the
cross-validated choice among the given families instead (:func:`encal.models.select.fit_auto`).
"""

import time

import numpy as np

from ..analysis.profile import profile_arrays
from . import select
from .spectral import fit_spectral

__all__ = ["fit_auto", "NETWORK_CANDIDATES", "NETWORK_STOPS_LIMIT", "NETWORK_MARGIN", "format_choice", "Selection"]

#: With ``networks=True``, networks are tried only on calibrations of at most this many stops.
NETWORK_STOPS_LIMIT = 400
#: A network replaces the spectral model only when its CV RMS is lower by more than this fraction.
NETWORK_MARGIN = 0.03
#: The network candidates (the hybrid, and the two larger periodic networks of the CV choice).
NETWORK_CANDIDATES = (
    select.Candidate("hybrid", {}),
    select.Candidate("ann", {"hidden": 12, "algorithm": "trainlm", "epochs": 300}),
    select.Candidate("ann", {"hidden": 20, "algorithm": "trainlm", "epochs": 300}),
)
_CV_OPTIONS = ("candidates", "folds", "tolerance", "use_grid", "stack")


def fit_auto(theta_enc_deg, error_arcmin, *, rng=None, noise_arcmin=None, networks=False, progress=None,
             **cv_options):
    """Fit the spectral model, or a network where a network cross-validates clearly better.

    Parameters
    ----------
    theta_enc_deg : array-like of shape (n,)
        Encoder angles in degrees.
    error_arcmin : array-like of shape (n,)
        Errors ``encoder - reference`` in arc-minutes.
    rng : int or numpy.random.Generator, optional
        Seed of the networks; the same seed gives the same model.
    noise_arcmin : float, optional
        The noise of one reading, when known (see :func:`~encal.models.spectral.fit_spectral`).
    networks : bool, default=False
        Also cross-validate the networks against the spectral model (on calibrations of at most
        :data:`NETWORK_STOPS_LIMIT` stops).
    progress : callable, optional
        Passed to :func:`~encal.models.spectral.fit_spectral`.
    **cv_options
        ``candidates``, ``folds``, ``tolerance``, ``use_grid``, ``stack``: choose among the given
        candidates by cross-validation instead (:func:`encal.models.select.fit_auto`).

    Returns
    -------
    Model
        With ``training['selection']``: ``scheme`` (``'evidence'``), ``chosen``, ``reason`` and
        the CV ``table`` of the spectral model and the networks when they were tried.
    """
    unknown = set(cv_options) - set(_CV_OPTIONS)
    if unknown:
        from .._core.errors import InputError

        raise InputError(f"fit_auto got unexpected options {', '.join(sorted(unknown))}; expected "
                         f"noise_arcmin, networks, rng or the cross-validation options {', '.join(_CV_OPTIONS)}")
    if cv_options:
        return select.fit_auto(theta_enc_deg, error_arcmin, rng=rng, **cv_options)
    theta, error = profile_arrays(theta_enc_deg, error_arcmin, "fit_auto")
    start = time.perf_counter()
    spectral = fit_spectral(theta, error, noise_arcmin=noise_arcmin, progress=progress)
    stops = spectral.training["stops"]
    if networks and stops > NETWORK_STOPS_LIMIT:
        reason = (f"the spectral model (evidence); networks not tried on {stops} stops (more than "
                  f"{NETWORK_STOPS_LIMIT})")
        networks = False
    else:
        reason = "the spectral model (evidence)"
    selection = {"scheme": "evidence", "folds": None, "table": [], "chosen": "spectral", "reason": reason}
    model = spectral
    if networks:
        model, selection = _against_networks(theta, error, spectral, rng)
    model.training["selection"] = {**selection, "time_s": time.perf_counter() - start}
    model.training["seed"] = int(rng) if isinstance(rng, (int, np.integer)) else None
    model.training["fit_options"] = {"noise_arcmin": noise_arcmin, "networks": bool(networks)}
    return model


def _against_networks(theta, error, spectral, rng):
    """Cross-validate the spectral model (its noise fixed at the full fit's) and the networks."""
    folds = min(select.DEFAULT_FOLDS, max(2, spectral.training["stops"] // select.MIN_POINTS_PER_FOLD))
    fold = select.interleaved_folds(theta, folds)
    sigma = spectral.training["noise"]["std_arcmin"]
    reference = select.Candidate("spectral", {"noise_arcmin": sigma} if sigma > 0 else {})
    candidates = (reference, *NETWORK_CANDIDATES)
    streams = [seq.spawn(folds + select.FINAL_FIT_ATTEMPTS)
               for seq in select._seed_sequence(rng).spawn(len(candidates))]
    scores = [select.cross_validate(theta, error, c, fold, seeds=s[:folds]) for c, s in zip(candidates, streams)]
    table = [score.as_dict() for score in scores]
    base = scores[0].rms_arcmin
    best = min(scores[1:], key=lambda score: score.rms_arcmin)
    selection = {"scheme": "evidence", "folds": int(folds), "table": table}
    resolution = 1e-9 * float(np.sqrt(np.mean(error**2)))  # differences below it are rounding
    if np.isfinite(best.rms_arcmin) and best.rms_arcmin < (1.0 - NETWORK_MARGIN) * base - resolution:
        model, attempts = select._final_fit(theta, error, best, streams[scores.index(best)][folds:])
        selection.update(chosen=best.candidate.label, final_fit_attempts=attempts,
                         reason=(f"{best.candidate.label} cross-validates {best.rms_arcmin:.4g} arcmin, more than "
                                 f"{NETWORK_MARGIN:.0%} below the spectral model's {base:.4g}: a local feature "
                                 "that a decaying spectrum shrinks"))
        return model, selection
    selection.update(chosen="spectral",
                     reason=(f"the spectral model (evidence); the best network, {best.candidate.label}, "
                             f"cross-validates {best.rms_arcmin:.4g} arcmin against its {base:.4g}, "
                             f"not {NETWORK_MARGIN:.0%} lower"))
    return spectral, selection


def format_choice(selection):
    """The choice of an evidence-based auto fit, as text for a terminal."""
    lines = []
    if selection.get("table"):
        lines.append(f"spectral model against the networks, {selection['folds']} interleaved folds (arcmin):")
        width = max(len(row["label"]) for row in selection["table"])
        lines.append(f"    {'candidate':<{width}}  {'CV RMS':>9}  {'time':>7}")
        for row in selection["table"]:
            mark = "*" if row["label"] == selection["chosen"] or (
                selection["chosen"] == "spectral" and row["family"] == "spectral") else " "
            rms = "failed" if row["cv_rms_arcmin"] is None else f"{row['cv_rms_arcmin']:#9.4g}"
            seconds = "      -" if row["time_s"] is None else f"{row['time_s']:6.2f}s"
            lines.append(f"  {mark} {row['label']:<{width}}  {rms:>9}  {seconds}")
    lines.append(f"chosen: {selection['reason']}")
    return "\n".join(lines)


def is_chosen(row, selection):
    """Whether a row of a selection table is the candidate chosen (the spectral row when 'spectral' is)."""
    return row["label"] == selection.get("chosen") or (
        selection.get("chosen") == "spectral" and row.get("family") == "spectral")


class Selection:
    """The choice of an automatic fit, readable and drawable.

    Parameters
    ----------
    table : dict
        ``model.training['selection']`` (also after a save/load round trip): the evidence scheme of
        :func:`fit_auto` or the cross-validation of :func:`encal.models.select.fit_auto`.

    ``str(selection)`` is the table and the reason as ``encal fit`` prints them; :meth:`plot` draws the
    cross-validated RMS of every candidate that has one.
    """

    def __init__(self, table):
        self.table = table

    @classmethod
    def of(cls, model):
        """The selection of a model made by ``method='auto'``, or None for any other model."""
        table = model.training.get("selection")
        return None if table is None else cls(table)

    @property
    def chosen(self):
        """Label of the chosen candidate (``'spectral'`` for the spectral model)."""
        return self.table["chosen"]

    @property
    def reason(self):
        """Why it was chosen, in one sentence."""
        return self.table["reason"]

    def rows(self):
        """The candidates with a held-out figure, lowest CV RMS first (failed ones last)."""
        return sorted(self.table.get("table") or [],
                      key=lambda row: (row["cv_rms_arcmin"] is None, row["cv_rms_arcmin"] or 0.0))

    def chosen_row(self):
        """The chosen candidate's row, or None when it has none (the spectral model alone)."""
        return next((row for row in self.rows() if is_chosen(row, self.table)), None)

    def as_dict(self):
        """The JSON-ready table."""
        return self.table

    def __str__(self):
        if self.table.get("scheme") == "evidence":
            return format_choice(self.table)
        return select.format_selection(self.table)

    def plot(self, ax=None):
        """Bars of the CV RMS (arcmin) per candidate, the chosen one marked; returns the axes."""
        from ..figures import plot_selection

        return plot_selection(self.table, ax=ax)
