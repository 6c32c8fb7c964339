"""Why auto (the spectral model) loses to the best single family on some real files (even/odd protocol).

Usage::

    python benchmarks/real_misses.py           # the 60 files of shared/data/real/mechaduino, about 2 minutes

Every family is fitted on the even rows and tested on the odd rows, as in ``bench_real_data.py --protocol
even-odd`` (same methods, same seed). Two things are measured.

Where the difference lies. The difference of the mean squares of auto's and the best family's residuals at
the odd rows is split by Parseval over the orders of the odd rows' own grid: order 0 (the residuals' mean) and
that grid's Nyquist order (their alternation from one odd row to the next) are the stepper's odd steps, their
mean offset and the odd half of its four-step pattern, which the even rows never see; the other orders are the
encoder's profile. ``z`` is the paired z of ``bench_real_data.py``; ``z rest`` the same with orders 0 and
Nyquist of the odd grid taken out of both residuals. A family that keeps the even rows' step alternation (the
training grid's Nyquist term, which the spectral model estimates and leaves out) carries some of it to the odd
rows, whose encoder angles are off the midpoints by the error itself; the last ratio refits auto and the best
family on the even rows with that alternation taken out.

Which alias a line near the training grid's Nyquist order is. On the even rows' grid of ``N`` stops the orders
``k`` and ``N - k`` agree at the stops and are opposite between them, and the spectral model puts every line
at ``k <= N/2``. The whole file (both parities, Nyquist order ``N``) separates them: for each line with
``N/4 < k < N/2`` its amplitude at ``k`` and at ``N - k`` is printed, and the test RMS with the line left out of
the correction, or moved to its alias (the same values at the stops). The variants over all files: every such
line at the alias the whole file shows (an oracle: it reads the test rows), every such line left out, every such
line shared between ``k`` and ``N - k`` by the background's prior ratio ``k^-β : (N - k)^-β``.
"""

import os

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import numpy as np  # noqa: E402

import encal  # noqa: E402
from encal.models.spectral import SpectralModel  # noqa: E402

from _methods import METHODS, RANDOMISED  # noqa: E402
from bench_real_data import DATA, GOAL, SINGLE, paired_z, read_index, short, test_rms  # noqa: E402

VARIANTS = ("as fitted", "at the alias the whole file shows", "left out", "shared by the background")


def parseval_parts(residual):
    """Each order's share of ``mean(residual**2)`` on the residual's own uniform grid (orders 0..n/2)."""
    spectrum = np.fft.rfft(residual) / residual.size
    weight = np.full(spectrum.size, 2.0)
    weight[0] = 1.0
    if residual.size % 2 == 0:
        weight[-1] = 1.0
    return weight * np.abs(spectrum) ** 2


def without_edges(residual):
    """The residual without its mean and its Nyquist alternation (orders 0 and n/2 of its own grid)."""
    spectrum = np.fft.rfft(residual)
    spectrum[0] = 0.0
    if residual.size % 2 == 0:
        spectrum[-1] = 0.0
    return np.fft.irfft(spectrum, residual.size)


def moved(model, train, lines, weight):
    """The spectral model with each line ``k`` of ``lines`` kept at ``k`` by ``weight(k)`` and the rest at its alias.

    The alias ``N - k`` takes the values of order ``k`` at the training stops: with the stops at encoder angles
    ``φ + 2πj/N``, ``a cos kθ + b sin kθ`` equals ``Re(conj(a - ib) e^{-iNφ} e^{i(N-k)θ})`` there.
    ``weight(k)`` None leaves the line out.
    """
    n_stops = model.training["stops"]
    coherent = np.mean(np.exp(1j * n_stops * np.radians(train.encoder_deg)))
    rotation = np.conj(coherent / abs(coherent))
    coefficients = {int(k): complex(c, -s) for k, c, s in zip(model.orders, model.cos, model.sin)}
    for k in lines:
        value = coefficients.pop(k, 0.0)
        share = weight(k)
        if share is None:
            continue
        coefficients[k] = share * value
        alias = n_stops - k
        coefficients[alias] = coefficients.get(alias, 0.0) + (1.0 - share) * np.conj(value) * rotation
    orders = np.array(sorted(coefficients))
    values = np.array([coefficients[k] for k in orders])
    return SpectralModel(orders, values.real, -values.imag)


def rms(model, cal):
    return float(np.sqrt(np.mean(encal.evaluate(model, cal).residual_arcmin ** 2)))


def without_alternation(train):
    """The training rows with their step alternation ``c (-1)^j`` (``c = mean((-1)^j e_j)``) taken out."""
    alternation = (-1.0) ** np.arange(len(train))
    step = np.mean(train.errors_arcmin * alternation)
    return encal.Calibration(train.reference_deg, np.mod(train.encoder_deg - step * alternation / 60.0, 360.0))


def ratio_without_alternation(train, test, best):
    """auto / ``best`` at the test rows, both fitted on the training rows without their step alternation."""
    train = without_alternation(train)
    method, options = METHODS[best]
    model = encal.fit(train, method=method, rng=0 if method in RANDOMISED else None, **options)
    return rms(encal.fit(train, method="auto"), test) / rms(model, test)


def main():
    edge_better = edge_worse = 0
    by_order = {}  # (stops, line order) -> [lines, of which larger at the alias in the whole file]
    ratios = {variant: {} for variant in VARIANTS}
    misses, odd_rows = [], []
    for row in read_index(DATA):
        cal = encal.read_calibration(DATA / row["file"], name=row["file"])
        even = np.arange(len(cal)) % 2 == 0
        train, test = cal.subset(even), cal.subset(~even)
        result, _, _, residual = test_rms(train, [test])
        best = min(SINGLE, key=result.get)
        parts = {name: parseval_parts(residual[name]) for name in result}
        nyquist = parts["auto"].size - 1
        for name in SINGLE:
            edge = (parts["auto"] - parts[name])[[0, nyquist]].sum()
            edge_better += edge < 0
            edge_worse += edge > 0
        difference = parts["auto"] - parts[best]
        other = 1 + int(np.argmax(difference[1:nyquist]))

        model = encal.fit(train, method="auto")
        n_stops, beta = model.training["stops"], model.training["background"]["exponent"]
        amplitude = 2.0 * np.abs(np.fft.rfft(cal.errors_arcmin)) / len(cal)  # whole file, by full step
        near = [k for k in model.training["lines"] if n_stops / 4 < k < n_stops / 2]
        for k in near:
            count = by_order.setdefault((n_stops, k), [0, 0, [], []])
            count[0] += 1
            count[1] += bool(amplitude[n_stops - k] > amplitude[k])
            count[2].append(amplitude[k])
            count[3].append(amplitude[n_stops - k])
        weights = {
            "as fitted": lambda k: 1.0,
            "at the alias the whole file shows": lambda k: 1.0 if amplitude[k] >= amplitude[n_stops - k] else 0.0,
            "left out": lambda k: None,
            "shared by the background": lambda k: k ** -beta / (k ** -beta + (n_stops - k) ** -beta),
        }
        for variant, weight in weights.items():
            ratios[variant][short(row["file"])] = rms(moved(model, train, near, weight), test) / result[best]

        ratio = result["auto"] / result[best]
        if ratio <= 1 + GOAL:
            continue
        line_text = "; ".join(
            f"{k}: {amplitude[k]:.2f} / {amplitude[n_stops - k]:.2f}, "
            f"{rms(moved(model, train, [k], lambda _: None), test) / result[best]:.3f}, "
            f"{rms(moved(model, train, [k], lambda _: 0.0), test) / result[best]:.3f}" for k in near) or "none"
        misses.append(f"| {short(row['file'])} | {ratio:.3f} | {best} | {difference.sum():.2f} | {difference[0]:.2f} "
                      f"| {difference[nyquist]:.2f} | {other}: {difference[other]:.2f} "
                      f"| {paired_z(residual['auto'], residual[best]):.1f} "
                      f"| {paired_z(without_edges(residual['auto']), without_edges(residual[best])):.1f} "
                      f"| {ratio_without_alternation(train, test, best):.3f} | {line_text} |")
        error = cal.errors_arcmin
        shift = residual["auto"] - residual[best]  # the best family's prediction at the odd rows minus auto's
        odd_alternation = (-1.0) ** np.arange(len(test))
        whole = encal.fit(cal, method="auto").training["lines"]
        method, options = METHODS[best]
        best_model = encal.fit(train, method=method, rng=0 if method in RANDOMISED else None, **options)
        kept = sorted(int(k) for k in best_model.orders) if method == "fourier" else "-"
        odd_rows.append(f"| {short(row['file'])} | {error[1::2].mean() - error[0::2].mean():+.2f} "
                        f"| {residual['auto'].mean():+.2f} "
                        f"| {np.mean(train.errors_arcmin * (-1.0) ** np.arange(len(train))):+.2f} "
                        f"| {shift.mean():+.3f} | {np.mean(shift * odd_alternation):+.3f} | {kept} | {whole} |")

    print("# Where auto loses to the best single family on the real files (even rows fitted, odd rows tested)\n")
    print("| file | auto / best | best | MSE difference (arcmin²) | of it: odd rows' mean | odd rows' alternation "
          "| largest other order | z | z rest | auto / best, the even rows' alternation taken out before both fits "
          "| lines N/4 < k < N/2: amplitude at k / at N − k (whole file), auto / best without the line, at N − k |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    print("\n".join(misses))
    print("\nThe odd rows of the same files (arcmin): the whole file's odd-step offset (mean of the odd rows' errors "
          "minus the even rows'), auto's mean residual at the odd rows, the even rows' alternation "
          "mean((-1)^j e_j), the best family's prediction at the odd rows minus auto's (its mean, its alternation "
          "from one odd row to the next), and the lines of the spectral model fitted on every full step.\n")
    print("| file | odd-step offset | auto's mean residual | even rows' alternation | best − auto: mean "
          "| alternation | the best family's orders (a Fourier series) | lines, every step fitted |")
    print("|---|---|---|---|---|---|---|---|")
    print("\n".join(odd_rows))

    print(f"\n- odd rows' mean and alternation, auto against each of the {len(SINGLE)} single families on every "
          f"file: auto's share of the MSE lower in {edge_better}, higher in {edge_worse}")
    print("- lines with N/4 < k < N/2 (stops N: order, lines, of which larger at N − k in the whole file, the whole "
          "file's amplitude at k and at N − k, arcmin): " + "; ".join(
              f"{n}: {k}, {count[0]}, {count[1]}, {min(count[2]):.2f}–{max(count[2]):.2f}, "
              f"{min(count[3]):.2f}–{max(count[3]):.2f}" for (n, k), count in sorted(by_order.items())))
    print("\n| lines with N/4 < k < N/2 | median auto / best single | worst | files within 2 % | files above 2 % |")
    print("|---|---|---|---|---|")
    for variant, by_file in ratios.items():
        values = np.array(list(by_file.values()))
        above = ", ".join(f"{name} {value:.3f}" for name, value in sorted(by_file.items(), key=lambda item: -item[1])
                          if value > 1 + GOAL)
        print(f"| {variant} | {np.median(values):.3f} | {values.max():.3f} | "
              f"{int(np.sum(values <= 1 + GOAL))} of {values.size} | {above} |")


if __name__ == "__main__":
    main()
