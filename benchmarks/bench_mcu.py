"""Instructions per corrected reading, flash and RAM on a Cortex-M4F build, for every kind and target.

    python benchmarks/bench_mcu.py [--quick] [--real FILE.csv]

Each deployment is exported with encal, compiled with Debian's arm-none-eabi-gcc
(``-O2 -mcpu=cortex-m4 -mthumb -mfpu=fpv4-sp-d16 -mfloat-abi=hard``, newlib's libm), linked
with a small driver that calls the code function on K codes spread over the turn, and run
under qemu-arm (user mode, ``-cpu max``: qemu's user mode cannot load a Cortex-M image, and
``max`` executes the same Thumb-2 and single-precision VFP instructions) with
``-singlestep -d exec,nochain``, which logs one line per executed instruction with the name of
the function it belongs to. The instructions executed outside the driver (the exported
function, its helpers and the library functions it calls), divided by K, are the instructions
per reading; instructions are not cycles (a VFP multiply, a load, a branch take 1 to 3 cycles
on a Cortex-M4F; a double-precision operation is a software call of tens of instructions).

Flash is what linking the deployment adds to the program (``.text + .rodata + .data`` over the
driver alone: the exported code and tables and what it pulls in from libm and libgcc), with the
exported object's own share in parentheses; RAM is the object's ``.data + .bss``.
The error column is the deployed error against the model over all 2^B codes, as encal states
it at export time (max and RMS, arc-minutes). Models: the stored test model files (16-bit)
and, unless --quick, models fitted to one real AS5047D calibration (14-bit; the
repository's ../shared/data/real set, or --real).
"""

import argparse
import os
import platform
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import encal
from encal.deploy import Compensator, save_model
from encal.deploy.targets import write_target

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "tests" / "data"
REAL = ROOT.parent / "shared" / "data" / "real" / "mechaduino" / "mech_cejosey_2019-01-01_f7b12b5a.csv"
DEBIAN_PACKAGES = ("gcc-arm-none-eabi", "qemu-user")


def _install_tools():
    """Install the cross-compiler and the emulator from Debian's packages when this is a Debian machine
    on which we are root; otherwise leave it to :func:`main` to say what is missing."""
    if shutil.which("arm-none-eabi-gcc") and shutil.which("qemu-arm"):
        return
    if shutil.which("apt-get") and hasattr(os, "geteuid") and os.geteuid() == 0:
        print(f"# installing {' '.join(DEBIAN_PACKAGES)} from Debian's packages", file=sys.stderr)
        subprocess.run(["apt-get", "update", "-qq"], check=False)
        subprocess.run(["apt-get", "install", "-y", "-qq", *DEBIAN_PACKAGES], check=False)


_install_tools()
CC = shutil.which("arm-none-eabi-gcc")
SIZE = shutil.which("arm-none-eabi-size")
QEMU = shutil.which("qemu-arm")
CFLAGS = ["-O2", "-std=c99", "-mcpu=cortex-m4", "-mthumb", "-mfpu=fpv4-sp-d16", "-mfloat-abi=hard",
          "-ffunction-sections", "-fdata-sections"]
LDFLAGS = ["-nostartfiles", "-static", "-Wl,-Ttext=0x10000", "-Wl,--gc-sections"]
DRIVER_NAMES = {"_start", "bench_main", "_exit_linux"}

START = r"""
void _exit_linux(int code) __attribute__((noreturn));
void _exit_linux(int code)
{
    register int r0 __asm__("r0") = code;
    register int r7 __asm__("r7") = 1; /* Linux exit(): qemu's user mode ends the program */
    __asm__ volatile ("svc #0" : : "r"(r0), "r"(r7));
    for (;;) {}
}
extern int bench_main(void);
void _start(void) __attribute__((naked, noreturn));
void _start(void)
{
    __asm__ volatile ("bl bench_main\n bl _exit_linux\n");
}
"""

DRIVER = r"""
#include <stdint.h>
#include "enc.h"
volatile {result} sink;
int bench_main(void)
{{
    uint32_t i;
    for (i = 0; i < {calls}u; ++i) {{
        const uint32_t code = (i * 2654435761u) >> {shift}; /* spread over the turn */
        sink = {call};
    }}
    return 0;
}}
"""


def build(folder, source_dir, function, result, calls, bits):
    driver = folder / "driver.c"
    call = f"enc_{function}(code)" if function else "({result})code".format(result=result)
    driver.write_text(DRIVER.format(result=result, calls=calls, shift=32 - bits, call=call))
    (folder / "start.c").write_text(START)
    sources = [str(driver), str(folder / "start.c")]
    if function:
        sources.append(str(source_dir / "enc.c"))
    program = folder / ("bench.elf" if function else "base.elf")
    subprocess.run([CC, *CFLAGS, *LDFLAGS, "-I", str(source_dir), *sources, "-lm", "-o", str(program)],
                   check=True, capture_output=True, text=True)
    return program


def instructions(program):
    """Executed instructions outside the driver, from qemu's one-line-per-instruction log."""
    run = subprocess.Popen([QEMU, "-cpu", "max", "-singlestep", "-d", "exec,nochain", "-D", "/dev/stderr",
                            str(program)], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    counter = subprocess.run(["awk", "/^Trace/ {n[$NF]++} END {for (k in n) print k, n[k]}"],
                             stdin=run.stderr, capture_output=True, text=True, check=True)
    run.wait()
    if run.returncode != 0:
        raise RuntimeError(f"{program} failed under qemu-arm ({run.returncode})")
    counts = dict(line.rsplit(" ", 1) for line in counter.stdout.splitlines())
    return sum(int(n) for name, n in counts.items() if name not in DRIVER_NAMES)


def sections(path):
    out = subprocess.run([SIZE, "-A", str(path)], capture_output=True, text=True, check=True).stdout
    sizes = {}
    for line in out.splitlines():
        fields = line.split()
        if len(fields) >= 2 and fields[1].isdigit():
            name = re.sub(r"^(\.[a-z]+).*", r"\1", fields[0])
            sizes[name] = sizes.get(name, 0) + int(fields[1])
    return sizes


def measure(comp, target, options, function, result, bits, calls, work):
    source_dir = work / "src"
    shutil.rmtree(source_dir, ignore_errors=True)
    _, summary = write_target(comp, source_dir, target, prefix="enc", bits=bits, **options)
    obj = source_dir / "enc.o"
    subprocess.run([CC, *CFLAGS, "-Wdouble-promotion", "-c", str(source_dir / "enc.c"), "-o", str(obj)],
                   check=True, capture_output=True)
    own = sections(obj)
    flash = own.get(".text", 0) + own.get(".rodata", 0) + own.get(".data", 0)
    ram = own.get(".data", 0) + own.get(".bss", 0)
    program = build(work, source_dir, function, result, calls, bits)
    base = build(work, source_dir, None, result, calls, bits)
    flash_of = lambda s: s.get(".text", 0) + s.get(".rodata", 0) + s.get(".data", 0)  # noqa: E731
    added = flash_of(sections(program)) - flash_of(sections(base))
    per_reading = instructions(program) / calls
    return {"per_reading": per_reading, "flash": flash, "added": added, "ram": ram,
            "max": summary.get("max_error_arcmin"), "rms": summary.get("rms_error_arcmin"),
            "what": _what(summary)}


def _what(summary):
    if summary["target"] == "host":
        return "double formula" if summary["form"] == "formula" else "dense int16 table"
    if summary["form"] == "formula":
        return f"float32 series, {summary['terms']} terms"
    cubic = " cubic B-spline" if summary.get("interpolation") == "cubic" else ""
    return f"{summary['nodes']}-node {summary['dtype']}{cubic}"


def deployments(kind_is_fourier):
    rows = [("host", {}, "correct_counts", "float", "host (double)"),
            ("host", {"table": "int16"}, "correct_counts", "float", "host --table"),
            ("cortex-m4f", {"interpolation": "linear"}, "correct_code", "uint32_t", "cortex-m4f table"),
            ("cortex-m4f", {"interpolation": "linear"}, "error_lsb", "float", "cortex-m4f table"),
            ("cortex-m4f", {"interpolation": "cubic"}, "correct_code", "uint32_t", "cortex-m4f table"),
            ("cortex-m4f", {"interpolation": "cubic"}, "error_lsb", "float", "cortex-m4f table"),
            ("fixed", {"interpolation": "linear"}, "correct_code", "uint32_t", "fixed table"),
            ("fixed", {"interpolation": "cubic"}, "correct_code", "uint32_t", "fixed table")]
    if kind_is_fourier:
        rows.append(("cortex-m4f", {"form": "formula"}, "correct_code", "uint32_t", "cortex-m4f formula"))
    return rows


def models(quick, real, work):
    found = [(f"{kind} (stored)", Compensator(DATA / f"model_v1_{kind}.json"), 16)
             for kind in ("fourier", "lut", "ann", "hybrid", "stack", "directional")]
    if quick or not real.is_file():
        return found
    cal = encal.read_calibration(real)
    for label, method, options in (("auto (real)", "auto", {"rng": 0}),
                                   ("fourier, 10 terms (real)", "fourier", {"n_orders": 10}),
                                   ("lut cubic (real)", "lut", {"interpolation": "cubic"})):
        model = encal.fit(cal, method=method, **options)
        path = save_model(model, work / f"{method}.json", reproducible=True)
        found.append((f"{label}: {model.kind}", Compensator(path), 14))
    return found


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true", help="stored models only")
    parser.add_argument("--real", type=Path, default=REAL, help="a real 14-bit calibration CSV")
    args = parser.parse_args()
    if not (CC and SIZE and QEMU):
        print("skipped: needs arm-none-eabi-gcc, arm-none-eabi-size and qemu-arm (Debian: gcc-arm-none-eabi, "
              "qemu-user), which could not be installed here")
        return
    version = subprocess.run([CC, "--version"], capture_output=True, text=True).stdout.splitlines()[0]
    print(f"# {version}; {subprocess.run([QEMU, '--version'], capture_output=True, text=True).stdout.splitlines()[0]}")
    print(f"# {platform.machine()}, load average {os.getloadavg()[0]:.2f}")
    print("| model | deployment | function | instructions / reading | flash bytes linked (the object's own) "
          "| RAM bytes | deployed error max / RMS, arcmin |")
    print("|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        for label, comp, bits in models(args.quick, args.real, work):
            fourier = comp.kind == "fourier"
            for target, options, function, result, name in deployments(fourier):
                calls = 4 if target == "host" and "table" not in options else 64
                try:
                    row = measure(comp, target, options, function, result, bits, calls, work)
                except subprocess.CalledProcessError as exc:
                    print(f"| {label} | {name} | {function} | failed: {exc.stderr!s:.80} | | | |")
                    continue
                error = "" if row["max"] is None else f"{row['max']:.3g} / {row['rms']:.3g}"
                print(f"| {label} | {name}: {row['what']} | {function} | {row['per_reading']:.0f} | "
                      f"{row['added']} ({row['flash']}) | {row['ram']} | {error} |", flush=True)


if __name__ == "__main__":
    main()
