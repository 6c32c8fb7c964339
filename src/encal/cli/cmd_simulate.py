"""Write simulated calibration CSVs of 16-bit resolver encoders (docs/simulator.md).

Without --seed: the built-in demo fleet, enc1..enc4 from fixed seeds (the
encoders of `encal demo`); with N > 4, enc5, enc6, ... come from one more
fixed seed, so the files are the same on every machine. With --seed S: N
encoders drawn from seed S.

For each encoder four files are written to DIR:
  <name>_train.csv     training grid 0, 2, ..., 358 deg
  <name>_test.csv      test grid 1, 3, ..., 359 deg
  <name>_epoch2.csv    training grid, calibrated again at a later epoch
  <name>_decoder2.csv  training grid, read by a second R/D converter
Columns: reference_deg, encoder_deg, epoch, and noise_free_error_arcmin, the
error without per-reading noise and with quantisation replaced by its mean
(readers of calibrations ignore it).
"""

from pathlib import Path

import numpy as np

from .._core.atomic import atomic_file_set
from .._version import __version__
from ..data.calibration import write_calibration
from .._core.errors import InputError
from ._common import int_in_range, nonnegative_int

MAX_ENCODERS = 1000

_RUN_DESCRIPTIONS = {
    "train": "training grid 0:2:358 deg, epoch 1, decoder 1",
    "test": "test grid 1:2:359 deg, epoch 1, decoder 1",
    "epoch2": "training grid 0:2:358 deg, epoch 2, decoder 1",
    "decoder2": "training grid 0:2:358 deg, epoch 1, decoder 2",
}


def add_arguments(parser):
    parser.add_argument("--encoders", metavar="N", type=int_in_range(1, MAX_ENCODERS), default=4,
                        help=f"number of encoders, 1 to {MAX_ENCODERS} (default 4)")
    parser.add_argument("--seed", metavar="S", type=nonnegative_int, default=None,
                        help="draw the encoders from this seed (default: the built-in demo fleet)")
    parser.add_argument("--out", metavar="DIR", default="encal-sim",
                        help="folder for the CSV files, created if missing (default encal-sim)")


def _output_folder(text):
    folder = Path(text)
    if folder.exists() and not folder.is_dir():
        raise InputError(f"--out {folder} is a file; expected a folder for the simulated calibrations")
    parent = folder.parent if str(folder.parent) else Path(".")
    if not parent.is_dir():
        raise InputError(f"--out {folder}: the parent folder {parent} does not exist; "
                         "expected an existing folder to create it in")
    folder.mkdir(exist_ok=True)
    return folder


def _seed_comment(member, demo):
    seed = member.seed
    stream = f", stream {seed.spawn_key[0]}" if seed.spawn_key else ""
    origin = "demo fleet" if demo else "encal simulate --seed"
    return f"seed: {seed.entropy}{stream} ({origin})"


def _summary(member, files):
    errors = member.train.errors_arcmin
    return (f"{member.name}: train MAE {np.mean(np.abs(errors)):.2f}  RMS {np.sqrt(np.mean(errors**2)):.2f}  "
            f"STD {np.std(errors):.2f}  min {errors.min():+.2f}  max {errors.max():+.2f} arcmin  "
            f"-> {files}")


def run(args):
    from ..simulate import demo_fleet, simulate_fleet

    folder = _output_folder(args.out)
    demo = args.seed is None
    fleet = demo_fleet(args.encoders) if demo else simulate_fleet(args.encoders, args.seed)
    summaries = []
    with atomic_file_set():  # every file of the fleet, or none
        for member in fleet:
            for run_name, sim_run in member.runs.items():
                write_calibration(
                folder / f"{member.name}_{run_name}.csv",
                    sim_run.calibration,
                    extra_columns={"noise_free_error_arcmin": sim_run.noise_free_error_arcmin},
                    comments=[
                        f"encal {__version__} simulate: simulated 16-bit resolver encoder (docs/simulator.md)",
                        _seed_comment(member, demo),
                        f"encoder: {member.name}",
                        f"run: {run_name} ({_RUN_DESCRIPTIONS[run_name]})",
                        "noise_free_error_arcmin: error without per-reading noise, quantisation at its mean",
                    ],
                )
            summaries.append(_summary(member, folder / f"{member.name}_*.csv"))
    print("\n".join(summaries))
    return 0
