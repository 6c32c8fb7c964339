"""Tables of the studies: printed as aligned text, written as CSV, embedded in the report as HTML.

A :class:`Table` holds raw values (floats stay floats); each :class:`Column`
says how to print its values and what its CSV header is. The builders below
make the paper's Tables 1-3 and the tables of encal's other studies from the
studies' result objects.
"""

import csv
import html
import io
import math
from dataclasses import dataclass, field

from ..._core.atomic import atomic_write

__all__ = [
    "Column",
    "Table",
    "profile_table",
    "sweep_table",
    "algorithm_table",
    "pruning_table",
    "comparison_table",
    "reproducibility_table",
    "PAPER_TABLE1",
    "PAPER_TABLE2",
    "PAPER_TABLE3",
]

#: The paper's Table 1: encoder -> (MAE, "RMS") in arcmin. Its "RMS" is the standard deviation.
PAPER_TABLE1 = {"enc1": (1.33, 1.48), "enc2": (0.55, 0.65), "enc3": (1.09, 1.35), "enc4": (1.78, 1.31)}

#: The paper's Table 2: algorithm -> final training MSE (arcmin^2) of the 1:80:1 network on encoder 1.
PAPER_TABLE2 = {"trainrp": 0.0150, "traincgp": 0.0103, "traincgf": 0.0144, "trainoss": 0.0147,
                "trainlm": 0.0083, "trainscg": 0.0096, "trainbfg": 0.0091}

#: The paper's Table 3: encoder -> (before, Fourier, ANN), each (MAE, "RMS") in arcmin on the test grid.
PAPER_TABLE3 = {
    "enc1": ((1.33, 1.48), (0.16, 0.21), (0.15, 0.19)),
    "enc2": ((0.55, 0.65), (0.16, 0.20), (0.16, 0.21)),
    "enc3": ((1.09, 1.35), (0.14, 0.18), (0.14, 0.20)),
    "enc4": ((1.78, 1.31), (0.16, 0.21), (0.14, 0.19)),
}


@dataclass(frozen=True)
class Column:
    """One column of a :class:`Table`.

    Parameters
    ----------
    key : str
        CSV header and JSON key, with its unit (``'rms_arcmin'``).
    heading : str
        Text heading (``'RMS'``); the table's title says the unit.
    fmt : str, default='{:.3f}'
        Format of a number in the text and HTML forms; strings print as they are.
    """

    key: str
    heading: str
    fmt: str = "{:.3f}"

    def text(self, value):
        """``value`` as printed in the table."""
        if value is None or (isinstance(value, float) and math.isnan(value)):
            return "-"
        if isinstance(value, str):
            return value
        return self.fmt.format(value)


@dataclass(frozen=True)
class Table:
    """A titled table of values with notes.

    Parameters
    ----------
    name : str
        File stem of its CSV (``'table1_profiles'``).
    title : str
        One line, with the unit of its numbers.
    columns : tuple of Column
    rows : tuple of tuple
        Raw values, one per column.
    notes : tuple of str
        Printed under the table.

    Examples
    --------
    >>> t = Table("t", "Demo (arcmin)", (Column("encoder", "encoder", "{}"), Column("mae_arcmin", "MAE")),
    ...           (("enc1", 1.2345),))
    >>> print(t.to_text())
    Demo (arcmin)
    encoder    MAE
    -------  -----
    enc1     1.234
    >>> t.csv_text()
    'encoder,mae_arcmin\\nenc1,1.2345\\n'
    """

    name: str
    title: str
    columns: tuple
    rows: tuple
    notes: tuple = field(default=())

    def __post_init__(self):
        object.__setattr__(self, "columns", tuple(self.columns))
        object.__setattr__(self, "rows", tuple(tuple(row) for row in self.rows))
        object.__setattr__(self, "notes", tuple(self.notes))
        for row in self.rows:
            if len(row) != len(self.columns):
                raise ValueError(f"table {self.name!r}: a row has {len(row)} values for "
                                 f"{len(self.columns)} columns")

    def _cells(self):
        return [[column.text(value) for column, value in zip(self.columns, row)] for row in self.rows]

    def to_text(self):
        """The table as aligned plain text: title, header, rule, rows, notes."""
        cells = self._cells()
        headings = [column.heading for column in self.columns]
        widths = [max([len(h)] + [len(row[i]) for row in cells]) for i, h in enumerate(headings)]
        numeric = [all(not isinstance(row[i], str) for row in self.rows if row[i] is not None)
                   for i in range(len(self.columns))]

        def line(values):
            parts = [v.rjust(w) if right else v.ljust(w) for v, w, right in zip(values, widths, numeric)]
            return "  ".join(parts).rstrip()

        out = [self.title, line(headings), "  ".join("-" * w for w in widths)]
        out += [line(row) for row in cells]
        out += [f"Note: {note}" for note in self.notes]
        return "\n".join(out)

    def __str__(self):
        return self.to_text()

    def csv_text(self):
        """The table as CSV: one header row of column keys, raw values (``'.8g'`` for floats)."""
        buffer = io.StringIO()
        writer = csv.writer(buffer, lineterminator="\n")
        writer.writerow([column.key for column in self.columns])
        for row in self.rows:
            writer.writerow(["" if v is None else format(v, ".8g") if isinstance(v, float) else v
                             for v in row])
        return buffer.getvalue()

    def write_csv(self, path):
        """Write :meth:`csv_text` to ``path`` atomically; returns the path."""
        atomic_write(path, self.csv_text())
        return path

    def records(self):
        """The rows as a list of dicts keyed by column key (JSON-ready)."""
        return [dict(zip((c.key for c in self.columns), row)) for row in self.rows]

    def to_html(self):
        """The table as an HTML ``<table>`` with a caption and notes (escaped)."""
        head = "".join(f"<th>{html.escape(c.heading)}</th>" for c in self.columns)
        body = []
        for row, cells in zip(self.rows, self._cells()):
            tds = "".join(
                f'<td class="{"text" if isinstance(v, str) else "num"}">{html.escape(text)}</td>'
                for v, text in zip(row, cells))
            body.append(f"<tr>{tds}</tr>")
        notes = "".join(f'<p class="note">{html.escape(n)}</p>' for n in self.notes)
        return (f"<table><caption>{html.escape(self.title)}</caption><thead><tr>{head}</tr></thead>"
                f"<tbody>{''.join(body)}</tbody></table>{notes}")


# --------------------------------------------------------------------------- Table 1


def profile_table(stats, harmonics, n_orders=10, paper=None):
    """Table 1: the error profile of every encoder (arcmin) and its largest harmonic orders.

    Parameters
    ----------
    stats : mapping of str to ErrorStats
        Statistics of each encoder's profile (training and test points together, as in the paper).
    harmonics : mapping of str to Harmonics
        Harmonic analysis of each encoder's training run.
    n_orders : int, default=10
        How many orders to list (the paper lists 10).
    paper : mapping of str to (float, float), optional
        The paper's (MAE, "RMS") per encoder, shown beside the measured values.

    Returns
    -------
    Table
    """
    columns = [Column("encoder", "encoder", "{}"), Column("n", "n", "{:d}"),
               Column("mae_arcmin", "MAE"), Column("rms_arcmin", "RMS"), Column("std_arcmin", "STD"),
               Column("min_arcmin", "min"), Column("max_arcmin", "max"), Column("pp_arcmin", "p-p")]
    if paper:
        columns += [Column("paper_mae_arcmin", "paper MAE", "{:.2f}"),
                    Column("paper_rms_arcmin", "paper 'RMS'", "{:.2f}")]
    columns.append(Column("top_orders", f"top-{n_orders} harmonic orders", "{}"))
    rows = []
    for name, s in stats.items():
        row = [name, s.n, s.mae, s.rms, s.std, s.min, s.max, s.pp]
        if paper:
            row += list(paper.get(name, (None, None)))
        row.append(" ".join(str(k) for k in harmonics[name].top(n_orders)))
        rows.append(row)
    notes = ["RMS is the root mean square about zero and STD the standard deviation about the mean, so "
             "RMS >= MAE always. The paper's 'RMS' column is the STD: its encoder 4 has MAE 1.78 > 'RMS' "
             "1.31, which no root mean square can be."]
    return Table("table1_profiles", "Table 1. Error profiles before compensation (arcmin)", columns, rows,
                 notes)


# --------------------------------------------------------------------------- Fig. 2a as a table


def sweep_table(sweep):
    """The hidden-node sweep: final training MSE (arcmin^2) per hidden-node count and algorithm.

    With a test calibration, the final test MSE (median over seeds) follows each algorithm's training columns.
    """
    with_test = sweep.test_mse_arcmin2 is not None
    columns = [Column("hidden", "N", "{:d}")]
    for algorithm in sweep.algorithms:
        columns += [Column(f"{algorithm}_mse_arcmin2", f"{algorithm} MSE", "{:.4g}"),
                    Column(f"{algorithm}_spread_arcmin2", "+/-", "{:.2g}")]
        if with_test:
            columns.append(Column(f"{algorithm}_test_mse_median_arcmin2", "test MSE", "{:.4g}"))
    rows = []
    for i, hidden in enumerate(sweep.hidden):
        row = [int(hidden)]
        for algorithm in sweep.algorithms:
            row += [float(sweep.mse_mean(algorithm)[i]), float(sweep.mse_std(algorithm)[i])]
            if with_test:
                row.append(float(sweep.test_mse_median(algorithm)[i]))
        rows.append(row)
    notes = [f"{sweep.encoding} encoding, {sweep.n_seeds} seed(s) per point (mean +/- standard deviation), "
             f"at most {_budget_text(sweep.epochs)} epochs per fit; encoder {sweep.encoder}."]
    if with_test:
        notes.append("test MSE: mean squared residual on the test grid (points never used in training), "
                     "median over seeds.")
    return Table("fig2a_sweep", f"Hidden-node sweep (Fig. 2a): final MSE (arcmin^2) of the 1:N:1 network, "
                 f"{sweep.encoder}", columns, rows, notes)


def _budget_text(epochs):
    return ", ".join(f"{name} {count}" for name, count in epochs.items())


# --------------------------------------------------------------------------- Table 2


def algorithm_table(study):
    """Table 2: final training MSE (arcmin^2) of the 1:N:1 network per training algorithm, over seeds."""
    columns = [Column("algorithm", "algorithm", "{}"), Column("paper_name", "paper's name", "{}"),
               Column("paper_mse_arcmin2", "paper MSE", "{:.4f}"),
               Column("mse_mean_arcmin2", "mean MSE", "{:.4f}"), Column("mse_std_arcmin2", "std", "{:.4f}"),
               Column("mse_min_arcmin2", "best", "{:.4f}"), Column("mse_max_arcmin2", "worst", "{:.4f}"),
               Column("test_rms_median_arcmin", "test RMS", "{:.3f}"),
               Column("test_rms_worst_arcmin", "worst", "{:.3f}"),
               Column("epochs_median", "epochs", "{:.0f}"), Column("stop", "stopped by", "{}"),
               Column("cpu_s", "CPU (s)", "{:.2f}")]
    rows = []
    for r in study.rows:
        rows.append([r.algorithm, r.paper_name or "-", PAPER_TABLE2.get(r.algorithm), r.mse_mean, r.mse_std,
                     r.mse_min, r.mse_max, r.test_rms_median, r.test_rms_worst, r.epochs_median, r.stop_reasons,
                     r.cpu_mean_s])
    notes = [f"1:{study.hidden}:1 network, {study.encoding} encoding, encoder {study.encoder}; "
             f"{study.n_seeds} seeds per algorithm (mean, population std, best, worst); each algorithm "
             f"gets at most {study.epochs} epochs and stops early only by its own MATLAB criteria.",
             "test RMS: residual RMS (arcmin) on the test grid (points never used in training): median and "
             "worst over seeds. CPU: mean CPU time of one fit."]
    return Table("table2_algorithms", "Table 2. Final training MSE (arcmin^2) by training algorithm",
                 columns, rows, notes)


# --------------------------------------------------------------------------- Fig. 3 as a table


def pruning_table(results):
    """SVD pruning per encoder: significant singular values and the pruned network's accuracy.

    Parameters
    ----------
    results : mapping of str to PruningResult
    """
    others = sorted({t for r in results.values() for t in r.counts if t != r.threshold}, reverse=True)
    columns = [Column("encoder", "encoder", "{}"), Column("hidden", "N", "{:d}"),
               Column("rank_before_activation", "rank of X", "{:d}"),
               Column("threshold", "threshold", "{:.0e}"),
               Column("significant", "significant", "{:d}")]
    columns += [Column(f"significant_at_{t:.0e}", f"at {t:.0e}", "{:d}") for t in others]
    columns += [Column("epochs_full", "epochs", "{:d}"), Column("mse_full_arcmin2", "MSE full", "{:.4f}"),
                Column("mse_pruned_arcmin2", "MSE pruned", "{:.4f}"),
                Column("test_rms_full_arcmin", "test RMS full", "{:.3f}"),
                Column("test_rms_pruned_arcmin", "test RMS pruned", "{:.3f}")]
    rows = []
    for name, r in results.items():
        epochs = getattr(getattr(r.full_model, "train_result", None), "epochs", None)
        rows.append([name, r.hidden, r.rank_before_activation, r.threshold, r.significant,
                     *[r.counts.get(t) for t in others], epochs, r.full_mse, r.pruned_mse, r.full_test_rms,
                     r.pruned_test_rms])
    notes = ["rank of X: numerical rank of the paper's matrix (hidden-node net inputs, before the sigmoid), 2 "
             "at most for one input. significant: singular values of the hidden-node outputs after the sigmoid "
             "above threshold x the largest; 'at' columns: the same count at other thresholds.",
             "The pruned network (N = significant) is trained afresh, the same way as the full one. MSE in "
             "arcmin^2 on the training grid; test RMS in arcmin on the test grid."]
    return Table("fig3_pruning", "SVD pruning (Fig. 3) of the 1:N:1 network", columns, rows, notes)


# --------------------------------------------------------------------------- Table 3


def comparison_table(comparisons):
    """Table 3: test-grid residuals (arcmin) of every model for every encoder.

    Parameters
    ----------
    comparisons : mapping of str to Comparison
        One comparison per encoder (:func:`encal.paper.studies.comparison.compare_models`).
    """
    with_floor = any(c.floor_arcmin is not None for c in comparisons.values())
    columns = [Column("encoder", "encoder", "{}"), Column("model", "model", "{}"),
               Column("mae_arcmin", "MAE"), Column("rms_arcmin", "RMS"), Column("std_arcmin", "STD"),
               Column("max_abs_arcmin", "max |r|")]
    if with_floor:
        columns.append(Column("rms_over_floor", "RMS/floor", "{:.2f}"))
    rows = []
    for name, comparison in comparisons.items():
        for entry in comparison.entries:
            s = entry.stats
            row = [name, entry.label, s.mae, s.rms, s.std, s.max_abs]
            if with_floor:
                row.append(entry.rms_over_floor)
            rows.append(row)
    notes = ["Residual = observed error - predicted error on the test grid (1, 3, ..., 359 deg), points "
             "no model was fitted to. 'before' is the raw error."]
    if with_floor:
        floors = ", ".join(f"{n} {c.floor_arcmin:.3f}" for n, c in comparisons.items()
                           if c.floor_arcmin is not None)
        notes.append("floor: RMS of measured minus noise-free error of the test run (arcmin), the best RMS "
                     f"any model can reach on it: {floors}.")
    return Table("table3_comparison", "Table 3. Residual error on the test grid (arcmin)", columns, rows,
                 notes)


# --------------------------------------------------------------------------- reproducibility


def reproducibility_table(results):
    """Repeat calibrations against the first one, and the first one's model on the repeats (arcmin).

    Parameters
    ----------
    results : mapping of str to Reproducibility
        One result per encoder (:func:`encal.paper.studies.reproducibility.reproducibility`).
    """
    with_floor = any(run.floor_arcmin is not None for r in results.values() for run in r.runs)
    columns = [Column("encoder", "encoder", "{}"), Column("run", "run", "{}"),
               Column("diff_mae_arcmin", "diff MAE"), Column("diff_rms_arcmin", "diff RMS"),
               Column("diff_max_abs_arcmin", "diff max|d|"),
               Column("within_1lsb", "within 1 LSB", "{:.0%}"),
               Column("model_rms_arcmin", "model RMS"),
               Column("model_rms_first_test_arcmin", "same-epoch test RMS")]
    if with_floor:
        columns.append(Column("floor_arcmin", "floor"))
    rows = []
    for name, result in results.items():
        same_epoch = None if result.first_test_residual is None else result.first_test_residual.rms
        for run in result.runs:
            row = [name, run.label, run.difference.mae, run.difference.rms, run.difference.max_abs,
                   run.within_one_lsb, run.model_residual.rms, same_epoch]
            if with_floor:
                row.append(run.floor_arcmin)
            rows.append(row)
    lsbs = {r.lsb_arcmin for r in results.values() if r.lsb_arcmin is not None}
    lsb_text = f"; 1 LSB = {lsbs.pop():.4f} arcmin" if len(lsbs) == 1 else ""
    notes = [f"diff: error of the repeat run minus error of the first run at the same reference angles{lsb_text}.",
             "model RMS: residual RMS when the model fitted to the first run corrects the repeat run; "
             "same-epoch test RMS: the same model on the first epoch's test grid, without drift."]
    if with_floor:
        notes.append("floor: RMS of measured minus noise-free error of the repeat run, the best any model can do.")
    return Table("reproducibility", "Reproducibility of the error profile (arcmin)", columns, rows, notes)
