"""Firmware formats: bytes written and the round trip through each firmware's own rule.

    python benchmarks/bench_firmware.py

For the stored fourier and cubic-lut model files (16-bit) and a 10-term Fourier series fitted to
one real AS5047D calibration (14-bit, ../shared/data/real), writes every firmware format and
prints the file's size, the round trip (that firmware's run-time rule against the model's
correction, on every code: max / RMS) and the storage rounding a priori, all in arcmin; then the real
model's largest orders (amplitude, arcmin), which say what 64 buckets or nodes (5.6 deg) cannot follow.
"""

from pathlib import Path

import numpy as np

import encal
from encal.deploy import Compensator
from encal.deploy.firmware import EXPORTERS

ROOT = Path(__file__).resolve().parents[1]
REAL = ROOT.parent / "shared" / "data" / "real" / "mechaduino" / "mech_cejosey_2019-01-01_f7b12b5a.csv"


def main():
    models = {"fourier (stored, 16-bit)": Compensator(ROOT / "tests" / "data" / "model_v1_fourier.json"),
              "lut cubic (stored, 16-bit)": Compensator(ROOT / "tests" / "data" / "model_v1_lut.json")}
    if REAL.is_file():
        model = encal.fit(encal.read_calibration(REAL), method="fourier", n_orders=10)
        models["real AS5047D, 10-term Fourier (14-bit)"] = Compensator(model)
        amplitudes = np.hypot(model.cos, model.sin)
        largest = ", ".join(f"{k}: {a:.2f}" for k, a in zip(model.orders, amplitudes) if k != 0)
    print("| model | format | file bytes | round trip max / RMS, arcmin | storage rounding, arcmin "
          "| constant left out, arcmin |")
    print("|---|---|---|---|---|---|")
    for name, comp in models.items():
        bits = comp.encoder.get("resolution_bits")
        for fmt, export in EXPORTERS.items():
            if fmt == "mechaduino" and bits != 14:
                continue
            options = {"bits": bits or 16} if fmt == "tinymovr" else {}
            if fmt in ("klipper", "mechaduino"):
                options["step_zero_deg"] = 0.0  # the reference's zero taken for a full step at driver phase 0
            if fmt == "klipper":
                options["step_direction"] = 1  # the stepper's positive steps raise the reference angle
            written = export(comp, **options)
            print(f"| {name} | {fmt} | {len(written.text.encode())} | {written.max_error_arcmin:.3g} / "
                  f"{written.rms_error_arcmin:.3g} | {written.quantisation_arcmin:.3g} | {written.offset_arcmin:.4g} |")
    if REAL.is_file():
        print(f"\nreal AS5047D, 10-term Fourier: orders by amplitude (arcmin) {largest}")


if __name__ == "__main__":
    main()
