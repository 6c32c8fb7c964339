"""Write the two example inputs of README.md that `encal simulate` does not make.

Both are synthetic (made here, from a stated error profile), so their truth is known:

- ``stepper.csv``: a stepper motor stepped through its 200 full steps (1.8 deg) against a 14-bit magnetic
  encoder read in counts, the way a Mechaduino-style board calibrates. The motor's zero is wherever it stood
  when calibration began (59.3 deg from the encoder's), so the error carries an arbitrary offset.
  Columns ``step_deg`` (the reference, degrees) and ``counts`` (0..16383).
- ``motor_log.txt``: a motor's log over one turn, whitespace-separated, angles in revolutions.
  Columns ``time_s``, ``commanded_rev`` (the reference) and ``measured_rev`` (the encoder).

Run from the repository: ``python examples/make_examples.py`` (writes into examples/).
"""

from pathlib import Path

import numpy as np

HERE = Path(__file__).parent


def profile_arcmin(theta_deg):
    """The encoder's own error against its reading: orders 1, 2 and 4, 8.3 arcmin RMS."""
    r = np.radians(theta_deg)
    return 9.0 * np.sin(r + 0.4) + 6.0 * np.cos(2 * r - 1.1) + 2.5 * np.sin(4 * r)


def stepper(rng):
    steps = np.arange(200) * 1.8
    shaft = steps + 59.3  # the encoder's angle of each full step
    encoder_deg = shaft + (profile_arcmin(shaft) + rng.normal(0.0, 0.5, steps.size)) / 60.0
    counts = np.mod(np.round(encoder_deg * 2**14 / 360.0), 2**14).astype(int)
    rows = [f"{s:.1f},{c:d}" for s, c in zip(steps, counts)]
    return "# synthetic stepper calibration (examples/make_examples.py)\nstep_deg,counts\n" + "\n".join(rows) + "\n"


def motor_log(rng):
    commanded = np.arange(400) / 400.0  # one turn, 0.9 deg apart
    measured = commanded + (profile_arcmin(commanded * 360.0) + rng.normal(0.0, 0.3, commanded.size)) / 21600.0
    rows = [f"{0.01 * i:8.2f}  {c:.7f}  {m:.7f}" for i, (c, m) in enumerate(zip(commanded, measured))]
    return ("# synthetic motor log (examples/make_examples.py)\n  time_s  commanded_rev  measured_rev\n"
            + "\n".join(rows) + "\n")


if __name__ == "__main__":
    rng = np.random.default_rng(2024)
    (HERE / "stepper.csv").write_text(stepper(rng), encoding="utf-8")
    (HERE / "motor_log.txt").write_text(motor_log(rng), encoding="utf-8")
