"""Issue 25: `encal export` and `encal fit` options and model values that gave wrong numbers or tracebacks.

- an option of one format given with another was silently ignored (`--format klipper --bits 12`);
- `--bits 1` for a compact table was an AttributeError;
- a re-signed model file with a coefficient of 1e100 wrote `#define SCALE_LSB inff` (not C) or a traceback;
- an encoder name holding `/*` broke the C build;
- `encal fit --noise 1e300` / `1e-300` were an OverflowError / a math domain error;
- `--format c --table` and `--format tinymovr` without a resolution were status 1 saying `bits=`.
"""

import json
import shutil
import subprocess

import numpy as np
import pytest

from encal import runtime
from encal.cli import main
from encal.cli.cmd_export import _APPLIES_TO, _DEFAULTS, add_arguments
from encal.deploy import compile_table, export_c
from encal.deploy.compact import MAX_EXPORT_ERROR_ARCMIN, choose_compact, compile_compact
from encal.deploy.targets import export_target
from encal._core.errors import InputError
from encal.models.fourier import FourierModel
from encal.models.spectral import MAX_NOISE_ARCMIN, fit_spectral, noise_resolution_arcmin

GCC = shutil.which("gcc")
CFLAGS = ["-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", "-trigraphs", "-c", "-o", "/dev/null"]
needs_gcc = pytest.mark.skipif(GCC is None, reason="gcc is not installed")
GRID = np.arange(0.0, 360.0, 2.0)
FORMATS = ("c", "table", "moteus", "simplefoc", "klipper", "mechaduino", "tinymovr")


def _model(cos=(0.3, 2.0), bits=14, name="enc"):
    return FourierModel([0, 1], list(cos), [0.0, 0.5], encoder={"name": name, "resolution_bits": bits})


def _resigned(path, change):
    """The model file at ``path`` edited by ``change`` and re-signed: it loads as an intact file."""
    document = json.loads(path.read_text(encoding="utf-8"))
    change(document)
    document.pop("sha256")
    document["sha256"] = runtime.content_sha256(document)
    path.write_text(json.dumps(document), encoding="utf-8")
    return path


@pytest.fixture
def model_file(tmp_path):
    return _model().save(tmp_path / "model.json", reproducible=True)


def _run(argv, capsys):
    """(exit status, stderr) of one command line; a usage error exits through argparse."""
    try:
        status = main([str(part) for part in argv])
    except SystemExit as exc:
        status = exc.code
    return status, capsys.readouterr().err


# --------------------------------------------------------------------------- 1. options of other formats

#: a value each option takes, for the command lines below
_VALUES = {"bits": "14", "dtype": "int16", "target": "host", "form": "table", "nodes": "64", "interpolation": "linear",
           "tolerance": "0.1", "cost": "bytes", "name": "enc", "table": None, "constants": "auto", "source": "1",
           "full_steps": "200", "sign": "-1", "offset": "1000", "conf": "dump.txt", "moteus_style": "console",
           "firmware_version": "1.0.8", "step_zero": "0", "step_direction": "-1"}


@pytest.mark.parametrize("option, fmt", [(option, fmt) for option, formats in _APPLIES_TO.items()
                                         for fmt in FORMATS if fmt not in formats])
def test_an_option_of_other_formats_is_a_usage_error(option, fmt, model_file, tmp_path, capsys):
    """Every option given with a format it does not apply to: status 2 naming it and its formats, nothing written."""
    flag = "--" + option.replace("_", "-")
    value = [] if _VALUES[option] is None else [_VALUES[option]]
    status, err = _run(["export", model_file, "--format", fmt, "-o", tmp_path / "out", flag, *value], capsys)
    assert status == 2, err
    formats = _APPLIES_TO[option]
    assert f"{flag} applies to --format {formats[0]}" in err and f"not {fmt}" in err, err
    assert formats[-1] in err.splitlines()[-1]
    assert not (tmp_path / "out").exists()


def test_an_option_of_another_format_names_the_formats_that_take_it(model_file, tmp_path, capsys):
    status, err = _run(["export", model_file, "--format", "moteus", "--step-zero", "0", "-o", tmp_path / "k"], capsys)
    assert status == 2
    assert err.splitlines()[-1].endswith("--step-zero applies to --format klipper or mechaduino, not moteus")


def test_every_format_specific_option_defaults_to_none():
    """The table can tell "given" only for an option whose argparse default is None; its default is in _DEFAULTS."""
    import argparse

    parser = argparse.ArgumentParser()
    add_arguments(parser)
    defaults = {action.dest: action.default for action in parser._actions}
    for option in _APPLIES_TO:
        assert defaults[option] is None, option
    assert set(_DEFAULTS) <= set(_APPLIES_TO)


def test_documented_defaults_still_apply(model_file, tmp_path, capsys):
    """Without the options, --source 0 (moteus) and --name encal (C) are what is written."""
    assert _run(["export", model_file, "--format", "moteus", "-o", tmp_path / "m.cfg"], capsys)[0] == 0
    assert "motor_position.sources.0.compensation_table.0 " in (tmp_path / "m.cfg").read_text()
    assert _run(["export", model_file, "--format", "c", "-o", tmp_path / "c"], capsys)[0] == 0
    assert sorted(p.name for p in (tmp_path / "c").iterdir()) == ["encal.c", "encal.h"]


@pytest.mark.parametrize("options, says", [
    (["--dtype", "float32"], "--dtype is the storage of a table"),
    (["--table", "--constants", "double"], "--constants is the storage of the host formula's constants"),
    (["--target", "cortex-m4f", "--form", "formula", "--nodes", "64"], "not --form formula"),
    (["--target", "cortex-m4f", "--form", "formula", "--dtype", "int8"], "not --form formula"),
    (["--target", "cortex-m4f", "--form", "formula", "--tolerance", "0.1"], "not --form formula"),
])
def test_c_options_the_chosen_c_ignores_are_usage_errors(options, says, model_file, tmp_path, capsys):
    """Before: written with exit 0, the option silently ignored (the host formula has no table to store...)."""
    status, err = _run(["export", model_file, "--format", "c", *options, "-o", tmp_path / "c"], capsys)
    assert status == 2 and says in err.splitlines()[-1], err
    assert not (tmp_path / "c").exists()


# --------------------------------------------------------------------------- 2. --bits 1 for a compact table

@pytest.mark.parametrize("target, high", [("cortex-m4f", 32), ("fixed", 24)])
def test_one_bit_for_a_compact_table_names_the_range(target, high, model_file, tmp_path, capsys):
    status, err = _run(["export", model_file, "--format", "c", "--target", target, "--bits", "1",
                        "-o", tmp_path / "c"], capsys)
    assert status == 1, err
    assert err.splitlines() == [f"encal export: error: --bits must be an int from 2 to {high} (the encoder resolution "
                                f"for the {target} target; a compact table has at least 4 nodes, one per code at most; "
                                "or None for the model file's). Got 1 instead."]
    assert not (tmp_path / "c").exists()


def test_one_bit_in_python():
    with pytest.raises(InputError, match="from 2 to 32"):
        choose_compact(_model(), bits=1)
    with pytest.raises(InputError, match="from 2 to 32"):
        compile_compact(_model(), 4, bits=1)
    files, summary = export_target(_model(), "cortex-m4f", form="formula", bits=1)  # the formula takes any code
    assert summary["form"] == "formula" and "#define CODE_MASK 0x1u" in files["encal.c"]


# --------------------------------------------------------------------------- 3. values beyond what can be written

@pytest.mark.parametrize("coefficient", [1e100, 1e30, -2.2e4])
@pytest.mark.parametrize("export", [
    lambda m: export_c(m), lambda m: export_c(m, table="int16"), lambda m: export_c(m, table="float32"),
    lambda m: compile_table(m, dtype="float32"), lambda m: export_target(m, "cortex-m4f"),
    lambda m: export_target(m, "cortex-m4f", form="formula"), lambda m: export_target(m, "fixed"),
    lambda m: export_target(m, "cortex-m4f", cost="bytes"),
], ids=["host", "host-int16-table", "host-float32-table", "dense-table", "cortex-m4f", "cortex-m4f-formula",
        "fixed", "cortex-m4f-cost"])
def test_errors_beyond_a_turn_are_refused_by_every_c_target(export, coefficient):
    """Before: 1e100 wrote `#define SCALE_LSB inff` (m4f) or a NaN traceback; 1e30 a table 'deployed' at 1e22."""
    with pytest.raises(InputError, match=r"the model predicts an error of -?[\d.e+]+ arcmin at 0 deg; expected errors "
                                         r"within one turn \(\|error\| <= 21600 arcmin\)"):
        export(_model(cos=(coefficient, 2.0)))


def test_errors_just_within_a_turn_are_exported():
    model = _model(cos=(MAX_EXPORT_ERROR_ARCMIN - 3.0, 2.0))  # at most 21599 arcmin
    for target in ("host", "cortex-m4f"):
        files, _ = export_target(model, target)
        assert "inf" not in files["encal.c"].replace("info", "")


@pytest.mark.parametrize("fmt, extra", [("c", ["--target", "cortex-m4f"]), ("c", ["--target", "fixed"]), ("c", []),
                                        ("c", ["--table"]), ("table", [])])
def test_a_resigned_huge_coefficient_writes_nothing(fmt, extra, model_file, tmp_path, capsys):
    huge = _resigned(model_file, lambda d: d["parameters"]["cos"].__setitem__(0, 1e100))
    output = tmp_path / "out"
    status, err = _run(["export", huge, "--format", fmt, *extra, "-o", output], capsys)
    assert status == 1, err
    assert len(err.splitlines()) == 1 and "model.json: the model predicts an error of 1e+100 arcmin" in err
    assert not output.exists()
    assert [p.name for p in tmp_path.iterdir()] == ["model.json"]


def test_fixed_target_refuses_a_mean_error_its_int32_offset_would_clip():
    """A mean error of 12000 arcmin was clipped to 10800 in OFFSET_BAM: every correction 1200 arcmin off, exit 0."""
    with pytest.raises(InputError, match="mean error, 12000 arcmin, is beyond the fixed target's int32"):
        export_target(_model(cos=(12000.0, 2.0)), "fixed")
    # a zero offset of 179.99 degrees (errors reaching 10801 arcmin) is no such case: its sums wrap modulo a turn
    files, summary = export_target(_model(cos=(10799.4, 2.0)), "fixed")
    assert summary["max_error_arcmin"] < 0.1


def test_float32_literals_are_never_inf():
    from encal.deploy.targets import _float

    with pytest.raises(InputError, match="float32"):
        _float(1e39)
    assert _float(3.0e38) == "3.00000001e+38f"


@pytest.mark.parametrize("deployment, says", [
    ({"target": "cortex-m4f", "form": "table", "nodes": 3, "dtype": "int16"}, "nodes a power of two from 4 to 16384"),
    ({"target": "cortex-m4f", "form": "table", "nodes": 10**400, "dtype": "int16"}, "got 1000000000000000000000000"),
    ({"target": "fixed", "form": "table", "nodes": 64, "dtype": "float32"}, "dtype 'int8' or 'int16'"),
    ({"target": "fixed", "form": "formula"}, "form 'table'"),
    ({"target": "cortex-m4f", "form": "table", "nodes": 64, "budget": "1KiB\x1b[2J"}, "budget the text"),
])
def test_a_resigned_recorded_deployment_names_the_file_and_field(deployment, says, model_file):
    """Before: 'The 'nodes' parameter of compile_compact must be ...', a parameter the user never gave."""
    edited = _resigned(model_file, lambda d: d["training"].__setitem__("deployment", deployment))
    with pytest.raises(InputError, match=r"model\.json: expected the training\.deployment recorded by 'encal fit "
                                         r"--budget' to hold") as info:
        export_target(edited, deployment["target"])
    assert says in str(info.value) and len(str(info.value)) < 400


# --------------------------------------------------------------------------- 4. names in C comments

HOSTILE = 'evil /* x */ "q" ??/\n#define y \\ \t\u00e9\u2028 */'


class _HostileKind(FourierModel):
    """A user's kind (format version 3) whose name is hostile C: it lands in the banner comment too."""

    kind = "my */ kind /* ??/"
    form = "fourier"


@needs_gcc
@pytest.mark.parametrize("options", [{}, {"table": "int16"}, {"target": "cortex-m4f"},
                                     {"target": "cortex-m4f", "form": "formula"}, {"target": "fixed"}],
                         ids=["host", "host-table", "cortex-m4f", "cortex-m4f-formula", "fixed"])
def test_hostile_names_compile(options, tmp_path, monkeypatch):
    """An encoder name and a kind with comment ends, trigraphs, quotes and newlines: gcc -Werror compiles the output."""
    from encal.models.kind import REGISTERED, ModelKind

    monkeypatch.setitem(REGISTERED, _HostileKind.kind, ModelKind(_HostileKind.kind, _HostileKind, None))
    model = _HostileKind([0, 1], [0.3, 2.0], [0.0, 0.5], encoder={"name": HOSTILE, "resolution_bits": 14})
    path = model.save(tmp_path / "hostile.json", reproducible=True)
    options = dict(options)
    files, _ = export_target(path, options.pop("target", "host"), **options)
    for name, text in files.items():
        (tmp_path / name).write_text(text, encoding="utf-8")
    banner = files["encal.c"].splitlines()[2]
    assert json.loads(banner[banner.index("kind ") + 5:banner.index(", encoder")]) == _HostileKind.kind
    assert json.loads(banner[banner.index("encoder ") + 8:banner.index(", sha256")]) == HOSTILE  # escaped, not lost
    compiled = subprocess.run([GCC, *CFLAGS, str(tmp_path / "encal.c")], capture_output=True, text=True)
    assert compiled.returncode == 0, compiled.stderr


# --------------------------------------------------------------------------- 5. fit --noise

@pytest.mark.parametrize("noise", [1e-300, 1e-13, 3.4e-12, 21600.5, 1e300, float("nan"), 0.0, -1.0, True])
def test_noise_outside_its_range_is_refused(noise):
    error = 2.0 * np.sin(np.radians(GRID))
    with pytest.raises(InputError, match=r"The 'noise_arcmin' parameter of fit_spectral must be a number of "
                                         r"arc-minutes from 3\.41e-12 .* to 21600 \(a turn\)"):
        fit_spectral(GRID, error, noise_arcmin=noise)


@pytest.mark.parametrize("amplitude", [1e-6, 1.0, 1e4])
@pytest.mark.parametrize("where", ["low", "high"])
def test_noise_at_its_bounds_fits(amplitude, where):
    """At both ends of the range the fit is finite; at the low end it passes through the points."""
    error = amplitude * (np.sin(np.radians(GRID)) + 0.1 * np.cos(np.radians(7 * GRID)))
    noise = noise_resolution_arcmin(error) if where == "low" else MAX_NOISE_ARCMIN
    model = fit_spectral(GRID, error, noise_arcmin=noise)
    assert np.all(np.isfinite(model.predict(GRID + 1.0)))
    if where == "low":
        assert np.max(np.abs(model.predict(GRID) - error)) <= 1e-10 * max(amplitude, 1.0)


def test_noise_resolution_follows_the_errors():
    assert noise_resolution_arcmin(np.array([1.0])) == pytest.approx(60 * np.spacing(360.0))
    assert noise_resolution_arcmin(np.array([1e6])) == np.spacing(1e6)


@pytest.fixture
def calibration(tmp_path):
    path = tmp_path / "cal.csv"
    rows = [f"{float(r)!r},{float(r + 2.0 * np.sin(np.radians(r)) / 60.0)!r}" for r in GRID]
    path.write_text("reference_deg,encoder_deg\n" + "\n".join(rows) + "\n", encoding="utf-8")
    return path


@pytest.mark.parametrize("method", ["spectral", "auto"])
@pytest.mark.parametrize("noise, status, says", [
    ("1e300", 2, "at most 21600 (a turn)"), ("inf", 2, "at most 21600"), ("nan", 2, "at most 21600"),
    ("0", 2, "> 0"), ("1e-300", 1, "--noise must be a number of arc-minutes from 3.41e-12"),
])
def test_noise_on_the_command_line(method, noise, status, says, calibration, tmp_path, capsys):
    output = tmp_path / "m.json"
    got, err = _run(["fit", calibration, "-o", output, "--method", method, f"--noise={noise}"], capsys)
    assert got == status, err
    assert "Traceback" not in err and says in err.splitlines()[-1]
    assert not output.exists()


# --------------------------------------------------------------------------- 6. a resolution the export needs

@pytest.mark.parametrize("fmt, extra, why", [
    ("c", ["--table"], "--format c --table looks up one entry per code"),
    ("tinymovr", [], "--format tinymovr works in ticks of the sensor (6 to 24 bits)"),
    ("table", [], "--format table has one entry per code"),
])
def test_no_resolution_is_a_usage_error_naming_bits(fmt, extra, why, tmp_path, capsys):
    path = _model(bits=None).save(tmp_path / "nobits.json", reproducible=True)
    status, err = _run(["export", path, "--format", fmt, *extra, "-o", tmp_path / "out"], capsys)
    assert status == 2, err
    assert err.splitlines()[-1] == (f"encal export: error: {why}, and {path} records no encoder resolution; "
                                    "pass --bits B")
    assert not (tmp_path / "out").exists()
