"""Firmware exports through the firmwares' own code: stated against measured round trip.

    python benchmarks/bench_firmware_own.py

Every harness in ``tests/deploy/firmware_own/`` (one per firmware) compiles or imports that firmware's
run-time code from ``../shared/firmware/`` and applies encal's table to every code of an encoder,
for the matrix of configurations of issue 26 (14- and 16-bit, encoder reversed, reference zero at
0 to 30 degrees, moteus sign and offset, each SimpleFOC version). Prints one Markdown row per
export x configuration: the round trip encal states, the one the firmware's code gives, or encal's
refusal. This is the table of BENCHMARKS.md "Firmware".
"""

import importlib
import pkgutil
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import tests.deploy.firmware_own as harnesses  # noqa: E402


def main():
    print("| firmware | configuration | stated RMS / max, arcmin | firmware's own code RMS / max, arcmin | "
          "agrees (5 %) |")
    print("|---|---|---|---|---|")
    failures = 0
    for info in pkgutil.iter_modules(harnesses.__path__):
        if info.name.startswith("test_"):  # the harnesses' tests stand beside them
            continue
        module = importlib.import_module(f"tests.deploy.firmware_own.{info.name}")
        reason = module.unavailable()
        if reason:
            print(f"| {info.name} | skipped: {reason} | | | |")
            continue
        for row in module.matrix():
            ok = harnesses.agrees(row)
            failures += not ok
            if row.refused:
                print(f"| {row.firmware} | {row.configuration} | refused: {row.refused} | | yes |")
            else:
                print(f"| {row.firmware} | {row.configuration} | {row.stated_rms:.4g} / {row.stated_max:.4g} | "
                      f"{row.measured_rms:.4g} / {row.measured_max:.4g} | {'yes' if ok else 'NO'} |")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
