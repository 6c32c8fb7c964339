"""Run the paper's whole procedure on the built-in demo fleet of four simulated encoders.

Prints Tables 1-3 and the other studies' tables on stdout (progress bars go
to stderr) and writes to DIR: report.html (one self-contained file),
tables/*.csv, figures/*.png, and one model file per encoder (enc1.json, ...).
Each model file is loaded back and checked to correct its encoder's test run
to the accuracy the report states.

Examples:
  encal demo                       # writes encal-demo/
  encal demo --out /tmp/demo --quick
"""

from ._common import size_option


def add_arguments(parser):
    parser.add_argument("--out", default="encal-demo", metavar="DIR",
                        help="folder for the report, tables, figures and model files (default: encal-demo)")
    parser.add_argument("--quick", action="store_true",
                        help="a small sweep and few epochs: seconds instead of a minute (for tests)")
    parser.add_argument("--workers", type=size_option("workers", 0), metavar="N",
                        help="worker processes for the fits (default: CPU count, at most 2; 0: none)")
    parser.add_argument("--seed", type=int, default=0, help="study seed of every fit (default: 0)")
    parser.add_argument("--encoders", type=size_option("encoders"), default=4, metavar="N",
                        help="encoders of the demo fleet (default: 4, the paper's)")
    parser.add_argument("--no-progress", action="store_true", help="no progress bars on stderr")


def run(args):
    from dataclasses import replace

    from ..paper.demo import FULL, QUICK, run_demo

    if args.seed < 0:
        from .._core.errors import InputError

        raise InputError(f"--seed must be a whole number >= 0. Got {args.seed} instead.")
    settings = replace(QUICK if args.quick else FULL, n_encoders=args.encoders)
    run_demo(args.out, settings=settings, workers=args.workers, seed=args.seed, progress=not args.no_progress)
    return 0
