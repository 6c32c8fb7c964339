"""Error model over an arc: a penalised cubic spline with its smoothing chosen by evidence.

A joint that cannot turn a full revolution is calibrated over an arc ``[start, end]``. There the error is
no periodic function: this kind fits a cubic B-spline on the arc (knots every ``knot_spacing_deg``)
with a second-difference penalty (Eilers and Marx's P-spline), and chooses the penalty's weight by the
restricted marginal likelihood (the evidence with a flat prior on the straight lines the penalty leaves
free; Wood 2011). The posterior gives the model's uncertainty, which grows toward the ends of the arc,
where fewer readings hold the spline.

The model is stored in the model file's ``lut`` form (a piecewise cubic: the spline's own pieces), plus
the two pieces outside the arc, which hold the value of the nearer end (the ``clamp`` rule); the file's
``range_deg`` says where the model holds, and outside it encal and the runtime answer NaN
(:mod:`encal._core.arcs`).
"""

import numpy as np

from .._core.arcs import RANGE_TOLERANCE_DEG, arc_of, span_of
from .._core.errors import InputError
from .._core.parameters import check_number
from .lut import LookupTableModel

__all__ = ["ArcModel", "fit_arc", "MAX_GAP_DEG"]

#: A calibration is an arc when it leaves exactly one gap over this many degrees (encal.data.calibration's rule).
MAX_GAP_DEG = 30.0
#: Most knot intervals of the spline (its cost is linear in them; the evidence chooses the smoothness).
MAX_INTERVALS = 720
#: Grid step of the stored uncertainty table, degrees.
UNCERTAINTY_STEP_DEG = 0.25


class ArcModel(LookupTableModel):
    """A piecewise cubic of the encoder angle, calibrated over the arc ``range_deg`` only.

    Parameters are those of :class:`~encal.models.lut.LookupTableModel` (``interpolation='cubic'``);
    ``range_deg`` is set by :func:`fit_arc` and by the model file.
    """

    kind = "arc"
    form = None  # the format names the kind: stored in the lut form (runtime.KIND_FORMS)

    def __repr__(self):
        name = self.encoder.get("name") or "unnamed encoder"
        where = "no range" if self.range_deg is None else f"{self.range_deg[0]:.4g}..{self.range_deg[1]:.4g} deg"
        return f"<ArcModel over {where}, {self.breaks_deg.size - 3} pieces, for {name}>"

    def full_turn(self, rule):
        """This model over the whole turn for a periodic export: the same pieces on the arc and, outside it,
        the nearer end's value (``rule='clamp'``) or zero (``'pass'``: no correction); ``range_deg`` None.

        At every angle it gives what :func:`encal._core.arcs.apply_outside_rule` gives (``encal correct
        --outside``): within :data:`~encal._core.arcs.RANGE_TOLERANCE_DEG` of an end (the end itself, a reading
        on it rounded) the end's value, as inside; and an angle exactly in the middle of the gap, as far past
        the end as before the start, the end's (``clamp_to_range``). Both were the other way round: under
        ``pass`` the end itself, a code when the calibration's readings were, got no correction, and under
        ``clamp`` the middle of the gap, a code for half such arcs, the start's.
        """
        if self.range_deg is None:
            return self
        breaks = np.asarray(self.breaks_deg, dtype=float)
        coefficients = np.array(self.coefficients, copy=True)
        end_break, middle, turn = breaks[-3], breaks[-2], breaks[-1]
        arc_breaks, arc_pieces = breaks[:-2], coefficients[:, :-2]  # the arc's own pieces (see fit_arc)
        end_value, start_value = coefficients[:, -2:-1], coefficients[:, -1:]
        if rule == "clamp":
            # the piece from the middle on starts one double later: the middle itself is the end's, as in Python
            outside = np.hstack([end_value, start_value])
            breaks = np.concatenate([arc_breaks, [np.nextafter(middle, np.inf), turn]])
        else:
            # the end's value over the tolerance past the end and before the start (inside in Python), zero between
            outside = np.hstack([end_value, np.zeros_like(end_value), start_value])
            tolerance = RANGE_TOLERANCE_DEG
            breaks = np.concatenate([arc_breaks, [end_break + tolerance, turn - tolerance, turn]])
        model = ArcModel(breaks, np.hstack([arc_pieces, outside]), "cubic", encoder=self.encoder,
                         training={**self.training, "outside_rule": rule})
        model.reading_sign = self.reading_sign
        return model

    def expected_rms_between_points(self):
        """Expected RMS error (arcmin) after correction of a new reading inside the arc, from the posterior:
        ``sqrt(mean(sigma_model^2) + sigma_noise^2)`` over the arc; None without an uncertainty."""
        if self.uncertainty is None or self.range_deg is None:
            return None
        from .._core.arcs import inside

        step = float(self.uncertainty["grid_step_deg"])
        table = np.asarray(self.uncertainty["model_std_arcmin"], dtype=float)
        held = inside(np.arange(table.size) * step, self.range_deg)
        return float(np.sqrt(np.mean(table[held] ** 2) + float(self.uncertainty["noise_std_arcmin"]) ** 2))

    def free_parameters(self):
        return int(self.training.get("effective_parameters", self.breaks_deg.size - 1))


def fit_arc(theta_enc_deg, error_arcmin, *, knot_spacing_deg=None, range_deg=None, progress=None):
    """Fit a penalised cubic spline over the arc the readings cover, smoothing chosen by evidence.

    Parameters
    ----------
    theta_enc_deg, error_arcmin : array-like of shape (n,)
        Encoder readings (degrees) and errors (arc-minutes); the readings must cover one arc (one gap
        over 30 degrees round the circle), unless ``range_deg`` is given.
    knot_spacing_deg : float, optional
        Degrees between knots; default: the arc over ``min(720, n_distinct)`` intervals (the penalty, not the
        knots, sets the smoothness).
    range_deg : (float, float), optional
        The arc ``[start, end]``; default: the one the readings cover.
    progress : callable, optional
        Accepted for the command line's progress display; the fit is one step.

    Returns
    -------
    ArcModel
        With ``range_deg``, ``uncertainty`` (the posterior's standard deviation on a 0.25-degree grid and
        the noise's) and, in ``training``, the chosen penalty, the noise and the effective parameters.

    Raises
    ------
    InputError
        If the readings cover the full turn or several separate arcs, or are too few (under 8 distinct).
    """
    from scipy.interpolate import BSpline
    from scipy.linalg import cho_solve_banded, cholesky_banded
    from scipy.optimize import minimize_scalar

    theta = np.mod(np.asarray(theta_enc_deg, dtype=float).reshape(-1), 360.0)
    error = np.asarray(error_arcmin, dtype=float).reshape(-1)
    if theta.shape != error.shape or not np.all(np.isfinite(theta)) or not np.all(np.isfinite(error)):
        raise InputError("fit_arc expects finite encoder angles and errors of the same length; "
                         f"got {theta.size} angles and {error.size} errors")
    if range_deg is None:
        range_deg = arc_of(theta, MAX_GAP_DEG)
        if range_deg is None:
            raise InputError("method 'arc' fits a calibration over one arc (its readings leaving one gap over "
                             f"{MAX_GAP_DEG:g} deg round the circle); these readings cover the full turn or "
                             "several separate arcs (use another method)")
    start = float(range_deg[0])
    span = span_of(range_deg)
    offset = np.mod(theta - start, 360.0)
    offset = np.where(offset > span + 1e-9, 0.0, offset)  # a reading a rounding below start
    distinct = np.unique(offset).size
    if distinct < 8:
        raise InputError(f"method 'arc' needs at least 8 distinct encoder angles over the arc; got {distinct}")
    if knot_spacing_deg is None:
        intervals = int(min(MAX_INTERVALS, distinct))
    else:
        spacing = check_number(knot_spacing_deg, "knot_spacing_deg", "fit_arc", low=1e-6)
        intervals = int(max(1, min(20000, np.ceil(span / spacing))))
    inner = np.linspace(0.0, span, intervals + 1)
    knots = np.concatenate([[0.0] * 3, inner, [span] * 3])
    size = intervals + 3
    design = BSpline.design_matrix(offset, knots, 3)  # sparse n x size, 4 nonzeros a row
    gram = (design.T @ design).toarray()
    rhs = np.asarray(design.T @ error).reshape(-1)
    second = np.diff(np.eye(size), 2, axis=0)
    penalty = second.T @ second
    null_dim, rank = 2, size - 2
    n = error.size

    def banded(matrix, width=3):
        upper = np.zeros((width + 1, size))
        for k in range(width + 1):
            upper[width - k, k:] = np.diagonal(matrix, k)
        return upper

    gram_band, penalty_band = banded(gram), banded(penalty)
    scale = np.trace(gram) / max(np.trace(penalty), 1e-300)
    yty = float(error @ error)

    def criterion(log_lambda):
        weight = scale * np.exp(log_lambda)
        factor = cholesky_banded(gram_band + weight * penalty_band)
        coef = cho_solve_banded((factor, False), rhs)
        # ||y - Bc||^2 + w c'Sc summed as it stands: its equal y'y - c'B'y cancels to rounding when the spline
        # follows the readings closely (clean readings, a strong or a weak penalty), and a deviance of 0 there
        # sent the criterion to its floor (noise 3e-150 arcmin, a straight line over a curved 10-degree arc).
        residual = error - design @ coef
        roughness = float(np.sum(np.diff(coef, 2) ** 2))  # c'Sc, S = D'D the second differences
        deviance = max(float(residual @ residual) + weight * roughness, 1e-300 * max(yty, 1.0))
        log_det = 2.0 * np.sum(np.log(factor[-1]))
        return (max(n - null_dim, 1)) * np.log(deviance) + log_det - rank * np.log(weight), coef, factor, deviance

    grid = np.linspace(-25.0, 25.0, 51)
    values = [criterion(v)[0] for v in grid]
    best = int(np.argmin(values))
    low, high = grid[max(best - 1, 0)], grid[min(best + 1, grid.size - 1)]
    if high > low:
        found = minimize_scalar(lambda v: criterion(v)[0], bounds=(low, high), method="bounded",
                                options={"xatol": 1e-3})
        log_lambda = float(found.x) if found.fun <= values[best] else float(grid[best])
    else:
        log_lambda = float(grid[best])
    _, coef, factor, deviance = criterion(log_lambda)
    noise_var = deviance / max(n - null_dim, 1)
    # effective parameters: trace of the hat matrix, tr(A^-1 B'B)
    inverse = cho_solve_banded((factor, False), np.eye(size))
    effective = float(np.sum(inverse * gram))
    spline = BSpline(knots, coef, 3)

    # the spline's pieces, in PPoly's convention (highest power first), on the encoder angle
    left, middle = inner[:-1], 0.5 * (inner[:-1] + inner[1:])
    pieces = np.vstack([spline(middle, 3) / 6.0, spline(left, 2) / 2.0, spline(left, 1), spline(left)])
    end_value, start_value = float(spline(span)), float(spline(0.0))
    rest = 360.0 - span
    breaks = np.concatenate([start + inner, [start + span + rest / 2.0, start + 360.0]])
    outside = np.zeros((4, 2))
    outside[3] = [end_value, start_value]  # the clamp rule: the nearer end's value
    model = ArcModel(breaks, np.hstack([pieces, outside]), "cubic")
    model.range_deg = [float(start), float(np.mod(start + span, 360.0))]

    # posterior standard deviation of the spline on a grid of the circle (the end's value outside)
    step = UNCERTAINTY_STEP_DEG
    circle = np.arange(0.0, 360.0, step)
    where = np.clip(np.mod(circle - start, 360.0), 0.0, None)
    where = np.where(where <= span, where, np.where(where - span < (360.0 - where), span, 0.0))
    basis = BSpline.design_matrix(np.clip(where, 0.0, span), knots, 3).tocsr()
    variance = np.asarray((basis @ inverse) * basis.toarray()).sum(axis=1)  # b' A^-1 b, row by row
    model_std = np.sqrt(np.maximum(noise_var * variance, 0.0))
    model.uncertainty = {"method": "arc-spline-posterior", "grid_step_deg": step,
                         "model_std_arcmin": model_std.tolist(), "noise_std_arcmin": float(np.sqrt(noise_var))}
    model.training = {"algorithm": "penalised cubic spline, smoothing by restricted marginal likelihood",
                      "intervals": intervals, "log10_penalty": float(log_lambda / np.log(10.0)),
                      "effective_parameters": round(effective, 3), "noise_std_arcmin": float(np.sqrt(noise_var)),
                      "range_deg": list(model.range_deg)}
    return model
