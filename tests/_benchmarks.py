"""A benchmark script of ``benchmarks/`` loaded as a module, for the tests that run part of it."""

import importlib.util

from tests._paths import REPO


def load_benchmark(name):
    """The module of ``benchmarks/<name>.py`` (not on ``sys.path``: loaded from its file)."""
    spec = importlib.util.spec_from_file_location(name, REPO / "benchmarks" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module
