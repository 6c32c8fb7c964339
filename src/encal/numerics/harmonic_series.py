"""A sum of harmonics ``Σ a_k cos(k θ) + b_k sin(k θ)`` at many angles, without a cosine and a sine per order.

The direct form computes the cosine and the sine of every ``k θ``: two transcendental functions per
order and angle. Here ``(cos kθ, sin kθ)``, the power ``z^k`` of ``z = e^{iθ}``, is the product of two
earlier powers by the angle-addition formulas::

    cos((j + l) θ) = cos jθ cos lθ - sin jθ sin lθ,    sin((j + l) θ) = cos jθ sin lθ + sin jθ cos lθ,

so an angle costs one ``cos`` and one ``sin`` and a few products, along an addition chain of the orders
planned once for the series (:func:`plan_products`): each order is the previous one times ``z`` to the
difference (a dense run of orders: one product each), or ``z`` to the order itself by squaring (a sparse
high order), whichever takes fewer products; the powers of two that the squarings make serve every order.

Accuracy: write ``u = 2^-53``. Each product adds a rounding of at most ``3u`` to the pair it makes, and
errors add along the chain, so ``z^k`` carries ``k`` times the error of ``z`` plus ``k - 1`` such
roundings whatever the chain: ``k (e_1 + 3u)``, with ``e_1`` the error of ``(cos θ, sin θ)`` (the
conversion to radians and the two functions, about ``4π u + 2u`` for θ below 2π). The direct form has the
same ``k e_1`` from the conversion plus the rounding of ``k θ`` (``2π k u``), so the two agree to a few
``k u`` of the coefficients. Stated bound, for θ in [0, 2π) and m orders: within
``u Σ_k (|a_k| + |b_k|) (20 k + m + 2)`` of the exact series; ``tests/numerics/test_harmonic_series.py`` checks it
against an extended precision reference for orders up to the model file's largest, for each of the three
forms.

A series of many orders costs less still by the spectral model's evaluator
(:class:`encal.numerics.trigsums.SeriesEvaluator`): the series and its derivatives tabulated once on a fine grid
of angles, each angle then a Taylor expansion about its nearest node (a few lookups, whatever the number of
orders). :class:`HarmonicSeries` chooses among the direct form, the chain and these tables by their
measured costs; the tables are used only while they are small (orders up to about 5,000).

All three forms are element-wise: the value at an angle does not depend on the other angles evaluated with it
(a stream's answers must not depend on its buffering). The products are real multiplications, additions
and subtractions, each rounded once in every NumPy loop; NumPy's complex multiplication is not used,
since its vectorised loops fuse a multiplication and an addition and its scalar ones do not.
"""

import numpy as np

from .trigsums import SeriesEvaluator

__all__ = ["HarmonicSeries", "plan_products"]

# Costs per angle in units of one ``cos`` and one ``sin`` of the angles (NumPy, a chunk of 8,192 angles; the
# "series" section of benchmarks/bench_hotpaths.py measures them: about 23 ns for the pair here).
#: One product of two powers: six passes over the angles (1-3 ns).
PRODUCT_COST = 0.1
#: Adding one order's ``a cos + b sin`` to the sum: four passes (1.3 ns).
TERM_COST = 0.06
#: Each order of the direct form beyond the first: its ``cos`` and ``sin`` and the phase, products and row sum
#: around them (45-50 ns; a single order alone costs one pair, its row sum being no sum).
DIRECT_ORDER_COST = 2.0
#: The spectral model's evaluator (:class:`encal.numerics.trigsums.SeriesEvaluator`: a Taylor expansion about the
#: nodes of a fine grid, whose tables hold the series' derivatives, summed by Horner's rule), whatever the orders:
#: 24-29 ns (chunks of 8,192 angles) while its tables hold up to :data:`TAYLOR_CACHED_NUMBERS` numbers (orders up to
#: about 1,000), then up to 50 ns (:data:`TAYLOR_COST_LARGE`) as they outgrow the cache.
TAYLOR_COST = 1.0
TAYLOR_COST_LARGE = 1.8
#: Table numbers up to which the evaluator costs :data:`TAYLOR_COST`.
TAYLOR_CACHED_NUMBERS = 1 << 17
#: Largest tables the evaluator may build (numbers: 4 MiB), so that they stay in cache and are built in a few
#: milliseconds: orders up to about 5,000. Above, 33 MB for the largest order, 32767, built in 0.1 s.
TAYLOR_TABLE_NUMBERS = 1 << 19


def plan_products(orders, routes=("difference", "squaring")):
    """An addition chain through the positive ``orders``: the products that make ``z^k`` for each of them.

    The orders are reached in increasing order; each is made from what is already there, by the route of
    ``routes`` that takes the fewest products (the first on a tie): ``'difference'``,
    ``z^k = z^p · z^(k - p)`` with ``p`` the order reached before ``k`` and ``z^(k - p)`` by the binary
    method (powers of two by squaring, then their products), one product for a dense run of orders; or
    ``'squaring'``, ``z^k`` itself by the binary method, as the exported C does.

    Parameters
    ----------
    orders : iterable of int
        Harmonic orders (any order, repeats and 0 allowed; 0 and 1 need no product).
    routes : sequence of {'difference', 'squaring'}, default=('difference', 'squaring')
        The routes tried for each order.

    Returns
    -------
    list of tuple of int
        Steps ``(k, i, j)`` meaning ``z^k = z^i · z^j`` (``i + j == k``), in an order in which every
        operand is ``1`` or made by an earlier step.

    Examples
    --------
    >>> plan_products([0, 1, 2, 3, 8])
    [(2, 1, 1), (3, 2, 1), (4, 2, 2), (8, 4, 4)]
    """
    made, highest = {1}, 1  # every power made so far is at most the last order reached, highest
    steps = []
    for k in sorted({int(k) for k in orders if k > 1}):
        chosen = min((_route(route, k, highest, made) for route in routes), key=len)
        steps += chosen
        made.update(step[0] for step in chosen)
        highest = k
    return steps


def _route(route, k, highest, made):
    """The steps that make ``z^k`` by ``route`` from the powers ``made`` (``highest`` the largest of them)."""
    if route == "difference":
        return _binary_steps(k - highest, made) + [(k, highest, k - highest)]
    if route == "squaring":
        return _binary_steps(k, made)
    raise ValueError(f"plan_products's routes must be 'difference' or 'squaring'; got {route!r}")


def _binary_steps(exponent, made):
    """Steps that make ``z^exponent`` from ``made`` by the binary method, reusing what is there."""
    if exponent in made:
        return []
    steps, new = [], set()
    power, partial = 1, None
    while power <= exponent:
        if power not in made and power not in new:
            steps.append((power, power // 2, power // 2))
            new.add(power)
        if exponent & power:
            if partial is None:
                partial = power
            else:
                total = partial + power
                if total not in made and total not in new:
                    steps.append((total, partial, power))
                    new.add(total)
                partial = total
        power <<= 1
    return steps


class HarmonicSeries:
    """``f(θ) = Σ_k a_k cos(k θ) + b_k sin(k θ)`` for fixed orders and coefficients, at any angles.

    Evaluated the cheapest of three ways by the measured costs (:data:`PRODUCT_COST`, :data:`TERM_COST`,
    :data:`DIRECT_ORDER_COST`, :data:`TAYLOR_COST`): the spectral model's evaluator while its tables are small
    (:data:`TAYLOR_TABLE_NUMBERS`), the direct form for a single order, else the addition chain of
    :func:`plan_products`, or the direct form for a few very high orders.

    Parameters
    ----------
    orders : ndarray of int of shape (m,)
        Distinct non-negative orders.
    cos, sin : ndarray of shape (m,)
        Coefficients ``a_k`` and ``b_k`` (any unit; the result has it).
    method : {None, 'recurrence', 'taylor', 'direct'}, default=None
        How to evaluate it; None chooses by the cost.
    chain : list of tuple of int, optional
        With ``method='recurrence'``: the addition chain to follow (steps ``(k, i, j)`` as
        :func:`plan_products` returns them, reaching every positive order); default
        :func:`plan_products`'s. Benchmarks compare chains with it.

    Attributes
    ----------
    method : {'recurrence', 'taylor', 'direct'}
        How the series is evaluated.
    steps : list of tuple of int
        The products of the addition chain (empty unless the chain is used).
    width : int
        Temporary numbers per angle of one evaluation (for :func:`encal.models.base.in_chunks`).

    Examples
    --------
    >>> series = HarmonicSeries(np.array([0, 2, 3]), np.array([1.0, 0.5, 0.0]), np.array([0.0, 0.0, 2.0]))
    >>> series.method, [round(float(v), 12) for v in series(np.array([0.0, np.pi / 2]))]
    ('recurrence', [1.5, -1.5])
    """

    def __init__(self, orders, cos, sin, *, method=None, chain=None):
        self.orders = np.asarray(orders, dtype=int).reshape(-1)
        self.cos = np.asarray(cos, dtype=float).reshape(-1)
        self.sin = np.asarray(sin, dtype=float).reshape(-1)
        highest = int(self.orders.max(initial=0))
        steps = plan_products(self.orders.tolist()) if chain is None else [tuple(step) for step in chain]
        if method is None:  # costs in units of one cos and one sin of the angles
            costs = {"direct": 1.0 + DIRECT_ORDER_COST * max(self.orders.size - 1, 0)}
            if highest > 0:
                costs["recurrence"] = 1.0 + PRODUCT_COST * len(steps) + TERM_COST * self.orders.size
                numbers = SeriesEvaluator.table_numbers(highest)
                if numbers <= TAYLOR_TABLE_NUMBERS:
                    costs["taylor"] = TAYLOR_COST if numbers <= TAYLOR_CACHED_NUMBERS else TAYLOR_COST_LARGE
            method = min(costs, key=costs.get)  # the first on a tie
        if method not in ("recurrence", "taylor", "direct"):
            raise ValueError("HarmonicSeries's method must be None, 'recurrence', 'taylor' or 'direct'; "
                             f"got {method!r}")
        self.method, self.steps = method, []
        if method == "recurrence":
            _check_chain(steps, self.orders)
            self.steps = steps
            self._program = _program(steps, self.orders, self.cos, self.sin)
            self.width = 2 * self._program[1] + 4
        elif method == "taylor":
            coefficients = np.zeros(highest + 1, dtype=complex)
            coefficients[self.orders] = self.cos - 1j * self.sin
            self._taylor = SeriesEvaluator(coefficients)
            self.width = 8  # its node, offset, power, sum and a term's products
        else:
            self.width = 2 * self.orders.size

    def __call__(self, theta_rad):
        """The series at ``theta_rad`` (1-D ndarray of angles in radians, best within one turn)."""
        if self.method == "taylor":
            return self._taylor(theta_rad)
        if self.method == "direct":
            phase = np.multiply.outer(theta_rad, self.orders)
            # Row sums, not a matrix product: BLAS sums a row in an order that depends on where the row falls
            # in the block, so a reading's value would change in its last bit with the buffering of a stream.
            return (np.cos(phase) * self.cos + np.sin(phase) * self.sin).sum(axis=1)
        return self._recurrence(theta_rad)

    def _recurrence(self, theta_rad):
        instructions, slots, constant = self._program
        n = theta_rad.size
        pairs = np.empty((slots, 2, n))
        total = np.full(n, constant)
        term, scratch = np.empty(n), np.empty(n)
        np.cos(theta_rad, out=pairs[0, 0])
        np.sin(theta_rad, out=pairs[0, 1])
        for instruction in instructions:
            if instruction[0] == "product":
                _, out, left, right = instruction
                _product(pairs[left], pairs[right], pairs[out], scratch)
            else:
                _, slot, a, b = instruction
                np.multiply(pairs[slot, 0], a, out=term)
                np.multiply(pairs[slot, 1], b, out=scratch)
                np.add(term, scratch, out=term)
                np.add(total, term, out=total)
        return total


def _product(left, right, out, scratch):
    """``out = left · right`` for pairs ``(cos, sin)`` (each of shape (2, n)); ``out`` is neither operand."""
    np.multiply(left[0], right[0], out=out[0])
    np.multiply(left[1], right[1], out=scratch)
    np.subtract(out[0], scratch, out=out[0])
    np.multiply(left[0], right[1], out=out[1])
    np.multiply(left[1], right[0], out=scratch)
    np.add(out[1], scratch, out=out[1])


def _check_chain(steps, orders):
    made = {1}
    for k, i, j in steps:
        if i not in made or j not in made or i + j != k:
            raise ValueError(f"an addition chain's step z^{k} = z^{i} · z^{j} needs i + j = k and both "
                             "powers made before it")
        made.add(k)
    missing = sorted(set(int(k) for k in orders if k > 0) - made)
    if missing:
        raise ValueError(f"the addition chain does not reach the orders {missing[:5]}")


def _program(steps, orders, cos, sin):
    """The chain as instructions on numbered slots of ``(cos, sin)`` pairs, slots reused once free.

    Returns ``(instructions, slots, constant)``: ``('product', out, left, right)`` and ``('term', slot, a, b)``
    (add ``a cos + b sin`` of the slot's pair to the total; the orders in increasing order), the number of
    slots, and the order-0 coefficient the total starts from.
    """
    coefficients = {int(k): (float(a), float(b)) for k, a, b in zip(orders, cos, sin)}
    constant = coefficients.pop(0, (0.0, 0.0))[0]
    events = []  # ('product', k, i, j) and ('term', k), in evaluation order
    if 1 in coefficients:
        events.append(("term", 1))
    for k, i, j in steps:
        events.append(("product", k, i, j))
        if k in coefficients:
            events.append(("term", k))
    last_use = {}  # where each power is used last (where it is made, if never used)
    for position, event in enumerate(events):
        for power in event[1:]:
            last_use[power] = position
    slot_of, free, slots, instructions = {1: 0}, [], 1, []
    for position, event in enumerate(events):
        if event[0] == "product":
            k, i, j = event[1:]
            if free:
                slot_of[k] = free.pop()
            else:
                slot_of[k], slots = slots, slots + 1
            instructions.append(("product", slot_of[k], slot_of[i], slot_of[j]))
            released = {i, j, k}
        else:
            k = event[1]
            instructions.append(("term", slot_of[k], *coefficients[k]))
            released = {k}
        for power in sorted(released):
            if last_use.get(power) == position and power in slot_of:
                free.append(slot_of.pop(power))
    return instructions, slots, constant
