"""Correct encoder angles from an encal model file with the Python standard library alone.

This one file is meant to be copied into a data acquisition program: it reads
a model file written by ``encal fit`` (any kind: ``fourier``, ``spectral``, ``lut``, ``ann``,
``hybrid``, ``stack``, ``directional``, or a kind added later), verifies its checksum and structure, and
evaluates the model one angle at a time. It evaluates a model by its *form*, the way its parameters are
stored (a Fourier series, a table, a network, ...): a kind added to encal that saves in one of these forms
is read and evaluated by this file unchanged. It imports nothing but ``json``, ``math``,
``bisect`` and ``hashlib``; NumPy and encal need not be installed.

    import runtime                          # this file, copied and renamed as you like
    model = runtime.load("enc1.json")       # checks the file; raises ModelFileError
    theta_cor = model.correct_deg(123.456)  # degrees in [0, 360)
    error = model.predict_arcmin(123.456)   # arc-minutes

Conventions (those of encal): angles in degrees, errors in arc-minutes, the
error is ``encoder - reference``; the corrected angle is
``(theta_in - predict_arcmin(theta_enc) / 60) mod 360``, in [0, 360), where
``theta_in = model_input_deg(theta_enc, reading_sign)`` is the reading itself,
or its negative for an encoder that counts against its reference (a model
file with ``"reading_sign": -1``, format version 2). A model calibrated over an
arc (``"range_deg": [start, end]``, format version 4) answers NaN outside it, or, with
``correct_deg(theta, outside='error' | 'clamp' | 'pass')``, follows the rule of ``encal correct --outside``.
An angle or a direction that encal refuses raises ValueError here too.

The file format is specified in encal's ``docs/model-file.md``. encal itself
uses the checks below when it loads a file, so every file encal loads, this
reader evaluates the same way. One difference is by design: a file of a kind
that this installation of encal has no class for (a kind added elsewhere, saved
in one of the forms) is evaluated here by its form, and refused by
``encal.load_model``, which builds the kind's own class.
"""

import bisect
import hashlib
import json
import math

__all__ = ["load", "read_document", "RuntimeModel", "ModelFileError", "model_input_deg", "reading_sign_of",
           "version_for", "range_of", "in_range", "nearer_end", "OUTSIDE_RULES",
           "canonical_json", "content_sha256", "check_document", "check_parameters",
           "check_uncertainty", "normalisation_of", "form_of", "names_a_form", "FORMAT", "VERSION", "KINDS",
           "FORMS", "KIND_FORMS"]

FORMAT = "encal.model"
#: The newest format version this reader understands. Version 2 is version 1 plus ``reading_sign``; version 3
#: is version 2 plus ``form``, for a kind the format does not name. A writer uses the oldest version that holds
#: the model, so a file of version 1 means what it always meant. Version 4 is version 3 plus ``range_deg``, for a
#: model calibrated over an arc: outside it the model answers NaN (an older reader refuses the file instead).
VERSION = 4
#: ``reading_sign`` values: 1, the encoder counts with its reference; -1, against it.
READING_SIGNS = (1, -1)
#: The forms a model's parameters are stored in, each checked and evaluated here (docs/model-file.md).
FORMS = ("ann", "directional", "fourier", "hybrid", "lut", "stack")
#: The model kinds the format names, and the form each is stored in (a spectral model: its posterior-mean
#: Fourier series; an arc model, version 4: its piecewise cubic over the turn, with ``range_deg``). A model of
#: another kind names its form in a ``form`` field (version 3), next to its
#: ``kind``: in the file, in a stack's member and in a directional model's part.
KIND_FORMS = {"ann": "ann", "arc": "lut", "directional": "directional", "fourier": "fourier", "hybrid": "hybrid",
              "lut": "lut", "spectral": "fourier", "stack": "stack"}
#: Model kinds whose parameters the format names.
KINDS = tuple(sorted(KIND_FORMS))
#: The forms, and the kinds the format names, that can be one direction's part of a ``directional`` model.
PART_FORMS = ("ann", "fourier", "hybrid", "lut", "stack")
PART_KINDS = tuple(kind for kind in KINDS if KIND_FORMS[kind] in PART_FORMS)
#: The forms, and the kinds the format names, that can be a member of a ``stack`` model.
MEMBER_FORMS = ("ann", "fourier", "hybrid", "lut")
MEMBER_KINDS = tuple(kind for kind in KINDS if KIND_FORMS[kind] in MEMBER_FORMS and kind != "arc")  # no arc in a
# stack: its members are weighed over the whole turn
#: Largest distance of a stack's weights' sum from 1.
WEIGHT_SUM_TOLERANCE = 1e-9
UNITS = {"input": "deg", "output": "arcmin", "error": "encoder - reference"}
FIELDS = ("format", "version", "kind", "encoder", "units", "normalisation", "parameters",
          "training", "sha256")
OPTIONAL_FIELDS = ("uncertainty", "reading_sign", "range_deg")
TRAINING_FIELDS = ("method", "algorithm", "epochs", "seed", "data_sha256", "n_points", "date",
                   "encal_version", "options")
_SCALING_FIELDS = ("input_offset", "input_gain", "target_offset", "target_gain")
_UNCERTAINTY_FIELDS = ("method", "grid_step_deg", "model_std_arcmin", "noise_std_arcmin")


class ModelFileError(ValueError):
    """A model file cannot be used: not JSON, another format, altered, newer, malformed."""


# -- checksum ---------------------------------------------------------------------------

def canonical_json(content):
    """The canonical JSON text of ``content``: keys sorted, no spaces, floats by ``repr``.

    ``json`` writes floats with ``float.__repr__``, the shortest text that
    reads back to the same double, so the canonical text, and the checksum,
    survive a save/load round trip exactly. Non-ASCII text is escaped.
    """
    return json.dumps(content, sort_keys=True, separators=(",", ":"), ensure_ascii=True,
                      allow_nan=False)


def content_sha256(document):
    """SHA-256 (hex) of the canonical JSON of every field of ``document`` but ``sha256``."""
    content = {key: value for key, value in document.items() if key != "sha256"}
    return hashlib.sha256(canonical_json(content).encode("ascii")).hexdigest()


# -- reading and checking ---------------------------------------------------------------

def read_document(path):
    """Read, verify and check a model file; return its JSON object.

    Raises
    ------
    ModelFileError
        If the file is not a valid, unaltered encal model file this reader understands, or cannot be read
        (missing, a folder, no permission), or ``path`` is not a path.
    """
    raw = _read_bytes(path)
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ModelFileError(f"{path}: expected UTF-8 JSON, found a byte that is not UTF-8 "
                             f"at offset {exc.start}") from None
    try:
        document = json.loads(text)
    except json.JSONDecodeError as exc:
        raise ModelFileError(f"{path}: expected a JSON model file, but line {exc.lineno} "
                             f"column {exc.colno} is not valid JSON ({exc.msg})") from None
    except ValueError as exc:  # an integer of more digits than Python converts
        raise ModelFileError(f"{path}: expected a JSON model file, but it holds a number too long to read "
                             f"({exc})") from None
    except RecursionError:
        raise ModelFileError(f"{path}: expected a JSON model file, but its arrays or objects are nested "
                             "too deeply to read") from None
    try:
        check_document(document, path)
    except RecursionError:
        raise ModelFileError(f"{path}: expected an encal model file, but its arrays or objects are nested "
                             "too deeply") from None
    return document


#: Largest model file read, in bytes: an endless device (``/dev/zero``) must not fill the memory.
MAX_FILE_BYTES = 1 << 30


def _read_bytes(path):
    """The bytes of the model file at ``path``; ModelFileError, naming it, when it cannot be read."""
    if isinstance(path, bool) or not (isinstance(path, (str, bytes)) or hasattr(type(path), "__fspath__")):
        # an int would be taken as an open file descriptor, and closed after reading
        shown = repr(path) if len(repr(path)) <= 60 else repr(path)[:57] + "..."
        raise ModelFileError(f"expected the path of a model file (a str or os.PathLike), got {shown}")
    chunks, size = [], 0
    try:
        with open(path, "rb") as handle:
            while chunk := handle.read(1 << 20):
                if b"\x00" in chunk:  # JSON text holds no NUL byte: a binary file, a device
                    offset = size + chunk.index(b"\x00")
                    raise ModelFileError(f"{path}: expected UTF-8 JSON, found a NUL byte at offset {offset} "
                                         "(is this a binary file?)")
                size += len(chunk)
                if size > MAX_FILE_BYTES:
                    raise ModelFileError(f"{path}: is larger than {MAX_FILE_BYTES >> 20} MiB; expected a model "
                                         "file (is this an endless stream or a device?)")
                chunks.append(chunk)
    except IsADirectoryError:
        raise ModelFileError(f"{path}: is a folder; expected a model file") from None
    except FileNotFoundError:
        raise ModelFileError(f"{path}: no such file; expected a model file") from None
    except OSError as exc:
        raise ModelFileError(f"{path}: cannot be read ({exc.strerror or exc}); expected a model file") from None
    return b"".join(chunks)


def check_document(document, where, *, verify_checksum=True):
    """Check a parsed model file completely (format, version, checksum, fields, parameters).

    Parameters
    ----------
    document : object
        The parsed JSON.
    where : str
        Name of the file, used in messages.
    verify_checksum : bool, default=True
        Whether to require the ``sha256`` field and compare it with the content.

    Raises
    ------
    ModelFileError
        Naming ``where``, the field and what was expected.
    """
    if not isinstance(document, dict):
        raise ModelFileError(f"{where}: expected a JSON object (an encal model file), "
                             f"got a JSON {_json_type(document)}")
    if document.get("format") != FORMAT:
        got = ("no 'format' field" if "format" not in document
               else f"format {_describe(document['format'])}")
        raise ModelFileError(f"{where}: expected an encal model file (format {FORMAT!r}), "
                             f"got {got}")
    version = document.get("version")
    if not _is_int(version) or version < 1:
        raise ModelFileError(f"{where}: expected a format version number (an integer >= 1), "
                             f"got {_describe(version)}")
    if version > VERSION:
        raise ModelFileError(f"{where}: the file has format version {version}, newer than "
                             f"version {VERSION} that this encal reads; upgrade encal (or the copy of its "
                             "runtime.py) to read it")
    if verify_checksum:
        _check_checksum(document, where)
    _check_reading_sign(document, version, where)
    _check_range(document, version, where)
    missing = [name for name in FIELDS if name not in document and name != "sha256"]
    if missing:
        raise ModelFileError(f"{where}: expected the fields {', '.join(FIELDS)}, "
                             f"but {_listed(missing)} missing")
    form = _check_form(document, FORMS, where, "", version)
    _check_header(document, where)
    check_parameters(form, document["parameters"], where, version=version)
    check_uncertainty(document.get("uncertainty"), where)
    expected = normalisation_of(form, document["parameters"])
    if document["normalisation"] != expected:
        raise ModelFileError(f"{where}: expected 'normalisation' to repeat the scaling held in "
                             f"'parameters' ({_describe(expected)}), got "
                             f"{_describe(document['normalisation'])}")


def _check_reading_sign(document, version, where):
    # Version 1 has no reading_sign: a version-1 reader would ignore one and apply the model to
    # un-negated readings, so a file that needs it must say version 2, which such readers refuse.
    if version < 2:
        if "reading_sign" in document:
            raise ModelFileError(f"{where}: format version {version} has no 'reading_sign' field, got one; "
                                 "expected version 2 for a file that records it")
        return
    sign = document.get("reading_sign")
    if not (_is_int(sign) and sign in READING_SIGNS):
        raise ModelFileError(f"{where}: expected 'reading_sign' to be 1 or -1 (format version {version}), "
                             f"got {'nothing' if 'reading_sign' not in document else _describe(sign)}")


def _check_range(document, version, where):
    if "range_deg" not in document:
        return
    if version < 4:
        raise ModelFileError(f"{where}: format version {version} has no 'range_deg' field, got one; "
                             "expected version 4 for a file that records it")
    value = document["range_deg"]
    if value is None:
        return
    if (not isinstance(value, list) or len(value) != 2 or not all(_is_number(v) for v in value)
            or not all(0.0 <= v < 360.0 for v in value) or value[0] == value[1]):
        shown = json.dumps(value) if isinstance(value, list) and len(json.dumps(value)) <= 60 else _describe(value)
        raise ModelFileError(f"{where}: expected 'range_deg' to be null or [start, end], two different numbers "
                             f"of degrees in [0, 360), got {shown}")


def range_of(document):
    """The calibrated range ``[start, end]`` (degrees, forward from start to end) of a checked model file, or None
    for a full turn (version 4; absent in older files)."""
    value = document.get("range_deg")
    return None if value is None else [float(value[0]), float(value[1])]


def in_range(theta_deg, range_deg):
    """Whether the model-input angle ``theta_deg`` lies in ``range_deg`` (always for None)."""
    if range_deg is None:
        return True
    span = (range_deg[1] - range_deg[0]) % 360.0
    offset = (theta_deg - range_deg[0]) % 360.0
    return offset <= span + 1e-9 or offset >= 360.0 - 1e-9


def reading_sign_of(document):
    """The ``reading_sign`` of a checked model file: 1 (absent, version 1) or -1."""
    return document.get("reading_sign", 1)


def version_for(reading_sign, form_named=False, has_range=False):
    """The format version a writer uses: the oldest that holds ``reading_sign`` and, when ``form_named``, a
    ``form`` field (a kind the format does not name, in the file or in one of its members or parts), and when
    ``has_range``, a ``range_deg`` (version 4)."""
    if has_range:
        return 4
    if form_named:
        return 3
    return 1 if reading_sign == 1 else 2


def names_a_form(entry):
    """Whether a model (a dict with ``kind``, ``parameters`` and perhaps ``form``) names a form anywhere: in
    itself, a stack's member or a directional model's part, nested ones included (format version 3)."""
    entries = [entry]
    while entries:
        entry = entries.pop()
        if "form" in entry:
            return True
        form, parameters = form_of(entry), entry["parameters"]
        if form == "stack":
            entries.extend(parameters["members"])
        elif form == "directional":
            entries.extend(parameters[part] for part in ("forward", "reverse"))
    return False


def form_of(entry):
    """The form of a checked model file, stack member or directional part: its ``form``, else its kind's.

    Examples
    --------
    >>> form_of({"kind": "spectral"}), form_of({"kind": "my-sine", "form": "fourier"})
    ('fourier', 'fourier')
    """
    return entry.get("form") or KIND_FORMS[entry["kind"]]


def _check_form(entry, forms, where, prefix, version):
    """The form of ``entry`` (a file, a stack member or a directional part), after checking its kind and form.

    A kind the format names has its own form and no ``form`` field; any other kind is a non-empty string with
    a ``form`` among ``forms`` (format version 3). ``prefix`` names the entry's fields (``''`` for the file).
    """
    kind, form = entry.get("kind"), entry.get("form")
    kinds = [name for name in KINDS if KIND_FORMS[name] in forms]
    if isinstance(kind, str) and kind in KIND_FORMS:
        if "form" in entry:
            raise ModelFileError(f"{where}: expected no {prefix}form for the kind {kind!r}, stored in its own "
                                 f"form ({KIND_FORMS[kind]}), got {_describe(form)}")
        if KIND_FORMS[kind] not in forms:
            raise ModelFileError(f"{where}: expected {prefix}kind to be one of {', '.join(kinds)}, got "
                                 f"{_describe(kind)} (or another kind with a {prefix}form among "
                                 f"{', '.join(forms)})")
        return KIND_FORMS[kind]
    if not (isinstance(kind, str) and kind) or version < 3:
        raise ModelFileError(f"{where}: expected {prefix}kind to be one of {', '.join(kinds)}, got "
                             f"{_describe(kind)} (or, from format version 3, another kind's name with a "
                             f"{prefix}form among {', '.join(forms)})")
    if not (isinstance(form, str) and form in forms):
        raise ModelFileError(f"{where}: expected {prefix}form, the form the kind {kind!r} is stored in, to be one "
                             f"of {', '.join(forms)}, got {'nothing' if 'form' not in entry else _describe(form)}")
    return form


def model_input_deg(theta_deg, reading_sign=1):
    """The angle at which a model is evaluated for the encoder reading ``theta_deg`` (degrees).

    ``(reading_sign * theta_deg) mod 360``, in [0, 360): the reading itself, or its negative for an
    encoder that counts against its reference.
    """
    return _wrap360(reading_sign * theta_deg)


def _check_checksum(document, where):
    checksum = document.get("sha256")
    if not isinstance(checksum, str):
        raise ModelFileError(f"{where}: expected a 'sha256' checksum field, "
                             f"got {_describe(checksum)}")
    try:
        actual = content_sha256(document)
    except ValueError:  # NaN or Infinity were read from the file
        raise ModelFileError(f"{where}: expected finite numbers only, got NaN or Infinity "
                             "somewhere in the file") from None
    if actual != checksum:
        raise ModelFileError(f"{where}: the sha256 checksum does not match the content "
                             f"(stored {checksum[:12]}..., computed {actual[:12]}...), "
                             "so the file was altered after it was written")


def _check_header(document, where):
    if document["units"] != UNITS:
        raise ModelFileError(f"{where}: expected units {json.dumps(UNITS)}, "
                             f"got {_describe(document['units'])}")
    encoder = document["encoder"]
    if not isinstance(encoder, dict) or not isinstance(encoder.get("name"), str):
        raise ModelFileError(f"{where}: expected 'encoder' to be an object with a string 'name', "
                             f"got {_describe(encoder)}")
    bits = encoder.get("resolution_bits", "missing")
    if bits is not None and not (_is_int(bits) and 1 <= bits <= 32):
        raise ModelFileError(f"{where}: expected encoder.resolution_bits to be an integer "
                             f"from 1 to 32 or null, got {_describe(bits)}")
    training = document["training"]
    if not isinstance(training, dict):
        raise ModelFileError(f"{where}: expected 'training' to be an object, "
                             f"got {_describe(training)}")
    missing = [name for name in TRAINING_FIELDS if name not in training]
    if missing:
        raise ModelFileError(f"{where}: expected the training fields {', '.join(TRAINING_FIELDS)}, "
                             f"but {_listed(missing)} missing")


def check_parameters(form, parameters, where, field="parameters", *, version=VERSION):
    """Check the parameters of a model stored in ``form`` (or of a kind the format names: its form) against
    the format (shapes, finite numbers); ``version`` is the file's format version.

    Raises
    ------
    ModelFileError
        Naming ``where`` and the offending field.
    """
    _require_object(parameters, where, field)
    check = {"fourier": _check_fourier, "lut": _check_lut, "ann": _check_ann, "hybrid": _check_hybrid,
             "stack": _check_stack, "directional": _check_directional}[KIND_FORMS.get(form, form)]
    check(parameters, where, field, version)


def check_uncertainty(uncertainty, where, field="uncertainty"):
    """Check the optional uncertainty data of a model (``None`` when it has none).

    It holds ``method``, ``grid_step_deg`` (dividing 360), ``model_std_arcmin``
    (one value >= 0 per grid angle) and ``noise_std_arcmin`` (>= 0); see
    encal's ``encal.models.uncertainty``.
    """
    if uncertainty is None:
        return
    _require_object(uncertainty, where, field)
    missing = [name for name in _UNCERTAINTY_FIELDS if name not in uncertainty]
    if missing:
        raise ModelFileError(f"{where}: expected {field} to hold {', '.join(_UNCERTAINTY_FIELDS)}, "
                             f"but {_listed(missing)} missing")
    step = uncertainty["grid_step_deg"]
    size = round(360.0 / step) if _is_number(step) and step >= 360.0 / MAX_UNCERTAINTY_GRID else 0
    if size < 1 or abs(size * step - 360.0) >= 1e-9:
        raise ModelFileError(f"{where}: expected {field}.grid_step_deg to divide 360 degrees into at most "
                             f"{MAX_UNCERTAINTY_GRID} steps, got {_describe(step)}")
    table = uncertainty["model_std_arcmin"]
    _require_numbers(table, size, where, f"{field}.model_std_arcmin")
    noise = uncertainty["noise_std_arcmin"]
    _require_number(noise, where, f"{field}.noise_std_arcmin")
    if noise < 0 or min(table) < 0:
        raise ModelFileError(f"{where}: expected standard uncertainties >= 0 in {field}, "
                             "got a negative one")


def _check_fourier(p, where, field, version):
    orders = p.get("orders")
    if not (isinstance(orders, list) and orders
            and all(_is_int(k) and 0 <= k <= MAX_FOURIER_ORDER for k in orders)
            and len(set(orders)) == len(orders)):
        raise ModelFileError(f"{where}: expected {field}.orders to be a non-empty list of distinct "
                             f"integers from 0 to {MAX_FOURIER_ORDER}, got {_describe(orders)}")
    for name in ("cos", "sin"):
        _require_numbers(p.get(name), len(orders), where, f"{field}.{name}")


def _check_lut(p, where, field, version):
    degree = _lookup({"linear": 1, "cubic": 3}, p.get("interpolation"))
    if degree is None:
        raise ModelFileError(f"{where}: expected {field}.interpolation to be 'linear' or 'cubic', "
                             f"got {_describe(p.get('interpolation'))}")
    breaks = p.get("breaks_deg")
    if not isinstance(breaks, list) or len(breaks) < 2:
        raise ModelFileError(f"{where}: expected {field}.breaks_deg to be a list of at least 2 "
                             f"numbers of degrees, got {_describe(breaks)}")
    _require_numbers(breaks, len(breaks), where, f"{field}.breaks_deg")
    if any(b <= a for a, b in zip(breaks, breaks[1:])):
        raise ModelFileError(f"{where}: expected {field}.breaks_deg to be strictly increasing, "
                             "but it is not")
    if abs(breaks[-1] - breaks[0] - 360.0) > 1e-9:
        raise ModelFileError(f"{where}: expected {field}.breaks_deg to span one turn "
                             f"(last = first + 360), got {breaks[0]!r} to {breaks[-1]!r}")
    _require_matrix(p.get("coefficients"), degree + 1, len(breaks) - 1, where,
                    f"{field}.coefficients")


def _check_ann(p, where, field, version):
    n_inputs = _lookup({"raw": 1, "periodic": 2}, p.get("encoding"))
    if n_inputs is None:
        raise ModelFileError(f"{where}: expected {field}.encoding to be 'raw' or 'periodic', "
                             f"got {_describe(p.get('encoding'))}")
    if p.get("activation") not in ("tansig", "logsig"):
        raise ModelFileError(f"{where}: expected {field}.activation to be 'tansig' or 'logsig', "
                             f"got {_describe(p.get('activation'))}")
    for name in ("input_offset", "input_gain"):
        _require_numbers(p.get(name), n_inputs, where, f"{field}.{name}")
    for name in ("target_offset", "target_gain", "b2"):
        _require_number(p.get(name), where, f"{field}.{name}")
    for name, gains in (("input_gain", p["input_gain"]), ("target_gain", [p["target_gain"]])):
        # mapminmax gains are 2 / (max - min) of real data: a gain near 0 turns every prediction into
        # an overflow, and then NaN (a re-signed file with target_gain 1e-300 did).
        if any(abs(gain) < 1.0 / MAX_PARAMETER_MAGNITUDE for gain in gains):
            raise ModelFileError(f"{where}: expected {field}.{name} to be a number with 1e-100 <= |x| <= 1e100, "
                                 f"got {_describe(gains[0] if len(gains) == 1 else gains)}")
    b1 = p.get("b1")
    if not isinstance(b1, list) or not b1:
        raise ModelFileError(f"{where}: expected {field}.b1 to be a non-empty list of numbers "
                             f"(one per hidden node), got {_describe(b1)}")
    hidden = len(b1)
    _require_numbers(b1, hidden, where, f"{field}.b1")
    _require_numbers(p.get("W2"), hidden, where, f"{field}.W2")
    _require_matrix(p.get("W1"), hidden, n_inputs, where, f"{field}.W1")


def _check_hybrid(p, where, field, version):
    for part, check in (("fourier", _check_fourier), ("ann", _check_ann)):
        check(_require_object(p.get(part), where, f"{field}.{part}"), where, f"{field}.{part}", version)


def _check_stack(p, where, field, version):
    members, weights = p.get("members"), p.get("weights")
    if not isinstance(members, list) or not members:
        raise ModelFileError(f"{where}: expected {field}.members to be a non-empty list of "
                             f"{{kind, parameters}} objects, got {_describe(members)}")
    for i, member in enumerate(members):
        name = f"{field}.members[{i}]"
        _require_object(member, where, name)
        form = _check_form(member, MEMBER_FORMS, where, f"{name}.", version)
        check_parameters(form, member.get("parameters"), where, f"{name}.parameters", version=version)
    _require_numbers(weights, len(members), where, f"{field}.weights")
    if min(weights) <= 0:
        raise ModelFileError(f"{where}: expected every one of {field}.weights to be > 0, "
                             f"got {min(weights)!r} among them")
    total = math.fsum(weights)
    if abs(total - 1.0) > WEIGHT_SUM_TOLERANCE:
        raise ModelFileError(f"{where}: expected {field}.weights to sum to 1 (within "
                             f"{WEIGHT_SUM_TOLERANCE:g}), got a sum of {total!r}")


def _check_directional(p, where, field, version):
    for part in ("forward", "reverse"):
        name = f"{field}.{part}"
        data = _require_object(p.get(part), where, name)
        form = _check_form(data, PART_FORMS, where, f"{name}.", version)
        check_parameters(form, data.get("parameters"), where, f"{name}.parameters", version=version)
        check_uncertainty(data.get("uncertainty"), where, f"{name}.uncertainty")


def normalisation_of(form, parameters):
    """The ``normalisation`` field for a model stored in ``form`` (or of a kind the format names): its networks'
    mapminmax settings, else ``{}``.

    ``ann`` and ``hybrid``: the network's four settings; ``directional``:
    ``{"forward": ..., "reverse": ...}`` with each part's normalisation; ``stack``:
    ``{"members": [...]}`` with each member's normalisation.
    """
    form = KIND_FORMS.get(form, form)
    if form == "directional":
        return {part: normalisation_of(form_of(parameters[part]), parameters[part]["parameters"])
                for part in ("forward", "reverse")}
    if form == "stack":
        return {"members": [normalisation_of(form_of(member), member["parameters"])
                            for member in parameters["members"]]}
    network = {"ann": parameters, "hybrid": parameters.get("ann")}.get(form)
    if network is None:
        return {}
    return {name: network[name] for name in _SCALING_FIELDS}


def _listed(names):
    return f"{', '.join(names)} {'is' if len(names) == 1 else 'are'}"


def _lookup(choices, value):
    """``choices[value]`` for a string key, else None (a JSON list or object as key is unhashable)."""
    return choices.get(value) if isinstance(value, str) else None


def _is_int(value):
    return isinstance(value, int) and not isinstance(value, bool)


#: Most angles of an uncertainty grid (a step of 0.08 arc-seconds): a re-signed step of 1e-300 degrees
#: would otherwise ask for a table of 3.6e302 values.
MAX_UNCERTAINTY_GRID = 1 << 24

#: Largest Fourier order: the highest a C ``int`` holds on every platform (C99 guarantees 16 bits), and
#: beyond the Nyquist order of any calibration of fewer than 65,536 points.
MAX_FOURIER_ORDER = 32767

#: Largest magnitude a parameter may have. Real models stay many orders below it; a file beyond it (made
#: by hand and re-signed) could overflow to inf or NaN in double precision, a wrong number that looks like
#: an answer, so it is refused as 'not a finite number' at load time.
MAX_PARAMETER_MAGNITUDE = 1e100


def _is_number(value):
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return False
    if isinstance(value, int):  # compared as an int: 10**400 is no float (math.isfinite would overflow)
        return -MAX_PARAMETER_MAGNITUDE <= value <= MAX_PARAMETER_MAGNITUDE
    return math.isfinite(value) and abs(value) <= MAX_PARAMETER_MAGNITUDE


def _require_object(value, where, field):
    if not isinstance(value, dict):
        raise ModelFileError(f"{where}: expected {field} to be a JSON object, "
                             f"got {_describe(value)}")
    return value


def _require_number(value, where, field):
    if not _is_number(value):
        raise ModelFileError(f"{where}: expected {field} to be a finite number (|x| <= 1e100), "
                             f"got {_describe(value)}")


def _require_numbers(value, n, where, field):
    if not (isinstance(value, list) and len(value) == n and all(map(_is_number, value))):
        raise ModelFileError(f"{where}: expected {field} to be a list of {n} finite numbers (|x| <= 1e100), "
                             f"got {_describe(value)}")


def _require_matrix(value, rows, columns, where, field):
    if not (isinstance(value, list) and len(value) == rows
            and all(isinstance(row, list) and len(row) == columns and all(map(_is_number, row))
                    for row in value)):
        raise ModelFileError(f"{where}: expected {field} to be {rows} rows of {columns} finite "
                             f"numbers, got {_describe(value)}")


def _json_type(value):
    names = {dict: "object", list: "array", str: "string", bool: "boolean", type(None): "null"}
    return names.get(type(value), "number")


def _describe(value):
    """Short description of a JSON value for a message."""
    if isinstance(value, list):
        if value and all(isinstance(row, list) for row in value):
            lengths = sorted({len(row) for row in value})
            return f"{len(value)} rows of {'/'.join(map(str, lengths))} values"
        bad = [v for v in value if not _is_number(v)]
        detail = f" including {_describe(bad[0])}" if bad else ""  # short: a row of 180 numbers was quoted whole
        return f"a list of {len(value)} values{detail}"
    text = json.dumps(value)
    return text if len(text) <= 60 else text[:57] + "..."


# -- evaluation -------------------------------------------------------------------------

def _wrap360(angle_deg):
    wrapped = angle_deg % 360.0
    return 0.0 if wrapped >= 360.0 else wrapped  # -1e-17 % 360 rounds to 360.0


def _fourier(p):
    terms = list(zip(p["orders"], p["cos"], p["sin"]))

    def predict(theta_deg):
        theta = math.radians(theta_deg)
        return math.fsum(a * math.cos(k * theta) + b * math.sin(k * theta) for k, a, b in terms)

    return predict


def _lut(p):
    breaks = p["breaks_deg"]
    columns = list(zip(*p["coefficients"]))  # one tuple of coefficients per interval
    start, last = breaks[0], len(breaks) - 2

    def predict(theta_deg):
        x = theta_deg - 360.0 * math.floor((theta_deg - start) / 360.0)  # into [x_0, x_0 + 360)
        i = min(max(bisect.bisect_right(breaks, x) - 1, 0), last)
        dx = x - breaks[i]
        value = 0.0
        for c in columns[i]:
            value = value * dx + c
        return value

    return predict


def _logsig(z):
    if z >= 0.0:
        return 1.0 / (1.0 + math.exp(-z))
    e = math.exp(z)  # the other form would overflow for very negative z
    return e / (1.0 + e)


def _ann(p):
    periodic = p["encoding"] == "periodic"
    offsets, gains = p["input_offset"], p["input_gain"]
    nodes = list(zip(p["W1"], p["b1"], p["W2"]))
    activation = math.tanh if p["activation"] == "tansig" else _logsig
    b2, target_offset, target_gain = p["b2"], p["target_offset"], p["target_gain"]

    def predict(theta_deg):
        if periodic:
            theta = math.radians(theta_deg)
            inputs = (math.cos(theta), math.sin(theta))
        else:
            inputs = (theta_deg,)
        x = [g * (u - o) - 1.0 for u, o, g in zip(inputs, offsets, gains)]
        y = b2
        for row, b, w in nodes:
            z = b
            for weight, xi in zip(row, x):
                z += weight * xi
            y += w * activation(z)
        return (y + 1.0) / target_gain + target_offset

    return predict


def _hybrid(p):
    fourier, ann = _fourier(p["fourier"]), _ann(p["ann"])
    return lambda theta_deg: fourier(theta_deg) + ann(theta_deg)


def _stack(p):
    terms = [(weight, _EVALUATORS[form_of(member)](member["parameters"]))
             for member, weight in zip(p["members"], p["weights"])]

    def predict(theta_deg):
        total = 0.0
        for weight, member in terms:  # in order, as encal adds them
            total += weight * member(theta_deg)
        return total

    return predict


def _directional(p):
    forward = _EVALUATORS[form_of(p["forward"])](p["forward"]["parameters"])
    reverse = _EVALUATORS[form_of(p["reverse"])](p["reverse"]["parameters"])

    def predict(theta_deg, direction=None):
        if direction is None:
            return 0.5 * (forward(theta_deg) + reverse(theta_deg))
        return forward(theta_deg) if direction > 0 else reverse(theta_deg)

    return predict


#: form -> evaluator
_EVALUATORS = {"fourier": _fourier, "lut": _lut, "ann": _ann, "hybrid": _hybrid, "stack": _stack,
               "directional": _directional}


class RuntimeModel:
    """An error model read from a model file, evaluated one angle at a time.

    Parameters
    ----------
    document : dict
        A checked model file (see :func:`read_document`).

    Attributes
    ----------
    kind : str
    form : str
        How its parameters are stored (one of :data:`FORMS`).
    encoder : dict
        ``{'name': str, 'resolution_bits': int or None}``.
    sha256 : str
        Checksum of the file's content: identifies the model.
    reading_sign : {1, -1}
        -1 when the encoder counts against its reference: readings are negated before the model sees
        them, and corrected angles are in the reference's sense.
    """

    def __init__(self, document):
        self.kind = document["kind"]
        self.form = form_of(document)
        self.encoder = document["encoder"]
        self.sha256 = document["sha256"]
        self.directional = self.form == "directional"
        self.reading_sign = reading_sign_of(document)
        self.range_deg = range_of(document)
        self._predict = _EVALUATORS[self.form](document["parameters"])

    def predict_arcmin(self, theta_deg, direction=None):
        """Predicted error ``encoder - reference`` in arc-minutes at encoder angle ``theta_deg``.

        ``direction`` (+1 turning forward, -1 turning back) selects a part of a
        ``directional`` model; ``None`` (unknown) gives the mean of both parts.
        Other kinds have one profile: they check it (as encal does) and ignore it. NaN for a reading outside the
        model's ``range_deg`` (a model calibrated over an arc, format version 4): it is never given a number there.

        Raises
        ------
        ValueError
            If ``theta_deg`` is not a finite number, or ``direction`` is not +1, -1 or None.
        """
        theta = model_input_deg(_finite(theta_deg), self.reading_sign)
        direction = _direction(direction)
        if not in_range(theta, self.range_deg):
            return math.nan  # calibrated over an arc that does not hold this reading
        return self._error_at(theta, direction)

    def _error_at(self, theta_in, direction):
        """The model's error (arc-minutes) at the model-input angle ``theta_in`` (degrees in [0, 360))."""
        if self.directional:
            return float(self._predict(theta_in, direction))
        return float(self._predict(theta_in))

    def correct_deg(self, theta_deg, direction=None, *, outside="nan"):
        """Corrected angle in degrees, in [0, 360), of the encoder reading ``theta_deg`` (degrees).

        ``direction`` is as for :meth:`predict_arcmin`. ``outside`` is what a model calibrated over an arc
        (``range_deg``) does with a reading outside it, the rules of ``encal correct --outside``: ``'nan'``
        (default) answers NaN; ``'error'`` raises ValueError naming the reading and the range; ``'clamp'``
        subtracts the error at the nearer end of the arc (the end after which the reading lies when it is
        as far from both), in the reading's direction for a directional model; ``'pass'`` leaves the reading
        uncorrected (``model_input_deg`` of it). A full-turn model has no outside and ignores it.
        """
        # The model input is wrapped first: for a multi-turn reading of 1e15 degrees the correction would be lost
        # to rounding.
        theta = model_input_deg(_finite(theta_deg), self.reading_sign)
        direction = _direction(direction)
        if outside not in OUTSIDE_RULES:
            raise ValueError(f"expected outside to be one of {', '.join(map(repr, OUTSIDE_RULES))}, got {outside!r}")
        if not in_range(theta, self.range_deg):
            if outside == "nan":
                return math.nan
            if outside == "pass":
                return theta
            if outside == "error":
                start, end = self.range_deg
                raise ValueError(f"the reading {theta_deg!r} deg is outside the calibrated range {start!r} to {end!r} "
                                 "deg; expected a reading inside it (outside='clamp' uses the correction of the "
                                 "nearer end, outside='pass' leaves it uncorrected)")
            return _wrap360(theta - self._error_at(nearer_end(theta, self.range_deg), direction) / 60.0)
        return _wrap360(theta - self._error_at(theta, direction) / 60.0)

    def __repr__(self):
        return f"<RuntimeModel kind={self.kind!r} for {self.encoder.get('name')!r}>"


#: What :meth:`RuntimeModel.correct_deg` does with a reading outside an arc model's range (``encal correct
#: --outside``'s rules, and NaN, the default of encal's Python API).
OUTSIDE_RULES = ("nan", "error", "clamp", "pass")


def nearer_end(theta_deg, range_deg):
    """The end of ``range_deg`` nearer to ``theta_deg`` round the circle (degrees in [0, 360)): the end when
    the angle is as far past it as before the start (encal's ``clamp_to_range``)."""
    start, end = range_deg
    return end if (theta_deg - end) % 360.0 <= (start - theta_deg) % 360.0 else start


def _finite(theta_deg):
    try:
        theta = float(theta_deg)
    except (TypeError, ValueError, OverflowError):  # None, 'ten', 10**400 (encal refuses them all)
        theta = math.nan
    if not math.isfinite(theta):
        raise ValueError(f"expected a finite encoder angle in degrees, got {_shown(theta_deg)}")
    return theta


def _shown(value):
    try:
        text = repr(value)
    except ValueError:  # an int of more digits than Python writes
        text = f"an {type(value).__name__} too long to write"
    return text if len(text) <= 60 else text[:57] + "..."


def _direction(direction):
    """``direction`` as +1, -1 or None, refusing what encal refuses (a bool, a string, 0, 2, ...)."""
    if direction is None:
        return None
    if not (isinstance(direction, (str, bytes)) or type(direction).__name__.startswith("bool")):  # NumPy's too
        try:
            value = float(direction)
        except (TypeError, ValueError, OverflowError):
            value = None
        if value in (1.0, -1.0):
            return 1 if value > 0 else -1
    raise ValueError(f"expected a direction of +1, -1 or None, got {_shown(direction)}")


def load(path):
    """Load a model file for per-angle correction.

    Parameters
    ----------
    path : str or os.PathLike
        An encal model file (JSON).

    Returns
    -------
    RuntimeModel
        With ``predict_arcmin(theta_deg)`` and ``correct_deg(theta_deg)``.

    Raises
    ------
    ModelFileError
        If the file is not a valid, unaltered model file of a version this reader knows.
    """
    return RuntimeModel(read_document(path))
