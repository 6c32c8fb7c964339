"""The report for your own encoder: one self-contained HTML page and its figures as PNG files.

Fits the model `encal fit` would make (same --method, same --seed; a seed is drawn and recorded when none
is given) and shows: the error profile with the model and its 95 % band, the zero offset stated apart when
the reference's zero is arbitrary, harmonic amplitudes and phases, the model comparison on held-out points,
errors before and after compensation on every TEST.csv (points the model never saw), the reversal (ISO 230-2)
when the calibration has a direction column, and drift when there are several epochs (an epoch column, or two
or more TEST files). The figures are embedded in the page and also written to REPORT_figures/.

Examples:
  encal report enc1_train.csv enc1_test.csv -o enc1.html
  encal report stepper.csv -o stepper.html --zero arbitrary
"""

from pathlib import Path

from ._common import (activity, add_calibration_options, add_target_tolerance_option, add_zero_options, check_paths,
                      read_calibration_from_args)


def add_arguments(parser):
    parser.add_argument("calibration", metavar="CAL.csv", help="calibration CSV the model is fitted on")
    parser.add_argument("tests", metavar="TEST.csv", nargs="*",
                        help="held-out or later calibrations of the same encoder")
    parser.add_argument("-o", "--output", required=True, metavar="REPORT.html", help="HTML file to write")
    parser.add_argument("--figures", metavar="DIR",
                        help="folder for the PNG figures (default: REPORT_figures beside the page)")
    parser.add_argument("--method", default="auto", choices=["auto", "spectral", "fourier", "lut", "ann", "hybrid"],
                        help="model family, as for encal fit (default: auto)")
    parser.add_argument("--seed", type=int, help="random seed, as for encal fit")
    parser.add_argument("--no-uncertainty", dest="uncertainty", action="store_false",
                        help="skip the bootstrap of the uncertainty band (30 to 100 refits of a chosen model other "
                             "than the spectral model, whose band comes from its posterior at no cost and is kept)")
    comparison = parser.add_mutually_exclusive_group()
    comparison.add_argument("--no-comparison", dest="compare", action="store_const", const=False, default="auto",
                            help="skip the model comparison (every candidate family scored on the test "
                                 "calibrations, or cross-validated without one)")
    comparison.add_argument("--comparison", dest="compare", action="store_const", const=True,
                            help="run the model comparison also on a calibration of more than 5000 points, "
                                 "where it is left out by default (it costs minutes there)")
    parser.add_argument("--model", metavar="MODEL.json",
                        help="also write the model file (the same model encal fit writes)")
    add_zero_options(parser)
    add_calibration_options(parser)
    add_target_tolerance_option(parser)


def run(args):
    from .._core.atomic import atomic_file_set
    from ..reports.encoder import ENCODER_FIGURES, encoder_report, verdict, write_encoder_report

    output = Path(args.output)
    figures_dir = Path(args.figures) if args.figures is not None else output.with_name(f"{output.stem}_figures")
    check_paths(inputs=[(path, "calibration") for path in (args.calibration, *args.tests)],
                outputs=[("-o", output), ("--model", args.model)],
                folders=[("--figures" if args.figures is not None else "the figures' folder", figures_dir,
                          [f"{name}.png" for name in ENCODER_FIGURES])])
    with activity("report") as progress:
        cal = read_calibration_from_args(args.calibration, args, progress, targets=True)
        tests = [read_calibration_from_args(path, args, progress) for path in args.tests]
        progress.stage(f"fitting ({args.method})" + (", comparing the models" if args.compare is not False else "")
                       + (", the uncertainty band" if args.uncertainty else ""))
        report = encoder_report(cal, tests, method=args.method, zero=args.zero, rng=args.seed,
                                uncertainty=args.uncertainty, compare=args.compare)
        progress.stage(f"writing {output} and its figures")
        with atomic_file_set():  # the page, its figures and the model file, or none of them
            written = write_encoder_report(report, output, figures_dir=args.figures)
            if args.model is not None:
                report.model.save(args.model)
    print(verdict(report))
    from ..reports.encoder import correction_warnings

    for sentence in correction_warnings(report):  # a valid report (status 0), but never a quiet one
        import warnings

        from .._core.errors import EncalWarning

        warnings.warn(sentence, EncalWarning, stacklevel=2)
    for note in report.notes + ([report.comparison_note] if report.comparison_note else []):
        print(note)
    figures = [path for key, path in written.items() if key.startswith("figure:")]
    print(f"{report.name}: {report.model.kind} model (seed {report.seed}); wrote {output} and "
          f"{len(figures)} figures in {figures[0].parent if figures else '-'}")
    return 0
