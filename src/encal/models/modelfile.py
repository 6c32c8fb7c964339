"""The model file: a model and how it was made, as versioned, checksummed JSON.

The format is specified in ``docs/model-file.md``. Checking a file (format,
version, checksum, fields, parameter shapes) is done by the standalone reader
:mod:`encal.runtime`, so encal and a copied runtime accept exactly the
same files; this module turns files into :class:`~encal.models.Model` objects
and back.
"""

import contextlib
import datetime
import json
import math
from pathlib import Path

import numpy as np

from .. import runtime
from .._atomic import atomic_write
from .._environment import source_date_epoch
from .._version import __version__
from ..arcs import check_range
from ..errors import InputError, ModelFileError
from .kind import kind_names, model_kind

__all__ = ["save_model", "load_model", "read_model", "model_to_dict", "model_from_dict", "dumps",
           "FORMAT", "VERSION"]

FORMAT = runtime.FORMAT
VERSION = runtime.VERSION

#: Date written by ``reproducible=True`` when SOURCE_DATE_EPOCH is not set.
_REPRODUCIBLE_DATE = "1970-01-01T00:00:00Z"


def model_to_dict(model, *, reproducible=False):
    """The model file content of ``model``, as a JSON-ready dict (with ``sha256``).

    Parameters
    ----------
    model : Model
        Any registered model kind.
    reproducible : bool, default=False
        Write a fixed training date (SOURCE_DATE_EPOCH if set, else
        1970-01-01T00:00:00Z) and no wall-clock timings (``time_s`` entries
        become null), so the same model gives the same bytes.

    Returns
    -------
    dict
        ``format, version, kind``, ``form`` for a kind the format does not name
        (then version 3), ``encoder``, ``reading_sign`` when it is -1 (then
        version 2, else 1) or in version 3, ``units, normalisation, parameters,
        training``, ``uncertainty`` when the model has one, and ``sha256``, in
        that order.

    Raises
    ------
    ModelFileError
        If the parameters do not fit the format (wrong shapes, NaN or infinite numbers).
    InputError
        If the training metadata is not JSON data, or SOURCE_DATE_EPOCH is not an integer.
    """
    # Any object with a model's interface (this module sits below :class:`~encal.models.base.Model`,
    # whose ``save`` it serves).
    if not all(callable(getattr(model, name, None)) for name in ("parameters", "predict")) \
            or not isinstance(getattr(model, "kind", None), str):
        raise InputError(f"expected an encal Model to save, got {type(model).__name__}")
    where = f"the {model.kind} model of {model.encoder.get('name') or 'an unnamed encoder'}"
    form = runtime.KIND_FORMS.get(model.kind, getattr(model, "form", None))
    if form not in runtime.FORMS:
        raise ModelFileError(f"{where}: format version {VERSION} holds the model kinds "
                             f"{', '.join(runtime.KINDS)}, and other kinds stored in one of the forms "
                             f"{', '.join(runtime.FORMS)} (the class's 'form'); {model.kind!r} gives "
                             f"{'no form' if form is None else f'the form {form!r}'}")
    named = {} if model.kind in runtime.KIND_FORMS else {"form": form}
    parameters = _json_data(model.parameters(), "parameters", finite=True)
    with _encal_errors():
        runtime.check_parameters(form, parameters, where)
    encoder = _json_data(model.encoder, "encoder", finite=False)
    sign = model.reading_sign
    if isinstance(sign, bool) or sign not in runtime.READING_SIGNS:
        raise ModelFileError(f"{where}: expected reading_sign 1 or -1, got {sign!r}")
    range_deg = getattr(model, "range_deg", None)
    if range_deg is not None:
        range_deg = check_range(list(range_deg), where)
    version = runtime.version_for(sign, runtime.names_a_form({"kind": model.kind, **named,
                                                              "parameters": parameters}),
                                  has_range=range_deg is not None or model.kind == "arc")
    document = {
        "format": FORMAT,
        "version": version,
        "kind": model.kind,
        **named,
        "encoder": {"name": encoder.pop("name", None) or "",
                    "resolution_bits": encoder.pop("resolution_bits", None), **encoder},
        **({} if version == 1 else {"reading_sign": int(sign)}),
        **({} if range_deg is None else {"range_deg": range_deg}),
        "units": dict(runtime.UNITS),
        "normalisation": runtime.normalisation_of(form, parameters),
        "parameters": parameters,
        "training": _training_metadata(model, reproducible),
    }
    if model.uncertainty is not None:
        document["uncertainty"] = _json_data(model.uncertainty, "uncertainty", finite=True)
    try:
        document["sha256"] = runtime.content_sha256(document)
    except ValueError:
        raise ModelFileError(f"{where}: expected finite numbers only, got NaN or infinity "
                             "outside the checked parameters") from None
    with _encal_errors():
        runtime.check_document(document, where)
    return document


def model_from_dict(document, *, source="model file", verify_checksum=True):
    """Rebuild a model from a model file's content.

    Parameters
    ----------
    document : dict
        As returned by :func:`model_to_dict` or read from a model file.
    source : str, default='model file'
        Where the content came from, for messages.
    verify_checksum : bool, default=True
        Whether to compare ``sha256`` with the content (hand-made dicts may skip it).

    Returns
    -------
    Model

    Raises
    ------
    ModelFileError
        If the content is not a valid model file of a version this encal reads.
    """
    with _encal_errors():
        runtime.check_document(document, source, verify_checksum=verify_checksum)
    kind = document["kind"]
    cls = model_kind(kind).model_class if kind in kind_names() else None
    if cls is None:
        raise ModelFileError(f"{source}: expected a model kind this installation can evaluate, "
                             f"got {kind!r}, which has no registered model class")
    try:
        model = cls.from_parameters(document["parameters"], encoder=document["encoder"],
                                    training=document["training"])
    except ModelFileError as exc:
        raise ModelFileError(f"{source}: {exc}") from None
    if document.get("uncertainty") is not None:
        model.uncertainty = document["uncertainty"]
    model.reading_sign = runtime.reading_sign_of(document)
    model.range_deg = runtime.range_of(document)
    return model


def save_model(model, path, *, reproducible=False):
    """Write ``model`` to a model file, atomically.

    Parameters
    ----------
    model : Model
    path : str or os.PathLike
        Destination (``.json``); its folder must exist.
    reproducible : bool, default=False
        Fix the training date (see :func:`model_to_dict`), so that the same
        data, options and seed give a byte-identical file.

    Returns
    -------
    pathlib.Path
        The file written.
    """
    atomic_write(path, dumps(model_to_dict(model, reproducible=reproducible)))  # refuses what is no path
    return Path(path)


def load_model(path):
    """Read a model file.

    Parameters
    ----------
    path : str or os.PathLike

    Returns
    -------
    Model

    Raises
    ------
    ModelFileError
        If the file is not JSON, not an encal model file, of a newer format
        version, altered after it was written (checksum), or malformed, or
        cannot be read (missing, a folder, no permission), or ``path`` is not
        a path (None); the message names the file.
    """
    return read_model(path)[0]


def read_model(path):
    """Read a model file; return the model and the file's ``sha256`` (which identifies it).

    Raises the same errors as :func:`load_model`.
    """
    with _encal_errors():
        document = runtime.read_document(path)
    model = model_from_dict(document, source=str(path), verify_checksum=False)
    return model, document["sha256"]


def dumps(document):
    """Model file text: readable JSON, one field per line, number arrays on one line each."""
    return _dumps(document, "") + "\n"


def _dumps(value, indent):
    inner = indent + "  "
    if isinstance(value, dict) and value:
        items = [f"{inner}{json.dumps(key, ensure_ascii=False)}: {_dumps(item, inner)}"
                 for key, item in value.items()]
        return "{\n" + ",\n".join(items) + "\n" + indent + "}"
    if isinstance(value, list) and any(isinstance(item, (list, dict)) for item in value):
        rows = ",\n".join(inner + _dumps(item, inner) for item in value)
        return "[\n" + rows + "\n" + indent + "]"
    return json.dumps(value, ensure_ascii=False, allow_nan=False, separators=(", ", ": "))


@contextlib.contextmanager
def _encal_errors():
    """Re-raise the standalone runtime's errors as encal's :class:`ModelFileError`."""
    try:
        yield
    except runtime.ModelFileError as exc:
        raise ModelFileError(str(exc)) from None


def _training_metadata(model, reproducible):
    training = {
        "method": model.kind, "algorithm": None, "epochs": None, "seed": None,
        "data_sha256": None, "n_points": None, "date": None, "encal_version": __version__,
        "options": {},
        **_json_data(model.training, "training", finite=False),
    }
    fixed = _fixed_date(reproducible)
    training["date"] = fixed or training["date"] or _utc_iso(datetime.datetime.now(datetime.UTC))
    if fixed:
        training = _without_timings(training)
    return training


def _without_timings(data):
    """``data`` with every wall-clock timing (a ``time_s`` entry) set to None: they differ run to run."""
    if isinstance(data, dict):
        return {key: None if key == "time_s" else _without_timings(value) for key, value in data.items()}
    if isinstance(data, list):
        return [_without_timings(value) for value in data]
    return data


def _fixed_date(reproducible):
    """The date to write when builds must be reproducible, else None."""
    seconds = source_date_epoch()
    if seconds is not None:
        return _utc_iso(datetime.datetime.fromtimestamp(seconds, datetime.UTC))
    return _REPRODUCIBLE_DATE if reproducible else None


def _utc_iso(moment):
    return moment.strftime("%Y-%m-%dT%H:%M:%SZ")


def _json_data(value, field, *, finite):
    """``value`` as plain JSON data (NumPy arrays and scalars become lists and numbers).

    Non-finite floats are kept when ``finite`` (the checks then name the
    field), and become ``None`` in metadata, since JSON has no NaN.
    """
    if isinstance(value, np.ndarray):
        value = value.tolist()
    elif isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, dict):
        result = {}
        for key, item in value.items():
            if not isinstance(key, str):
                raise InputError(f"expected text keys in the model's {field}, got {key!r}")
            result[key] = _json_data(item, f"{field}.{key}", finite=finite)
        return result
    if isinstance(value, (list, tuple)):
        return [_json_data(item, f"{field}[{i}]", finite=finite) for i, item in enumerate(value)]
    if isinstance(value, float) and not math.isfinite(value) and not finite:
        return None
    if value is None or isinstance(value, (str, int, float)):
        return value
    raise InputError(f"expected JSON data (numbers, text, lists, dicts) in the model's {field}, "
                     f"got a {type(value).__name__}")
