"""The paper's network studies on your own calibration: hidden-node sweep, algorithm table, SVD pruning.

  sweep       final training MSE of the 1:N:1 network for N = 10..110 with trainlm and traingd (Fig. 2)
  algorithms  final training MSE at N = 80 for every training algorithm, over seeds (Table 2)
  prune       SVD of the trained network's hidden layer; the network retrained at the pruned size (Fig. 3)

The table goes to stdout; with --out DIR its CSV and figure(s) are written there too.

Examples:
  encal study sweep enc1_train.csv --out study/ --seeds 3
  encal study algorithms enc1_train.csv --test enc1_test.csv --epochs 500
  encal study prune enc1_train.csv --test enc1_test.csv
"""

from .._core.number_cells import read_whole
from ._common import add_calibration_options, check_paths, nonnegative_int, read_calibration_from_args, size_option


def add_arguments(parser):
    parser.add_argument("study", choices=["sweep", "algorithms", "prune"], help="which study")
    parser.add_argument("train", metavar="TRAIN.csv", help="calibration the networks are trained on")
    parser.add_argument("--test", metavar="TEST.csv",
                        help="calibration to measure each network on (never used for training)")
    parser.add_argument("--out", metavar="DIR", help="write the table as CSV and the figure(s) as PNG here")
    parser.add_argument("--seeds", type=size_option("seeds"),
                        help="fits per point from different initial weights (default: sweep 1, algorithms 5)")
    parser.add_argument("--epochs", type=size_option("epochs"), default=1000,
                        help="epoch budget of every fit (default: 1000, MATLAB's)")
    parser.add_argument("--hidden", metavar="N[,N...]",
                        help="hidden nodes: a list for sweep (default 10,20,...,110), one number otherwise "
                             "(default 80)")
    parser.add_argument("--algorithms", metavar="NAMES",
                        help="comma-separated MATLAB names (default: sweep trainlm,traingd; algorithms all ten)")
    parser.add_argument("--encoding", choices=["raw", "periodic"], default="raw",
                        help="network input: the raw angle (the paper's, default) or cos/sin")
    parser.add_argument("--threshold", type=float, default=1e-2,
                        help="prune: relative threshold of a significant singular value (default: 1e-2)")
    parser.add_argument("--seed", type=nonnegative_int, default=0, help="study seed (default: 0)")
    parser.add_argument("--workers", type=size_option("workers", 0), metavar="N",
                        help="worker processes (default: CPU count, at most 2; 0: none)")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar on stderr")
    add_calibration_options(parser)


def _counts(text, default, single):
    from .._core.limits import SIZE_LIMITS
    from .._core.errors import InputError

    if text is None:
        return default
    try:
        values = [read_whole(v) for v in text.split(",") if v.strip()]  # not '1_0' (10) nor '１'
    except ValueError:
        values = []
    largest = SIZE_LIMITS["hidden"][0]
    if not values or min(values) < 1 or max(values) > largest or (single and len(values) != 1):
        what = (f"one whole number from 1 to {largest}" if single
                else f"comma-separated whole numbers from 1 to {largest}")
        raise InputError(f"--hidden must be {what} ({SIZE_LIMITS['hidden'][1]}). Got {text!r} instead.")
    return values[0] if single else tuple(values)


def _names(text, default):
    if text is None:
        return default
    return tuple(name.strip() for name in text.split(",") if name.strip())


def _check_algorithms(names):
    from .._core.errors import InputError
    from ..training import ALGORITHMS

    unknown = [name for name in names if name not in ALGORITHMS]
    if unknown or not names:
        raise InputError(f"--algorithms must name some of {', '.join(sorted(ALGORITHMS))}. "
                         f"Got {', '.join(unknown) or 'none'} instead.")
    return names


def _sweep(args, train, test):
    from ..paper.studies.sweep import PAPER_HIDDEN, hidden_node_sweep

    hidden = _counts(args.hidden, PAPER_HIDDEN, single=False)
    algorithms = _check_algorithms(_names(args.algorithms, ("trainlm", "traingd")))
    result = hidden_node_sweep(train, test, hidden=hidden, algorithms=algorithms, encoding=args.encoding,
                               epochs=args.epochs, seeds=args.seeds or 1,
                               curve_hidden=80 if 80 in hidden else hidden[-1], rng=args.seed,
                               workers=args.workers, progress=not args.no_progress)
    return result.table(), {"fig2a_sweep": result.plot, "fig2b_training": result.plot_curves}


def _algorithms(args, train, test):
    from ..paper.studies.algorithms import EXTRA_ALGORITHMS, PAPER_ALGORITHMS, compare_algorithms

    algorithms = _check_algorithms(_names(args.algorithms, (*PAPER_ALGORITHMS, *EXTRA_ALGORITHMS)))
    result = compare_algorithms(train, test, algorithms=algorithms, hidden=_counts(args.hidden, 80, single=True),
                                encoding=args.encoding, epochs=args.epochs, seeds=args.seeds or 5, rng=args.seed,
                                workers=args.workers, progress=not args.no_progress)
    return result.table(), {"table2_algorithms": result.plot, "table2_training": result.plot_curves}


def _prune(args, train, test):
    from ..paper.studies.pruning import svd_pruning
    from ..paper.studies.tables import pruning_table

    result = svd_pruning(train, test, hidden=_counts(args.hidden, 80, single=True), encoding=args.encoding,
                         epochs=args.epochs, threshold=args.threshold, rng=args.seed)
    return pruning_table({train.name: result}), {"fig3_singular_values": result.plot}


_STUDIES = {"sweep": _sweep, "algorithms": _algorithms, "prune": _prune}
#: The files each study writes into --out.
_WRITES = {"sweep": ("fig2a_sweep.csv", "fig2a_sweep.png", "fig2b_training.png"),
           "algorithms": ("table2_algorithms.csv", "table2_algorithms.png", "table2_training.png"),
           "prune": ("fig3_pruning.csv", "fig3_singular_values.png")}


def run(args):
    from pathlib import Path

    out = Path(args.out) if args.out else None
    check_paths(inputs=[(args.train, "calibration"), (args.test, "calibration")],
                folders=[("--out", out, _WRITES[args.study])])
    train = read_calibration_from_args(args.train, args)
    test = read_calibration_from_args(args.test, args) if args.test else None
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
    table, figures = _STUDIES[args.study](args, train, test)
    print(table.to_text())
    if out is not None:
        from .._core.atomic import atomic_file_set
        from ..figures import detached_figures, save_figure

        with atomic_file_set(), detached_figures():  # the table and every figure, or none of them
            table.write_csv(out / f"{table.name}.csv")
            for name, plot in figures.items():
                save_figure(plot().figure, out / f"{name}.png")
        print(f"wrote {table.name}.csv and {', '.join(name + '.png' for name in figures)} in {out}")
    return 0
