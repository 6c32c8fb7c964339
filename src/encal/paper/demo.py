"""``encal demo``: the paper's whole procedure on the built-in demo fleet.

Four simulated resolver encoders ('enc1'..'enc4', :func:`encal.simulate.demo_fleet`)
go through every step of Dhar et al.:

1. error profiles, statistics and harmonic analysis (Table 1, Fig. 1);
2. the hidden-node sweep with trainlm and traingd on enc1 (Fig. 2a, 2b);
3. the training-algorithm table at N = 80 on enc1, over seeds (Table 2);
4. SVD pruning of every encoder's 1:80:1 network, retrained at the pruned size (Fig. 3);
5. Fourier, lookup-table and network compensation on the test grid (Table 3, Fig. 4);
6. reproducibility across a later epoch and a second decoder;

then writes the tables (text on stdout, CSV), the figures (PNG), one HTML report
and one model file per encoder, and checks that every model file, loaded
back, corrects its encoder's test run to the accuracy the report states.

Fits run on up to two worker processes (see :mod:`encal._core.pool`); every
fit is seeded by what it is, not by when it runs, so the numbers are the same
for any number of workers.
"""

import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .._core.atomic import atomic_file_set, atomic_write, staged_path
from .._core.errors import EncalError, InputError
from ..analysis.profile import error_stats, harmonics
from .._core.pool import Workers, run_tasks
from .studies.algorithms import EXTRA_ALGORITHMS, PAPER_ALGORITHMS, compare_algorithms
from .studies.comparison import compare_models
from .studies.pruning import svd_pruning
from .studies.reproducibility import reproducibility
from .studies.sweep import PAPER_HIDDEN, hidden_node_sweep
from .studies.tables import (
    PAPER_TABLE1,
    algorithm_table,
    comparison_table,
    profile_table,
    pruning_table,
    reproducibility_table,
    sweep_table,
)

__all__ = ["DemoSettings", "FULL", "QUICK", "EncoderResult", "SavedModel", "DemoResult", "run_demo"]


@dataclass(frozen=True)
class DemoSettings:
    """How much work the demo does.

    Attributes
    ----------
    n_encoders : int
        Encoders of the demo fleet.
    hidden : tuple of int
        Hidden-node counts of the sweep.
    sweep_seeds, sweep_epochs : int
        Fits per sweep point and epoch budget of each.
    algorithm_seeds, algorithm_epochs : int
        Fits per algorithm in Table 2 and the epoch budget every algorithm gets.
    network_epochs : int
        Epoch budget of the networks of Table 3 and of the SVD pruning.
    saved_model : str
        The model written to ``<encoder>.json``: ``'auto'``, the one ``encal fit`` chooses by
        cross-validation on the training grid (same seed), or the key of a Table 3 model.
    """

    n_encoders: int = 4
    hidden: tuple = PAPER_HIDDEN
    sweep_seeds: int = 3
    sweep_epochs: int = 1000
    algorithm_seeds: int = 5
    algorithm_epochs: int = 1000
    network_epochs: int = 1000
    saved_model: str = "auto"

    def describe(self):
        """The settings in words, for the report."""
        saved = "the model encal fit chooses" if self.saved_model == "auto" else f"Table 3's {self.saved_model}"
        return (f"{self.n_encoders} encoders; sweep N = {', '.join(str(n) for n in self.hidden)} with "
                f"{self.sweep_seeds} seed(s) of at most {self.sweep_epochs} epochs; Table 2 with "
                f"{self.algorithm_seeds} seed(s) of {self.algorithm_epochs} epochs; Table 3 networks "
                f"{self.network_epochs} epochs; model files: {saved}")


#: The full demo: the paper's sweep (N = 10..110) and MATLAB's default budget of 1000 epochs.
FULL = DemoSettings()

#: A quick run for tests: three sweep points, few epochs, two seeds per algorithm.
QUICK = DemoSettings(hidden=(10, 40, 80), sweep_seeds=1, sweep_epochs=30, algorithm_seeds=2,
                     algorithm_epochs=30, network_epochs=30)


@dataclass(frozen=True, eq=False)
class EncoderResult:
    """Everything the demo measured on one encoder.

    Attributes
    ----------
    name : str
    train, test : Calibration
        The training (0, 2, ..., 358 deg) and test (1, 3, ..., 359 deg) runs.
    profile : ErrorStats
        Error statistics of the training and test points together (Table 1, Fig. 1), arcmin.
    harmonics : Harmonics
        Harmonic analysis of the training run.
    floor_arcmin : float
        Measurement floor of the test run, arcmin.
    comparison : Comparison
        Table 3 for this encoder.
    pruning : PruningResult
        SVD pruning of the paper's 1:80:1 network.
    reproducibility : Reproducibility
        Later epoch and second decoder against the first calibration.
    saved : SavedModel
        The model written to ``<name>.json`` and its accuracy on the test grid.
    cpu_s : float
        CPU time of this encoder's fits and analyses, seconds.
    """

    name: str
    train: object
    test: object
    profile: object
    harmonics: object
    floor_arcmin: float
    comparison: object
    pruning: object
    reproducibility: object
    saved: object = None
    cpu_s: float = 0.0


@dataclass(frozen=True, eq=False)
class SavedModel:
    """The model the demo writes for one encoder.

    Attributes
    ----------
    model : Model
    label : str
        What it is, in words (the chosen candidate of ``encal fit``, or a Table 3 row).
    evaluation : Evaluation
        The model on the test grid, which it never saw (arcmin).
    """

    model: object
    label: str
    evaluation: object

    @property
    def stats(self):
        """Residual statistics on the test grid (arcmin)."""
        return self.evaluation.after


@dataclass(eq=False)
class DemoResult:
    """The demo's results, tables and files.

    Attributes
    ----------
    settings : DemoSettings
    encoders : dict of str to EncoderResult
    sweep : SweepResult
    algorithms : AlgorithmStudy
    tables : dict of str to Table
        By CSV name, in print order.
    files : dict of str to Path
        Everything written, by role (``'report'``, ``'model:enc1'``, ``'table:...'``, ``'figure:...'``).
    checks : dict of str to dict
        Per encoder, the reloaded model's test statistics and the reported ones.
    timings : dict of str to float
        Wall-clock seconds of each stage.
    workers : int
        Worker processes used.
    """

    settings: DemoSettings
    encoders: dict
    sweep: object
    algorithms: object
    tables: dict = field(default_factory=dict)
    files: dict = field(default_factory=dict)
    checks: dict = field(default_factory=dict)
    timings: dict = field(default_factory=dict)
    workers: int = 1


def _encoder_study(task):
    """Table 3, SVD pruning and reproducibility of one encoder (runs in a worker process)."""
    cpu_start = time.process_time()
    settings, seed = task["settings"], task["seed"]
    train, test = task["train"], task["test"]
    comparison = compare_models(train, test, floor_arcmin=task["floors"]["test"],
                                epochs=settings.network_epochs, rng=seed)
    pruning = svd_pruning(train, test, model=comparison.entry("ann-paper").model,
                          epochs=settings.network_epochs, rng=seed)
    repeats = {label: task[label] for label in ("epoch2", "decoder2")}
    saved = _saved_model(settings.saved_model, comparison, train, test, seed)
    repro = reproducibility(train, repeats, model=saved.model, test=test,
                            floors={label: task["floors"][label] for label in repeats})
    both = np.r_[train.errors_arcmin, test.errors_arcmin]
    return EncoderResult(
        name=train.name, train=train, test=test, profile=error_stats(both),
        harmonics=harmonics(train.encoder_deg, train.errors_arcmin),
        floor_arcmin=task["floors"]["test"], comparison=comparison, pruning=pruning, reproducibility=repro,
        saved=saved, cpu_s=time.process_time() - cpu_start)


def _saved_model(key, comparison, train, test, seed):
    """The model written for an encoder: ``encal fit``'s choice ('auto') or a Table 3 row."""
    from ..models.fitting import evaluate, fit
    from ..models.auto import Selection

    if key == "auto":
        model = fit(train, method="auto", rng=seed)
        selection = Selection.of(model)
        label = f"chosen by encal fit: {selection.chosen if selection is not None else model.kind}"
    else:
        entry = comparison.entry(key)
        model, label = entry.model, entry.label
    return SavedModel(model, label, evaluate(model, test))


def _stage(timings, name):
    """Context manager recording the wall-clock time of a stage."""

    class _Timer:
        def __enter__(self):
            self.start = time.perf_counter()
            return self

        def __exit__(self, *exc):
            timings[name] = time.perf_counter() - self.start
            return False

    return _Timer()


def run_demo(out="encal-demo", *, quick=False, settings=None, workers=None, seed=0, progress=True,
             stdout=None, report=True):
    """Run the paper's whole procedure on the demo fleet and write its results to ``out``.

    Parameters
    ----------
    out : str or os.PathLike or None, default='encal-demo'
        Folder for the report, tables, figures and model files (created if missing). None writes nothing
        (no figures, report or model files).
    quick : bool, default=False
        Use :data:`QUICK` (for tests) instead of :data:`FULL`.
    settings : DemoSettings, optional
        Overrides ``quick``.
    workers : int or None, default=None
        Worker processes (None: the CPU count, at most 2; 0: fit in this process).
    seed : int, default=0
        Study seed of every fit.
    progress : bool, default=True
        Progress bars on stderr.
    stdout : file-like, optional
        Where the tables and the summary are printed; default ``sys.stdout``.
    report : bool, default=True
        Write the HTML report and figures (needs Matplotlib).

    Returns
    -------
    DemoResult

    Raises
    ------
    EncalError
        If a model file, loaded back, does not reproduce the reported accuracy.
    """
    from ..simulate import demo_fleet, measurement_floor

    settings = settings or (QUICK if quick else FULL)
    stream = sys.stdout if stdout is None else stdout
    timings = {}
    total_start = time.perf_counter()
    out = None if out is None else Path(out)
    if out is not None:
        if out.exists() and not out.is_dir():
            raise InputError(f"--out {out} is a file; expected a folder for the demo's results")
        out.mkdir(parents=True, exist_ok=True)

    with _stage(timings, "simulate"):
        fleet = demo_fleet(settings.n_encoders)
    tasks = [{"settings": settings, "seed": seed, "train": m.train.calibration, "test": m.test.calibration,
              "epoch2": m.epoch2.calibration, "decoder2": m.decoder2.calibration,
              "floors": {name: measurement_floor(run) for name, run in m.runs.items()}} for m in fleet]
    first = fleet[0]
    with Workers(workers) as pool:
        with _stage(timings, "encoders"):
            results = run_tasks(_encoder_study, tasks, workers=pool, progress=progress,
                                label="per-encoder fits (Table 3, pruning, repeats)")
        with _stage(timings, "sweep"):
            sweep = hidden_node_sweep(first.train.calibration, first.test.calibration, hidden=settings.hidden,
                                      epochs=settings.sweep_epochs, seeds=settings.sweep_seeds,
                                      curve_hidden=80 if 80 in settings.hidden else None, rng=seed,
                                      workers=pool, progress=progress)
        with _stage(timings, "algorithms"):
            algorithms = compare_algorithms(first.train.calibration, first.test.calibration,
                                            algorithms=(*PAPER_ALGORITHMS, *EXTRA_ALGORITHMS),
                                            epochs=settings.algorithm_epochs, seeds=settings.algorithm_seeds,
                                            rng=seed, workers=pool, progress=progress)
        encoders = {r.name: r for r in results}
        result = DemoResult(settings=settings, encoders=encoders, sweep=sweep, algorithms=algorithms,
                            timings=timings, workers=pool.count)
        result.tables = _tables(result)
        for table in result.tables.values():
            stream.write(table.to_text() + "\n\n")
        stream.flush()
        if out is not None:
            with atomic_file_set():  # all the files, or none of them
                with _stage(timings, "files"):
                    _write_tables(result, out)
                    _write_models(result, out)
                if report:
                    with _stage(timings, "report"):
                        _write_report(result, out, pool, progress)
    timings["total"] = time.perf_counter() - total_start
    _print_summary(result, stream)
    return result


def _tables(result):
    encoders = result.encoders
    tables = [
        profile_table({n: e.profile for n, e in encoders.items()}, {n: e.harmonics for n, e in encoders.items()},
                      paper=PAPER_TABLE1),
        sweep_table(result.sweep),
        algorithm_table(result.algorithms),
        pruning_table({n: e.pruning for n, e in encoders.items()}),
        comparison_table({n: e.comparison for n, e in encoders.items()}),
        reproducibility_table({n: e.reproducibility for n, e in encoders.items()}),
    ]
    return {table.name: table for table in tables}


def _write_tables(result, out):
    folder = out / "tables"
    folder.mkdir(exist_ok=True)
    for name, table in result.tables.items():
        result.files[f"table:{name}"] = table.write_csv(folder / f"{name}.csv")


def _write_models(result, out):
    """Save one model per encoder, load it back, and check it reproduces the reported test accuracy."""
    from ..deploy import load_model
    from ..models.fitting import evaluate

    for name, encoder in result.encoders.items():
        entry = encoder.saved
        path = out / f"{name}.json"
        entry.model.save(path, reproducible=True)
        result.files[f"model:{name}"] = path
        reloaded = evaluate(load_model(staged_path(path)), encoder.test).after
        reported = entry.stats
        result.checks[name] = {"model": entry.label, "file": str(path), "rms_arcmin": reloaded.rms,
                               "max_abs_arcmin": reloaded.max_abs, "reported_rms_arcmin": reported.rms,
                               "reported_max_abs_arcmin": reported.max_abs}
        if not (np.isclose(reloaded.rms, reported.rms, rtol=1e-9, atol=1e-12)
                and np.isclose(reloaded.max_abs, reported.max_abs, rtol=1e-9, atol=1e-12)):
            raise EncalError(
                f"{path} loaded back corrects {name}'s test run to RMS {reloaded.rms:.6f} arcmin, but the "
                f"report states {reported.rms:.6f}; expected the saved model to reproduce the reported accuracy")


def _write_report(result, out, workers, progress):
    from .report import render_figures, write_report

    figures = render_figures(result, workers=workers, progress=progress)
    folder = out / "figures"
    folder.mkdir(exist_ok=True)
    for name, png in figures.items():
        path = folder / f"{name}.png"
        atomic_write(path, png)
        result.files[f"figure:{name}"] = path
    result.files["report"] = write_report(result, out / "report.html", figures)


def _print_summary(result, stream):
    lines = []
    for name, check in result.checks.items():
        before = result.encoders[name].comparison.entry("before").stats
        lines.append(f"{name}: {Path(check['file']).name} ({check['model']}) loaded back corrects the test run "
                     f"from RMS {before.rms:.3f} to {check['rms_arcmin']:.3f} arcmin, max |error| "
                     f"{before.max_abs:.2f} -> {check['max_abs_arcmin']:.2f} arcmin, as reported")
    if "report" in result.files:
        lines.append(f"report: {result.files['report']}")
    stages = ", ".join(f"{k} {v:.1f} s" for k, v in result.timings.items())
    lines.append(f"time ({result.workers} worker process{'es' if result.workers != 1 else ''}): {stages}")
    if not result.checks:
        lines.append("no files written (out=None)")
    stream.write("\n".join(lines) + "\n")
    stream.flush()
