"""``encal._core.memory``: freed memory given back between a command's stages (issue 30, dense30)."""

import subprocess
import sys

import pytest

from encal._core import memory

PROGRAM = """
import re, numpy as np
from encal._core.memory import release_freed_memory
def resident():
    return int(re.search(r"VmRSS:\\s+(\\d+)", open("/proc/self/status").read()).group(1)) // 1024
block = bytearray(30 * 2**20)   # a file read at once: its own mapping, whose release raises glibc's threshold
del block
arrays = [np.ones(10**6) for _ in range(8)]  # then 8 MB arrays come from the heap ...
del arrays[:-1]  # ... and stay resident once freed, below the one still held
before = resident()
released = release_freed_memory()
print(released, before, resident())
"""


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's malloc_trim is a Linux allocator's")
def test_memory_freed_by_numpy_is_given_back():
    memory.release_freed_memory()
    if memory._trim is False:
        pytest.skip("this C library has no malloc_trim (glibc's)")
    process = subprocess.run([sys.executable, "-c", PROGRAM], capture_output=True, text=True, check=True)
    released, before, after = process.stdout.split()
    assert released == "True" and int(before) - int(after) > 30  # MiB: the seven arrays freed (56 MB) let go


def test_without_malloc_trim_nothing_happens(monkeypatch):
    monkeypatch.setattr(memory, "_trim", False)
    assert memory.release_freed_memory() is False
