"""Cost-aware choice of a deployment: the cheapest within a tolerance, the most accurate within a budget.

The candidates, for the ``cortex-m4f`` target: compact tables of every node
dtype and power-of-two size, interpolated linearly or by a cubic B-spline, and,
for a model that is a Fourier series, the series itself in float32; for
``fixed``: integer compact tables, interpolated likewise. Each has a
cost in flash bytes (of its data), entries (nodes or terms) and C operations
per reading (:data:`encal.deploy.costs.OPERATIONS`; a sinf or cosf call counts
as :data:`encal.deploy.costs.CALL_OPERATIONS`), and a deployed error against the model over all
codes (:mod:`encal.deploy.compact`).
"""

import re
from dataclasses import dataclass

import numpy as np

from .._core.errors import InputError
from .._core.parameters import check_choice, check_number, invalid
from .compact import (INTERPOLATIONS, MAX_NODES, MIN_NODES, check_exportable, check_table_bits, compile_compact,
                      evaluation_bits, model_on_codes)
from .compensator import Compensator
from .costs import CALL_OPERATIONS, OPERATIONS, reading_cost_key
from .series32 import fourier_float32, fourier_terms

__all__ = ["Deployment", "candidates", "choose_deployment", "parse_budget", "COSTS"]

COSTS = ("bytes", "entries", "operations")
#: The processors a deployment is chosen for: float32 arithmetic, or integers only.
_TARGETS = ("cortex-m4f", "fixed")
_UNITS = {"b": "bytes", "byte": "bytes", "bytes": "bytes", "kib": "bytes", "k": "bytes",
          "entries": "entries", "entry": "entries", "nodes": "entries", "n": "entries",
          "ops": "operations", "op": "operations", "operations": "operations"}


@dataclass(frozen=True)
class Deployment:
    """One way of deploying a model, its costs and its deployed error (arcmin, over all codes)."""

    target: str
    form: str
    nodes: int | None
    dtype: str | None
    terms: int | None
    bytes: int
    entries: int
    operations: int
    max_error_arcmin: float
    rms_error_arcmin: float
    interpolation: str | None = None

    def cost(self, kind):
        return getattr(self, kind)

    def describe(self):
        cubic = " cubic B-spline" if self.interpolation == "cubic" else ""
        what = (f"{self.nodes}-node {self.dtype}{cubic} table" if self.form == "table"
                else f"{self.terms}-term Fourier series in float32")
        return (f"{self.target} {what}: {self.bytes} bytes, {self.operations} operations per reading; "
                f"deployed error max {self.max_error_arcmin:.3g}, RMS {self.rms_error_arcmin:.3g} arcmin")

    def as_dict(self):
        return {"target": self.target, "form": self.form, "nodes": self.nodes, "dtype": self.dtype,
                "terms": self.terms, "bytes": self.bytes, "entries": self.entries,
                "operations": self.operations, "max_error_arcmin": self.max_error_arcmin,
                "rms_error_arcmin": self.rms_error_arcmin, "interpolation": self.interpolation}


def parse_budget(text):
    """``'1024B'``, ``'4KiB'``, ``'256entries'``, ``'200ops'`` -> ``(cost, value)``.

    Raises
    ------
    InputError
        If the text is not a positive number followed by a known unit.
    """
    match = re.fullmatch(r"\s*(\d+(?:\.\d+)?)\s*([A-Za-z]+)\s*", str(text), flags=re.ASCII)  # not '２0B' (20)
    unit = match and match.group(2).lower()
    if not match or unit not in _UNITS or float(match.group(1)) <= 0:
        raise InputError(f"expected a budget such as 1024B, 4KiB, 256entries or 200ops, got {text!r}")
    value = float(match.group(1)) * (1024 if unit in ("kib", "k") else 1)
    return _UNITS[unit], value


def candidates(model, *, target="cortex-m4f", bits=None):
    """Every deployment of ``model`` for ``target`` (see the module), with its costs and error."""
    check_choice(target, "target", "candidates", _TARGETS)
    comp = model if isinstance(model, Compensator) else Compensator(model)
    bits = _check_bits(comp.encoder.get("resolution_bits") if bits is None else bits, "candidates")
    reference = check_exportable(model_on_codes(comp, bits), comp, "candidates")
    largest = min(MAX_NODES, 2**evaluation_bits(bits))
    dtypes = ("int8", "int16") if target == "fixed" else ("int8", "int16", "float32")
    interpolations = INTERPOLATIONS
    key = reading_cost_key(target, bits)
    fixed = target == "fixed"
    found = []
    for interpolation in interpolations:
        form = "cubic" if interpolation == "cubic" else "table"
        for dtype in dtypes:
            nodes = MIN_NODES
            while nodes <= largest:
                table = compile_compact(comp, nodes, dtype=dtype, bits=bits, reference=reference,
                                        interpolation=interpolation)
                found.append(Deployment(
                    target, "table", nodes, dtype, None, table.table_bytes, nodes,
                    OPERATIONS[(target, form, key)],
                    table.fixed_max_error_arcmin if fixed else table.max_error_arcmin,
                    table.fixed_rms_error_arcmin if fixed else table.rms_error_arcmin, interpolation))
                nodes *= 2
    terms = fourier_terms(comp) if target == "cortex-m4f" else None
    if terms is not None:
        orders, cos, sin = terms
        grid = evaluation_bits(bits)
        deployed = fourier_float32(orders, cos, sin, np.arange(2**grid, dtype=np.int64) << (32 - grid))
        error = deployed.astype(float) - reference
        k = int(orders.size)
        found.append(Deployment(
            target, "formula", None, None, k, 12 * k, k,
            k * (OPERATIONS[("cortex-m4f", "formula", "per_term")] + 2 * CALL_OPERATIONS),
            float(np.max(np.abs(error))), float(np.sqrt(np.mean(error**2)))))
    return found


def choose_deployment(model, *, tolerance_arcmin=None, budget=None, cost="bytes", target="cortex-m4f",
                      bits=None):
    """The cheapest deployment within a tolerance, or the most accurate one within a budget.

    Parameters
    ----------
    model : Model, Compensator, str or os.PathLike
    tolerance_arcmin : float, optional
        Largest deployed error (max over all codes) allowed, arc-minutes.
    budget : (str, float) or str, optional
        Largest cost, e.g. ``('bytes', 1024)`` or ``'1KiB'`` (see :func:`parse_budget`).
    cost : {'bytes', 'entries', 'operations'}, default='bytes'
        What "cheapest" means with a tolerance alone (a budget names its own).
    target : {'cortex-m4f', 'fixed'}, default='cortex-m4f'
    bits : int, optional

    Returns
    -------
    chosen : Deployment
    report : dict
        ``met`` (the tolerance is met, or None without one), ``gave_up`` (one
        sentence: the error given up against the model, and what the next
        better deployment would cost), ``budget``, ``tolerance_arcmin``.
    """
    caller = "choose_deployment"
    if isinstance(budget, str):
        budget = parse_budget(budget)
    if budget is not None:
        budget = _check_budget(budget, caller)
        cost = budget[0]
    check_choice(cost, "cost", caller, COSTS)
    if tolerance_arcmin is not None:
        tolerance_arcmin = check_number(tolerance_arcmin, "tolerance_arcmin", caller, low=0.0, low_open=True,
                                        note="arc-minutes, or None")
    check_choice(target, "target", caller, _TARGETS)
    if tolerance_arcmin is None and budget is None:
        raise InputError("expected a tolerance, a budget or both to choose a deployment")
    comp = model if isinstance(model, Compensator) else Compensator(model)
    bits = _check_bits(comp.encoder.get("resolution_bits") if bits is None else bits, caller)
    every = candidates(comp, target=target, bits=bits)
    affordable = [d for d in every if budget is None or d.cost(cost) <= budget[1]]
    if not affordable:
        cheapest = min(every, key=lambda d: d.cost(cost))
        raise InputError(f"expected a budget of at least {cheapest.cost(cost)} {cost} (the cheapest deployment, "
                         f"{cheapest.describe()}), got {budget[1]:g}")
    within = [d for d in affordable
              if tolerance_arcmin is None or d.max_error_arcmin <= float(tolerance_arcmin)]
    if tolerance_arcmin is not None and within:
        chosen = min(within, key=lambda d: (d.cost(cost), d.bytes, d.operations, d.max_error_arcmin))
    else:
        chosen = min(affordable, key=lambda d: (d.max_error_arcmin, d.cost(cost)))
    met = None if tolerance_arcmin is None else chosen.max_error_arcmin <= float(tolerance_arcmin)
    better = [d for d in every if d.max_error_arcmin < chosen.max_error_arcmin]
    nearest = min(better, key=lambda d: (d.cost(cost), d.bytes, d.max_error_arcmin)) if better else None
    gave_up = (f"gave up {chosen.max_error_arcmin:.3g} arcmin (max; RMS {chosen.rms_error_arcmin:.3g}) "
               "against the model")
    if nearest is not None:
        gave_up += f"; the next more accurate choice costs {nearest.cost(cost)} {cost}: {nearest.describe()}"
    return chosen, {"met": met, "gave_up": gave_up, "budget": budget, "tolerance_arcmin": tolerance_arcmin}


def _check_budget(budget, caller):
    """A budget as ``(cost, value)``: a cost of :data:`COSTS` and a finite value > 0."""
    expected = f"a text such as '1KiB' or a pair (cost, value > 0) with a cost among {', '.join(COSTS)}"
    try:
        cost, value = budget
    except (TypeError, ValueError):  # not a pair
        raise invalid("budget", caller, expected, budget) from None
    if cost not in COSTS:
        raise invalid("budget", caller, expected, budget)
    return cost, check_number(value, "budget", caller, low=0.0, low_open=True, note=f"{cost}")


def _check_bits(bits, caller):
    """The encoder resolution as an int from 2 to 32 (a compact table's 4 nodes, one per code), or None when unknown."""
    return check_table_bits(bits, caller)
