"""The C program that times one function over many codes, shared by bench_deploy.py and bench_hotpaths.py.

``timing_driver(call, header="", declaration="", n=...)`` is the source of a program that evaluates
``call`` (a C expression in the loop variable ``k``, a ``uint32_t``) for ``k = 0 .. n-1``, three
times, and prints the least CPU time per call in nanoseconds and a checksum (so that the compiler
cannot drop the calls).

``machine()`` describes the machine such timings ran on: CPU, cores, system, Python, NumPy, gcc.
"""

import os
import platform
import shutil
import subprocess

import numpy as np

_TEMPLATE = """\
#define _POSIX_C_SOURCE 199309L
#include <stdint.h>
#include <stdio.h>
#include <time.h>
{header}
{declaration}

static double now(void)
{{
    struct timespec t;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}}

int main(void)
{{
    const uint32_t n = {n}u;
    double best = 1e30, sum = 0.0;
    int repeat;
    for (repeat = 0; repeat < 3; ++repeat) {{
        uint32_t k;
        const double start = now();
        double elapsed;
        for (k = 0; k < n; ++k) {{
            sum += (double){call};
        }}
        elapsed = now() - start;
        if (elapsed < best) best = elapsed;
    }}
    printf("%.3f %g\\n", 1e9 * best / (double)n, sum);
    return 0;
}}
"""


def timing_driver(call, *, n, header="", declaration=""):
    """C source of the timing program (see the module docstring)."""
    return _TEMPLATE.format(call=call, n=n, header=header, declaration=declaration)


def machine():
    """One line: the CPU, its cores, the system, Python, NumPy and gcc versions."""
    cpu = "unknown CPU"
    with open("/proc/cpuinfo", encoding="utf-8") as handle:
        for line in handle:
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    gcc = "no gcc"
    if shutil.which("gcc"):
        gcc = subprocess.run(["gcc", "--version"], capture_output=True, text=True).stdout.split("\n")[0]
    return (f"{cpu}, {os.cpu_count()} cores, {platform.system()} {platform.release()}; "
            f"Python {platform.python_version()}, NumPy {np.__version__}; {gcc}")
