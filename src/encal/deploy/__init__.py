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
"""

from .cexport import export_c, write_c
from .compact import CompactTable, choose_compact, compile_compact
from .compensator import Compensator
from .. import runtime  # the standalone reader, encal's bottom layer; here too, beside the other artefacts
from ..models.modelfile import load_model, model_from_dict, model_to_dict, read_model, save_model
from .table import CorrectionTable, compile_table, load_table, save_table
from .targets import export_target, write_target

__all__ = ["runtime", "save_model", "load_model", "read_model", "model_to_dict", "model_from_dict",
           "Compensator", "CorrectionTable", "compile_table", "save_table", "load_table",
           "export_c", "write_c", "CompactTable", "compile_compact", "choose_compact", "export_target",
           "write_target"]
