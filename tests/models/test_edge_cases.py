"""Numerical edge cases for every model family: degenerate, extreme and tiny or huge calibrations.

Each family (Fourier, linear and cubic lookup tables, the periodic and the paper's raw-angle network,
the hybrid, and auto) is fitted to each profile of :data:`PROFILES`. Every fit must either succeed
with finite predictions everywhere and the accuracy stated in :data:`BOUNDS`, or refuse with an
:class:`~encal._core.errors.EncalError`; no NaN, no overflow, no warning (pytest turns warnings into
errors). Accuracy is measured on a test grid between the calibration points (odd degrees), as the
residual RMS after correction, in arc-minutes.

Networks train for a few epochs only (the suite must stay fast), so their bounds are loose; the
closed-form families must be exact where the profile is in their span.
"""


import numpy as np
import pytest

import encal
from encal._core.angles import ARCMIN_PER_DEG
from encal.data.calibration import Calibration
from encal.deploy import Compensator
from encal._core.errors import CalibrationError, EncalError
from encal.models.select import Candidate
from encal.training import ALGORITHMS
from tests._paths import DATA

#: auto with a short list of quick candidates (one per family); the default list runs in
#: test_auto_with_default_candidates.
QUICK_CANDIDATES = (
    Candidate("fourier", {"select": "top", "n_orders": 10}),
    Candidate("lut", {"interpolation": "cubic"}),
    Candidate("ann", {"hidden": 6, "algorithm": "trainlm", "epochs": 60}),
    Candidate("hybrid", {"epochs": 60}),
)

FAMILIES = {
    "fourier": ("fourier", {}),
    "lut-linear": ("lut", {"interpolation": "linear"}),
    "lut-cubic": ("lut", {"interpolation": "cubic"}),
    "ann": ("ann", {"hidden": 8, "epochs": 150, "rng": 0}),
    "ann-raw": ("ann", {"hidden": 8, "epochs": 150, "rng": 0, "encoding": "raw"}),
    "hybrid": ("hybrid", {"epochs": 100, "rng": 0}),
    "auto": ("auto", {"rng": 0, "candidates": QUICK_CANDIDATES}),
}


def _harmonic(order, amplitude_arcmin, phase=0.3):
    return lambda ref: amplitude_arcmin * np.sin(order * np.radians(ref) + phase)


def _offset(offset_deg):
    return lambda ref: offset_deg * ARCMIN_PER_DEG + 2.0 * np.sin(np.radians(ref) + 0.3)


#: name -> (number of calibration points, error in arcmin as a function of the reference angle)
PROFILES = {
    "zero": (180, lambda ref: 0.0 * ref),
    "constant": (180, lambda ref: 5.0 + 0.0 * ref),
    "first-harmonic": (180, _harmonic(1, 3.0)),
    "16th-harmonic": (180, _harmonic(16, 1.0)),
    "misplaced-magnet-20deg": (180, _harmonic(1, 20.0 * ARCMIN_PER_DEG)),
    "offset-37deg": (180, _offset(37.0)),
    "offset-179.9deg": (180, _offset(179.9)),
    "offset-180deg": (180, _offset(180.0)),
    "offset-minus-179.99deg": (180, _offset(-179.99)),
    "step": (180, lambda ref: np.where((ref % 360.0) < 180.0, 1.0, -1.0)),
    "8-points": (8, _harmonic(1, 2.0)),
}

EXACT = 1e-6  # arcmin: "exact" up to rounding

#: Test-grid residual RMS bounds, arcmin: (profile, family) -> bound; a bound of the form
#: ("before", f) is f times the RMS of the uncorrected errors on the test grid. Families not listed
#: for a profile get the universal bound: never worse than no correction.
BOUNDS = {
    **{(p, f): EXACT for p in ("zero", "constant") for f in FAMILIES},
    **{("first-harmonic", f): EXACT for f in ("fourier", "hybrid", "auto")},
    ("first-harmonic", "lut-linear"): ("before", 1e-3),
    ("first-harmonic", "lut-cubic"): ("before", 1e-5),
    ("first-harmonic", "ann"): ("before", 1e-2),
    ("first-harmonic", "ann-raw"): ("before", 1e-2),
    **{("16th-harmonic", f): EXACT for f in ("fourier", "hybrid", "auto")},
    ("16th-harmonic", "lut-linear"): ("before", 0.05),
    ("16th-harmonic", "lut-cubic"): ("before", 1e-3),
    **{("misplaced-magnet-20deg", f): ("before", 1e-3) for f in FAMILIES},
    **{(p, f): 0.01 for p in PROFILES if p.startswith("offset") for f in FAMILIES},
    **{(p, f): EXACT for p in PROFILES if p.startswith("offset")
       for f in ("fourier", "hybrid", "auto")},
    **{("8-points", f): EXACT for f in ("fourier", "hybrid")},
}

#: (profile, family) pairs that must be refused with an EncalError instead, and why.
REFUSED = {}


def _calibration(n_points, error, shift_deg=0.0):
    reference = np.arange(n_points) * (360.0 / n_points) + shift_deg
    return Calibration(reference, reference + error(reference) / ARCMIN_PER_DEG)


def _test_grid(n_points, error):
    """Points halfway between the calibration points."""
    return _calibration(n_points, error, shift_deg=180.0 / n_points)


def _fit(method, options, cal):
    return encal.fit(cal, method=method, **options)


def _check_finite(model):
    theta = np.linspace(-720.0, 720.0, 14401)
    predicted = model.predict(theta)
    assert np.all(np.isfinite(predicted))
    assert np.all(np.isfinite(model.correct(theta)))
    corrected = model.correct(theta)
    assert np.all((corrected >= 0.0) & (corrected < 360.0))


@pytest.mark.parametrize("family", FAMILIES)
@pytest.mark.parametrize("profile", PROFILES)
def test_family_on_profile(profile, family):
    """Fits with finite predictions and the stated accuracy, or refuses with an EncalError."""
    n_points, error = PROFILES[profile]
    method, options = FAMILIES[family]
    cal = _calibration(n_points, error)
    if (profile, family) in REFUSED:
        with pytest.raises(EncalError):
            _fit(method, options, cal)
        return
    model = _fit(method, options, cal)
    _check_finite(model)
    result = encal.evaluate(model, _test_grid(n_points, error))
    bound = BOUNDS.get((profile, family), ("before", 1.0))
    if isinstance(bound, tuple):
        bound = bound[1] * result.before.rms + EXACT
    assert result.after.rms <= bound, f"test RMS {result.after.rms:.3g} arcmin > {bound:.3g}"
    fitted = encal.evaluate(model, cal)
    assert np.isfinite(fitted.after.rms)
    if family.startswith("lut"):
        assert fitted.after.max_abs <= EXACT  # a table passes through its points


def test_auto_with_default_candidates():
    """The default auto (every candidate) on a large zero offset near 180 degrees: exact, finite."""
    n_points, error = PROFILES["offset-179.9deg"]
    model = encal.fit(_calibration(n_points, error), method="auto", rng=0)
    _check_finite(model)
    assert encal.evaluate(model, _test_grid(n_points, error)).after.rms <= 0.01


def test_folded_error_is_refused_by_fit():
    """An error of 45 degrees at twice per turn folds the encoder back: no model can correct it."""
    cal = _calibration(180, _harmonic(2, 45.0 * ARCMIN_PER_DEG))
    for method in ("fourier", "lut"):
        with pytest.raises(CalibrationError, match="back"):
            encal.fit(cal, method=method)


# --------------------------------------------------------------------------- 10,000 points

DENSE = 10_000


@pytest.mark.parametrize("family, method, options", [
    ("lut-linear", "lut", {"interpolation": "linear"}),
    ("lut-cubic", "lut", {"interpolation": "cubic"}),
    ("fourier-explicit-orders", "fourier", {"orders": [0, 1, 2, 3]}),
    ("ann", "ann", {"hidden": 6, "epochs": 20, "rng": 0}),
])
def test_ten_thousand_points(family, method, options):
    """A dense calibration (10,000 points, 0.036 degree apart) fits and corrects a first harmonic."""
    error = _harmonic(1, 2.0)
    model = encal.fit(_calibration(DENSE, error), method=method, **options)
    _check_finite(model)
    result = encal.evaluate(model, _test_grid(DENSE, error))
    bound = 0.05 if family == "ann" else 1e-6
    assert result.after.rms <= bound * result.before.rms + EXACT


@pytest.mark.parametrize("method, options", [("fourier", {}), ("hybrid", {"epochs": 20, "rng": 0}),
                                             ("auto", {"rng": 0, "candidates": QUICK_CANDIDATES})])
def test_ten_thousand_points_default_fourier_ranking(method, options):
    """The families that rank harmonic orders (up to the Nyquist order, 5,000) on a dense calibration."""
    error = _harmonic(1, 2.0)
    model = encal.fit(_calibration(DENSE, error), method=method, **options)
    _check_finite(model)
    result = encal.evaluate(model, _test_grid(DENSE, error))
    assert result.after.rms <= 1e-3 * result.before.rms


# --------------------------------------------------------------------------- training stays finite

NASTY = {
    "constant": (180, lambda ref: 5.0 + 0.0 * ref),
    "zero": (60, lambda ref: 0.0 * ref),
    "huge": (180, _harmonic(1, 150.0 * ARCMIN_PER_DEG)),
    "step": PROFILES["step"],
    "8-points": PROFILES["8-points"],
    "tiny": (90, _harmonic(3, 1e-12)),
}


@pytest.mark.parametrize("encoding", ["periodic", "raw"])
@pytest.mark.parametrize("algorithm", sorted(ALGORITHMS))
def test_training_never_returns_non_finite_weights(algorithm, encoding):
    """Every training algorithm, on every nasty profile: finite weights and finite predictions."""
    for name, (n_points, error) in NASTY.items():
        reference = np.arange(n_points) * (360.0 / n_points)
        target = error(reference)
        model = encal.models.ann.fit_ann(reference, target, hidden=6, algorithm=algorithm, encoding=encoding,
                                         rng=1, epochs=25)
        weights = np.concatenate([np.ravel(np.asarray(value, dtype=float))
                                  for key, value in model.parameters().items()
                                  if key not in ("encoding", "activation")])
        assert np.all(np.isfinite(weights)), (name, algorithm)
        assert np.all(np.isfinite(model.predict(np.linspace(0.0, 360.0, 721)))), (name, algorithm)


@pytest.mark.parametrize("profile", list(NASTY))
def test_hybrid_stays_finite(profile):
    n_points, error = NASTY[profile]
    reference = np.arange(n_points) * (360.0 / n_points)
    model = encal.models.hybrid.fit_hybrid(reference, error(reference), epochs=25, rng=1)
    assert np.all(np.isfinite(model.predict(np.linspace(0.0, 360.0, 721))))


# --------------------------------------------------------------------------- regressions (bugs these tests found)

def test_aliasing_orders_are_refused():
    """Orders that alias one another on the calibration grid cannot be identified: refuse them."""
    cal = _calibration(180, _harmonic(1, 2.0))
    with pytest.raises(EncalError):
        encal.fit(cal, method="fourier", orders=[0, 1, 179])


def test_correction_of_a_huge_multi_turn_angle():
    """correct(theta + 360 k) == correct(theta) even where theta + 360 k has no fractional digits left
    (the reading is wrapped before the correction is subtracted), by the model, the Compensator and the
    standalone runtime."""
    model = encal.fit(_calibration(180, _harmonic(1, 2.0)), method="fourier")
    turns = 360.0 * 2.0**44  # exactly representable, 0 mod 360
    expected = model.correct(0.0)
    assert expected != 0.0
    assert model.correct(turns) == pytest.approx(expected, abs=1e-9)
    assert Compensator(model).correct(turns) == pytest.approx(expected, abs=1e-9)


def test_the_outside_attacks_api_cases_are_encal_errors():
    """Found by the fresh outside attack of issue 25: a plain OverflowError, an AttributeError and a silent 21600."""
    import pytest

    import encal

    model = encal.load_model(DATA / "model_v1_fourier.json")
    with pytest.raises(encal.InputError, match="finite numbers of degrees"):
        model.correct(10**400)
    with pytest.raises(encal.InputError, match="must be a SimulatedRun"):
        encal.measurement_floor(-1)
    with pytest.raises(encal.InputError, match="'bits' parameter of lsb_arcmin must be an int from 1"):
        encal.lsb_arcmin(0)
