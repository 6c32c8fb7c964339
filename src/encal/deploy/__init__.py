"""Deployment: model files, online correction, dense tables and C export.

- :func:`save_model` / :func:`load_model`: the versioned, checksummed JSON model file.
- :class:`Compensator`: correct encoder readings with a model (NumPy, vectorised).
- :mod:`encal.runtime`: a standalone, standard-library-only reader of model
  files, to copy into a data acquisition program.
- :func:`compile_table`: a per-code correction table for a B-bit encoder.
- :func:`export_c`: C source for firmware.
- :func:`compile_compact` / :func:`choose_compact`: a periodic table of N nodes (linear or cubic B-spline)
  with a stated deployed error; :func:`export_target`: C for ``host``,
  ``cortex-m4f`` (float32 only) or ``fixed`` (integers only).

Public names are loaded on first use, as in :mod:`encal`: ``encal correct`` needs the compensator
alone, not the C export and every model kind behind it.
"""

import importlib

# public name -> module that defines it
_PUBLIC = {
    "runtime": "encal.runtime",  # the standalone reader, encal's bottom layer; here too, beside the other artefacts
    "save_model": "encal.models.modelfile", "load_model": "encal.models.modelfile",
    "read_model": "encal.models.modelfile", "model_to_dict": "encal.models.modelfile",
    "model_from_dict": "encal.models.modelfile",
    "Compensator": "encal.deploy.compensator",
    "CorrectionTable": "encal.deploy.table", "compile_table": "encal.deploy.table",
    "save_table": "encal.deploy.table", "load_table": "encal.deploy.table",
    "export_c": "encal.deploy.cexport", "write_c": "encal.deploy.cexport",
    "CompactTable": "encal.deploy.compact", "compile_compact": "encal.deploy.compact",
    "choose_compact": "encal.deploy.compact",
    "export_target": "encal.deploy.targets", "write_target": "encal.deploy.targets",
}

__all__ = list(_PUBLIC)


def __getattr__(name):
    try:
        module = _PUBLIC[name]
    except KeyError:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}") from None
    module = importlib.import_module(module)
    value = module if name == "runtime" else getattr(module, name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(__all__))
