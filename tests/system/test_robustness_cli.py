"""The robustness catalogue: hostile and degenerate inputs to every ``encal`` command.

The contract (DESIGN.md): bad data or a failed operation exits with status 1 and one line on stderr,
``encal COMMAND: error: <what, where, what was expected>``, never a traceback; a usage mistake exits
with status 2 (argparse's usage message); odd but valid input is accepted; input that is usable but
probably a mistake (angles that look like radians) gets one ``encal COMMAND: warning: ...`` line.

How it runs. Each entry of :data:`CASES` is one command line. All of them run in ONE subprocess of
the installed package (:data:`_DRIVER` calls ``encal.cli.main`` once per case with its own stdin,
stdout and stderr, and turns an escaping exception into a traceback on that case's stderr, as the
interpreter would), so the catalogue covers hundreds of command lines in the time of a few process
starts. A handful of cases also run as real ``python -m encal`` processes
(:func:`test_real_process`), and :func:`test_every_command_is_catalogued` fails when a command appears
without bad-data and usage cases here.

The second half checks that nothing encal writes is ever half-written: a failed fit or write leaves
no model file, no temporary file, and an existing output file untouched.
"""

import json
import os
import re
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest

import encal
from encal.cli import build_parser, main
from encal import runtime

# --------------------------------------------------------------------------- the files

GRID_TRAIN = np.arange(0.0, 360.0, 2.0)
_SCATTERED = (GRID_TRAIN < 100) | ((GRID_TRAIN >= 150) & (GRID_TRAIN < 300))  # issue 31: two gaps
GRID_TEST = np.arange(1.0, 360.0, 2.0)


def _profile_arcmin(reference_deg):
    """A resolver-like error profile, arcmin: a few harmonics, a few arc-minutes."""
    theta = np.radians(reference_deg)
    return 2.0 * np.sin(theta + 0.3) + 0.6 * np.cos(2 * theta) + 0.2 * np.sin(16 * theta)


def _csv_text(reference, encoder, header="reference_deg,encoder_deg", separator=",", comments=()):
    lines = [f"# {c}" for c in comments] + [header.replace(",", separator)]
    lines += [f"{float(r)!r}{separator}{float(e)!r}" for r, e in zip(reference, encoder)]
    return "\n".join(lines) + "\n"


def _good_csv(grid=GRID_TRAIN, offset_deg=0.0):
    return _csv_text(grid, grid + offset_deg + _profile_arcmin(grid) / 60.0)


def _edit_cell(text, row, column, value):
    """``text`` (CSV with one header line) with data row ``row``, column ``column`` replaced by ``value``."""
    lines = text.splitlines()
    cells = lines[row + 1].split(",")
    cells[column] = value
    lines[row + 1] = ",".join(cells)
    return "\n".join(lines) + "\n"


def _resigned(document):
    """``document`` with a checksum that matches its (edited) content, as model-file text."""
    document = dict(document)
    document["sha256"] = runtime.content_sha256(document)
    return json.dumps(document, indent=1)


def _make_files(folder):
    """Write every input of the catalogue into ``folder``; return {placeholder: path}."""
    folder = Path(folder)
    good = _good_csv()
    train_lines = good.splitlines()
    encoder = GRID_TRAIN + _profile_arcmin(GRID_TRAIN) / 60.0
    texts = {
        "train": good,
        "test": _good_csv(GRID_TEST),
        "empty": "",
        "blank": "# only a comment\n\n   \n",
        "header_only": "reference_deg,encoder_deg\n",
        "numbers_first": "\n".join(train_lines[1:]) + "\n",
        "no_encoder_column": good.replace("encoder_deg", "reading", 1),
        "truncated": good[: len(good) // 2].rstrip("0123456789.\n").rstrip(","),  # the last row cut short
        "semicolon": good.replace(",", ";"),
        "tab": good.replace(",", "\t"),
        "decimal_comma": _csv_text(GRID_TRAIN, GRID_TRAIN, separator=";").replace(".", ","),
        "nan": _edit_cell(good, 5, 1, "nan"),
        "inf": _edit_cell(good, 5, 1, "-inf"),
        "text_cell": _edit_cell(good, 7, 0, "ten"),
        "empty_cell": _edit_cell(good, 7, 0, ""),
        "huge_angle": _edit_cell(good, 3, 0, "1e15"),
        "bad_bits": "# resolution_bits: 99\n" + good,
        "seven_points": _csv_text(GRID_TRAIN[::26][:7], GRID_TRAIN[::26][:7]),
        "duplicate": good + "10.0,10.5\n",
        # Three readings at every stop, one after another: a repeated-readings calibration, read without a flag.
        "repeated": _csv_text(np.repeat(GRID_TRAIN, 3), np.repeat(encoder, 3)
                              + np.random.default_rng(0).normal(0.0, 0.1, 3 * GRID_TRAIN.size) / 60.0),
        # The training pass with its zero moved by 79.2 degrees (a motor's repeat, docs/drift.md).
        "shifted": _good_csv(offset_deg=79.2),
        "radians": _csv_text(np.radians(GRID_TRAIN), np.radians(encoder)),
        "reversed": _csv_text(GRID_TRAIN, -encoder),
        # two gaps (100-150, 300-360): one contiguous arc is accepted since issue 31
        "gap": _csv_text(GRID_TRAIN[_SCATTERED], encoder[_SCATTERED]),
        "fold": _csv_text(GRID_TRAIN, GRID_TRAIN + 45.0 * np.sin(np.radians(2 * GRID_TRAIN))),  # folds back
        "arc": _csv_text(GRID_TRAIN[(GRID_TRAIN >= 10) & (GRID_TRAIN <= 130)],  # issue 31: one arc
                         encoder[(GRID_TRAIN >= 10) & (GRID_TRAIN <= 130)]),
        "fifteen_points": _csv_text(GRID_TRAIN[::12], encoder[::12]),
        "angles": "10\n20\nabc\n30\n",
        "angles_ok": "# encoder angles\n10\n20.5\n\n-3\n725\n",
        "afile": "not a folder\n",
        # issues 25/26 (fw-sfoc-tiny): firmware tables
        "sfoc_empty": "float calibrationLut[3] = {};\n",
        "sfoc_nan": "float calibrationLut[3] = {0.001,\n0.0,\nnan};\n",
        "sfoc_bare": "float calibrationLut[3] = {0.001, 0.0, -0.001};\n",
        "tiny_inf": "int32_t rec_table[64] = {1, inf};\n",
        # issue 26 (Klipper, Mechaduino imports): a non-finite angle in a calibrate list and in a lookup[]
        "klipper_nan": "[angle s]\ncalibrate:\n    " + ", ".join(["1.0"] * 7 + ["nan"]) + "\n",
        "mechaduino_inf": "const float lookup[16384] = {\n" + ", ".join(
            [f"{v:.3f}" for v in np.arange(16383) * 360 / 16384] + ["INFINITY"]) + "\n};\n",
    }
    paths = {}
    for key, text in texts.items():
        paths[key] = folder / f"{key}.csv"
        paths[key].write_text(text, encoding="utf-8", newline="")
    paths["binary"] = folder / "binary.csv"
    paths["binary"].write_bytes(bytes(range(256)) * 8)
    paths["utf16"] = folder / "utf16.csv"
    paths["utf16"].write_bytes(good.encode("utf-16"))
    paths["missing"] = folder / "missing.csv"

    cal = encal.read_calibration(paths["train"])
    model = encal.fit(cal, method="fourier")
    paths["model"] = model.save(folder / "model.json", reproducible=True)
    paths["arc_model"] = encal.fit(encal.read_calibration(paths["arc"])).save(folder / "arc_model.json")  # issue 31
    ann_model = encal.fit(cal, method="ann", hidden=3, epochs=5, rng=0)
    paths["ann_model"] = ann_model.save(folder / "ann_model.json", reproducible=True)
    text = paths["model"].read_text(encoding="utf-8")
    document = json.loads(text)
    newer = dict(document, version=runtime.VERSION + 1)
    altered = json.loads(text)
    altered["parameters"]["cos"][0] += 0.001
    no_parameters = {key: value for key, value in document.items() if key != "parameters"}
    huge = json.loads(text)
    huge["parameters"]["cos"] = [1e308] * len(huge["parameters"]["cos"])
    models = {
        "not_json": "this is not JSON\n",
        "other_format": json.dumps({"format": "something.else", "version": 1}),
        "newer": _resigned(newer),
        "truncated_model": text[: len(text) // 2],
        "altered": json.dumps(altered, indent=1),
        "json_array": "[1, 2, 3]",
        "empty_model": "",
        "no_parameters": _resigned(no_parameters),
        "huge_parameters": _resigned(huge),
    }
    for key, content in models.items():
        paths[key] = folder / f"{key}.json"
        paths[key].write_text(content, encoding="utf-8")
    paths["binary_model"] = folder / "binary_model.json"
    paths["binary_model"].write_bytes(bytes(range(255, -1, -1)) * 4)
    paths["model_copy"] = folder / "model_copy.json"
    paths["model_copy"].write_bytes(paths["model"].read_bytes())
    paths["input_copy"] = folder / "input_copy.csv"
    paths["input_copy"].write_bytes(paths["train"].read_bytes())
    paths["nodir"] = folder / "no" / "such" / "folder"
    paths["out"] = folder / "out"  # where refused commands would have written: must stay empty
    paths["scratch"] = folder / "scratch"  # where the accepted commands write
    paths["out"].mkdir()
    paths["scratch"].mkdir()
    _make_dialect_and_edited_files(folder, paths, good, document)
    _make_moteus_files(folder, paths, document)
    _make_issue25_files(folder, paths, document)
    _make_files_and_paths_files(folder, paths, good)
    _make_plausibility_files(folder, paths)
    _make_fuzz5_files(folder, paths)
    _make_strict6_files(folder, paths)
    _make_store6_files(paths)
    _make_fuzz6_files(folder, paths)
    _make_metrology8_files(folder, paths)
    arc = np.arange(45.0, 315.0, 1.0)  # an arc of 269 deg: the outside attack's case
    paths["arc_only"] = folder / "arc_only.csv"
    paths["arc_only"].write_text(_csv_text(arc - (30 * np.sin(np.radians(arc)) + 10 * np.cos(np.radians(3 * arc))) / 60,
                                           arc), encoding="utf-8")
    _make_fleet8_files(folder, paths)
    _make_arc8_files(folder, paths)
    _make_noise9_files(folder, paths)
    return {key: str(path) for key, path in paths.items()}


def _make_dialect_and_edited_files(folder, paths, good, document):
    """The inputs of the CSV-dialect and re-signed-model cases (issue 17)."""
    lines = good.splitlines()
    header, rows = lines[0], lines[1:]

    def csv(*parts):
        return "\n".join(parts) + "\n"

    bad_row = list(rows)
    bad_row[97] = "194.0,194,031005859375"  # a decimal comma in one cell: line 99
    texts = {
        "quoted_header": csv('"time, s",reference_deg,encoder_deg,"temp, C"',
                             *(f'"{i},5",{row},"20,0"' for i, row in enumerate(rows))),
        "decimal_comma_cell": csv(header, *bad_row),
        "trailing_comma": csv(header, *(row + "," for row in rows)),
        "unbalanced_quote": csv(header, *rows[:10], '"20.0,20.01', *rows[11:]),
        "text_after_quote": csv(header, *rows[:10], '"20.0"x,20.01', *rows[11:]),
        "formfeed_comment": csv("# run\x0c2", header, *rows[:4], "8.0,oops", *rows[5:]),
        "u2028_comment": csv("# run\u20282\u2029", header, *rows[:4], "8.0,oops", *rows[5:]),
        "nel_comment": csv("# run\x852", header, *rows[:4], "8.0,oops", *rows[5:]),
        "cr_only": "\r".join([header, *rows]) + "\r",
        "crlf_bom": "\ufeff" + "\r\n".join([header, *rows]) + "\r\n",
        "superscript_bits": csv("# resolution_bits: \u00b2", header, *rows),
        "arabic_bits": csv("# resolution_bits: \u0661\u0666", header, *rows),
        "repeated_rows": csv(header, *(row for row in rows[:120] for _ in range(3)), *rows[120:]),
        "quoted_cells": csv("reference_deg,encoder_deg,note", *(f'{row},"say ""hi"", ok"' for row in rows)),
        "spaced_names": csv('" Reference_Deg ", " ENCODER_DEG "', *rows),
        "named_extra": csv("reference_deg,encoder_deg,whole,fraction", *(row + ",98,031" for row in rows)),
        "stdin_quoted": csv('"time, s",encoder_deg,temp_C', "0.5,10.0,25.0", "1.0,20.0,26.0"),
    }
    for key, text in texts.items():
        paths[key] = folder / f"{key}.csv"
        paths[key].write_text(text, encoding="utf-8", newline="")
    paths["constant_model"] = folder / "constant_model.json"
    from encal.models.fourier import FourierModel

    FourierModel([0], [30.0], [0.0]).save(paths["constant_model"], reproducible=True)  # corrects by -0.5 deg

    def edited(key, change):
        content = json.loads(json.dumps(document))
        change(content)
        content.pop("sha256", None)
        paths[key] = folder / f"{key}.json"
        paths[key].write_text(_resigned(content), encoding="utf-8")

    ann = json.loads(Path(paths["ann_model"]).read_text(encoding="utf-8"))

    def edited_ann(key, change):
        content = json.loads(json.dumps(ann))
        change(content)
        content.pop("sha256", None)
        paths[key] = folder / f"{key}.json"
        paths[key].write_text(_resigned(content), encoding="utf-8")

    def gain(name, value):
        def change(d):
            if name == "target_gain":
                d["parameters"][name] = d["normalisation"][name] = value
            else:
                d["parameters"][name][0] = d["normalisation"][name][0] = value
        return change

    edited_ann("tiny_target_gain", gain("target_gain", 1e-300))
    edited_ann("tiny_input_gain", gain("input_gain", -1e-300))
    edited_ann("huge_int_b2", lambda d: d["parameters"].__setitem__("b2", 10**400))
    edited_ann("huge_w1", lambda d: d["parameters"]["W1"][0].__setitem__(0, 1e101))
    edited("huge_int_cos", lambda d: d["parameters"]["cos"].__setitem__(0, 10**400))
    edited("huge_int_order", lambda d: d["parameters"]["orders"].__setitem__(0, 10**400))
    edited("huge_int_bits", lambda d: d["encoder"].__setitem__("resolution_bits", 10**400))
    edited("huge_int_version", lambda d: d.__setitem__("version", 10**400))
    edited("sign_in_v1", lambda d: d.__setitem__("reading_sign", -1))
    edited("sign_zero", lambda d: d.update(version=2, reading_sign=0))
    edited("sign_text", lambda d: d.update(version=2, reading_sign="-1"))
    edited("sign_missing_v2", lambda d: d.update(version=2))
    edited("sign_float", lambda d: d.update(version=2, reading_sign=-1.0))
    edited("sign_reversed_ok", lambda d: d.update(version=2, reading_sign=-1))
    edited("tiny_grid_step", lambda d: d.__setitem__("uncertainty", {
        "method": "given", "grid_step_deg": 1e-300, "model_std_arcmin": [0.1], "noise_std_arcmin": 0.1}))
    edited("negative_noise", lambda d: d.__setitem__("uncertainty", {
        "method": "given", "grid_step_deg": 180.0, "model_std_arcmin": [0.1, 0.1], "noise_std_arcmin": -0.1}))
    paths["long_name"] = folder / "scratch" / ("m" * 245 + ".json")  # 250 characters: legal
    paths["too_long_name"] = folder / "out" / ("m" * 256)


# --------------------------------------------------------------------------- the catalogue

@dataclass(frozen=True)
class Case:
    """One command line and what must come of it.

    ``argv`` may name the catalogue's files as ``{key}`` (see :func:`_make_files`). ``says``: words the
    error line (status 1) must hold, besides the command's prefix (case-insensitive). ``warns``: words
    of the one expected warning line. ``prints``: words standard output must hold; ``answers``: its
    number of lines. ``marks``: e.g. a strict xfail for a known bug in another module.
    """

    id: str
    argv: tuple
    status: int
    says: tuple = ()
    warns: tuple = ()
    prints: tuple = ()
    answers: int | None = None
    stdin: str = ""
    marks: tuple = field(default=(), compare=False)
    env: tuple = ()  # (name, value) pairs set while the case runs

    @property
    def command(self):
        return self.argv[0]


def _data_cases(command, *before, after=()):
    """The bad-calibration-file cases of a command that reads calibration CSVs."""
    bad = {
        "missing": ("missing.csv", "no such file"),
        "empty": ("empty.csv", "empty"),
        "blank": ("blank.csv", "empty"),
        "header_only": ("header_only.csv", "at least 8"),
        "numbers_first": ("numbers_first.csv", "header"),
        "no_encoder_column": ("no_encoder_column.csv", "encoder_deg"),
        "binary": ("binary.csv", "binary"),
        "utf16": ("utf16.csv", "UTF-8"),
        "truncated": ("truncated.csv", "truncated"),
        "nan": ("nan.csv", "finite"),
        "inf": ("inf.csv", "finite"),
        "text_cell": ("text_cell.csv", "'ten'"),
        "empty_cell": ("empty_cell.csv", "reference_deg"),
        "huge_angle": ("huge_angle.csv", "1e15"),
        "bad_bits": ("bad_bits.csv", "resolution_bits"),
        "seven_points": ("seven_points.csv", "at least 8"),
        "duplicate": ("duplicate.csv", "--average-duplicates"),
        "reversed": ("reversed.csv", "--reverse"),
        "gap": ("gap.csv", "--allow-gaps"),
        "fold": ("fold.csv", "back"),
    }
    cases = []
    for key, (name, word) in bad.items():
        says = (name, word) if key != "missing" else (name, word, "expected")
        cases.append(Case(f"{command}-{key}", (command, *before, f"{{{key}}}", *after), 1, says))
    cases += [
        Case(f"{command}-folder-as-csv", (command, *before, "{out}", *after), 1, ("folder",)),
        Case(f"{command}-radians", (command, *before, "{radians}", *after), 1, ("gap",),
             warns=("radians", "57.29578")),
    ]
    return cases


CASES = [
    # ---------------------------------------------------------------- profile
    *_data_cases("profile"),
    # The repeat of 10 degrees reads 30 arcmin off the first: averaged on request, and named as a misread.
    Case("profile-duplicates-averaged", ("profile", "{duplicate}", "--average-duplicates"), 0,
         prints=("180 points",), warns=("line 182 (encoder 10.500 deg)", "misread")),
    # Kept as repeated readings on request: 181 points.
    Case("profile-duplicates-kept", ("profile", "{duplicate}", "--keep-duplicates"), 0,
         prints=("181 points",), warns=("line 182 (encoder 10.500 deg)", "misread")),
    Case("profile-duplicates-kept-and-averaged", ("profile", "{duplicate}", "--keep-duplicates",
                                                  "--average-duplicates"), 2),
    Case("profile-repeated-readings-accepted", ("profile", "{repeated}"), 0, prints=("540 points",)),
    Case("profile-reversed-accepted", ("profile", "{reversed}", "--reverse"), 0),
    Case("profile-gap-accepted", ("profile", "{gap}", "--allow-gaps"), 0),
    Case("profile-radians-accepted-with-warning", ("profile", "{radians}", "--allow-gaps", "--json"), 0,
         warns=("radians",)),
    # A header without commas: whitespace-separated (tabs or spaces), read like the comma-separated file.
    Case("profile-tab-separated-accepted", ("profile", "{tab}", "--json"), 0, prints=('"n": 180',)),
    Case("profile-no-column-of-that-name", ("profile", "{train}", "--ref-col", "angle"), 1, ("no column 'angle'",)),
    Case("profile-unknown-unit", ("profile", "{train}", "--enc-unit", "grad"), 2),
    Case("profile-counts-without-bits", ("profile", "{train}", "--enc-unit", "counts"), 2),
    Case("profile-no-argument", ("profile",), 2),
    Case("profile-negative-top", ("profile", "{train}", "--top", "-1"), 2),
    Case("profile-unknown-option", ("profile", "{train}", "--bogus"), 2),
    # ---------------------------------------------------------------- fit
    *_data_cases("fit", after=("-o", "{out}/m.json", "--method", "fourier")),
    Case("fit-duplicates-averaged", ("fit", "{duplicate}", "-o", "{scratch}/avg.json", "--method", "lut",
                                     "--average-duplicates"), 0, prints=("180 points",),
         warns=("line 182 (encoder 10.500 deg)", "misread")),
    Case("fit-repeated-readings-accepted", ("fit", "{repeated}", "-o", "{scratch}/rep.json", "--method", "spectral"),
         0, prints=("540 points", "prior: noise from repeated readings")),
    Case("fit-duplicates-kept-and-averaged", ("fit", "{duplicate}", "-o", "{out}/m.json", "--keep-duplicates",
                                              "--average-duplicates"), 2),
    # A repeat pass on another grid, or at another zero, is no repeat.
    Case("fit-repeat-on-another-grid", ("fit", "{train}", "-o", "{out}/m.json", "--repeat", "{test}"), 1,
         ("--repeat", "test.csv", "180 of its 180 stops", "are not stops of", "train.csv")),
    Case("fit-repeat-at-another-zero", ("fit", "{train}", "-o", "{out}/m.json", "--repeat", "{shifted}"), 1,
         ("--repeat", "shifted.csv", "+79.2 deg", "train.csv", "zero moved")),
    Case("fit-reversed-accepted", ("fit", "{reversed}", "-o", "{scratch}/rev.json", "--method", "fourier",
                                   "--reverse"), 0),
    Case("fit-output-folder-missing", ("fit", "{train}", "-o", "{nodir}/m.json"), 1, ("does not exist",)),
    Case("fit-output-is-a-folder", ("fit", "{train}", "-o", "{out}", "--method", "lut"), 1, ("folder",)),
    Case("fit-output-is-the-input", ("fit", "{input_copy}", "-o", "{input_copy}", "--method", "lut"), 1,
         ("calibration",)),
    Case("fit-hidden-0", ("fit", "{train}", "-o", "{out}/m.json", "--method", "ann", "--hidden", "0"), 2),
    Case("fit-hidden-negative", ("fit", "{train}", "-o", "{out}/m.json", "--method", "ann", "--hidden", "-4"), 2),
    Case("fit-hidden-not-a-number", ("fit", "{train}", "-o", "{out}/m.json", "--method", "ann", "--hidden", "x"), 2),
    Case("fit-epochs-0", ("fit", "{train}", "-o", "{out}/m.json", "--method", "ann", "--epochs", "0"), 2),
    Case("fit-unknown-method", ("fit", "{train}", "-o", "{out}/m.json", "--method", "spline"), 2),
    Case("fit-unknown-encoding", ("fit", "{train}", "-o", "{out}/m.json", "--method", "ann", "--encoding", "x"), 2),
    Case("fit-unknown-interpolation", ("fit", "{train}", "-o", "{out}/m.json", "--method", "lut",
                                       "--interpolation", "quadratic"), 2),
    Case("fit-n-orders-0", ("fit", "{train}", "-o", "{out}/m.json", "--method", "fourier", "--n-orders", "0"), 2),
    Case("fit-no-output", ("fit", "{train}"), 2),
    Case("fit-unknown-algorithm", ("fit", "{train}", "-o", "{out}/m.json", "--method", "ann", "--algorithm",
                                   "trainxx", "--epochs", "2"), 1, ("trainlm", "trainxx")),
    Case("fit-bad-orders", ("fit", "{train}", "-o", "{out}/m.json", "--method", "fourier", "--orders", "1,x"), 2,
         ("--orders",)),
    Case("fit-negative-orders", ("fit", "{train}", "-o", "{out}/m.json", "--method", "fourier", "--orders=-1,2"),
         1, ("orders",)),
    Case("fit-option-of-another-method", ("fit", "{train}", "-o", "{out}/m.json", "--method", "lut", "--hidden",
                                          "3"), 2, ("--hidden",)),
    Case("fit-folds-1", ("fit", "{train}", "-o", "{out}/m.json", "--folds", "1"), 2),
    Case("fit-too-many-folds", ("fit", "{train}", "-o", "{out}/m.json", "--folds", "100", "--seed", "0"), 1,
         ("folds", "100")),
    Case("fit-folds-with-lut", ("fit", "{train}", "-o", "{out}/m.json", "--method", "lut", "--folds", "3"), 2,
         ("--folds",)),
    Case("fit-negative-seed", ("fit", "{train}", "-o", "{out}/m.json", "--method", "ann", "--epochs", "2",
                               "--seed", "-1"), 1, ("-1",)),
    Case("fit-orders-and-n-orders", ("fit", "{train}", "-o", "{out}/m.json", "--method", "fourier", "--orders",
                                     "1", "--n-orders", "2"), 2, ("--orders and --n-orders",)),
    Case("fit-negative-seed-auto", ("fit", "{train}", "-o", "{out}/m.json", "--seed", "-1"), 1, ("-1",)),
    Case("fit-aliasing-orders", ("fit", "{train}", "-o", "{scratch}/alias.json", "--method", "fourier", "--orders",
                                 "0,1,179"), 1, ("179",)),
    # ---------------------------------------------------------------- evaluate
    *_data_cases("evaluate", "{model}"),
    Case("evaluate-model-missing", ("evaluate", "{out}/none.json", "{test}"), 1, ("none.json",)),
    Case("evaluate-model-not-json", ("evaluate", "{not_json}", "{test}"), 1, ("not_json.json", "JSON")),
    Case("evaluate-model-empty", ("evaluate", "{empty_model}", "{test}"), 1, ("empty_model.json", "JSON")),
    Case("evaluate-model-binary", ("evaluate", "{binary_model}", "{test}"), 1, ("binary_model.json", "UTF-8")),
    Case("evaluate-model-other-format", ("evaluate", "{other_format}", "{test}"), 1, ("other_format.json",
                                                                                     "encal.model")),
    Case("evaluate-model-newer", ("evaluate", "{newer}", "{test}"), 1, ("newer.json", "version 4", "upgrade")),
    Case("evaluate-model-truncated", ("evaluate", "{truncated_model}", "{test}"), 1, ("truncated_model.json",
                                                                                     "JSON")),
    Case("evaluate-model-altered", ("evaluate", "{altered}", "{test}"), 1, ("altered.json", "checksum")),
    Case("evaluate-model-array", ("evaluate", "{json_array}", "{test}"), 1, ("json_array.json", "object")),
    Case("evaluate-model-no-parameters", ("evaluate", "{no_parameters}", "{test}"), 1, ("parameters",)),
    Case("evaluate-model-is-a-csv", ("evaluate", "{train}", "{test}"), 1, ("train.csv", "JSON")),
    Case("evaluate-model-is-a-folder", ("evaluate", "{out}", "{test}"), 1, ("out",)),
    Case("evaluate-one-argument", ("evaluate", "{model}"), 2),
    Case("evaluate-repeated-readings-accepted", ("evaluate", "{model}", "{repeated}", "--json"), 0,
         prints=('"n": 540',)),
    # ---------------------------------------------------------------- correct
    Case("correct-model-missing", ("correct", "{out}/none.json", "{angles_ok}"), 1, ("none.json",)),
    Case("correct-model-not-json", ("correct", "{not_json}", "{angles_ok}"), 1, ("not_json.json", "JSON")),
    Case("correct-model-other-format", ("correct", "{other_format}", "{angles_ok}"), 1, ("encal.model",)),
    Case("correct-model-newer", ("correct", "{newer}", "{angles_ok}"), 1, ("newer.json", "upgrade")),
    Case("correct-model-truncated", ("correct", "{truncated_model}", "{angles_ok}"), 1, ("JSON",)),
    Case("correct-model-altered", ("correct", "{altered}", "{angles_ok}"), 1, ("altered.json", "checksum")),
    Case("correct-model-binary", ("correct", "{binary_model}", "{angles_ok}"), 1, ("UTF-8",)),
    Case("correct-bad-line", ("correct", "{model}", "{angles}"), 1, ("line 3", "'abc'", "expected"), answers=2),
    Case("correct-bad-line-skipped", ("correct", "{model}", "{angles}", "--skip-bad"), 0, prints=("nan",),
         answers=4),
    Case("correct-bad-stdin-line", ("correct", "{model}", "-"), 1, ("line 2", "stdin"), stdin="10\n1,2,x\n",
         answers=1),
    Case("correct-nan-on-stdin", ("correct", "{model}"), 1, ("line 1",), stdin="nan\n", answers=0),
    Case("correct-odd-but-valid", ("correct", "{model}", "{angles_ok}"), 0, answers=4),
    Case("correct-input-missing", ("correct", "{model}", "{missing}"), 1, ("missing.csv",)),
    Case("correct-input-binary", ("correct", "{model}", "{binary}"), 1, ("binary.csv", "line 1")),
    Case("correct-input-folder", ("correct", "{model}", "{out}"), 1, ("out",)),
    Case("correct-no-model", ("correct",), 2),
    Case("correct-options-before-file", ("correct", "{model}", "--skip-bad", "{angles}"), 0, answers=4),
    # ---------------------------------------------------------------- export
    Case("export-model-missing", ("export", "{out}/none.json", "--format", "table", "-o", "{out}/t.bin"), 1,
         ("none.json",)),
    Case("export-model-not-json", ("export", "{not_json}", "--format", "table", "-o", "{out}/t.bin"), 1, ("JSON",)),
    Case("export-model-newer", ("export", "{newer}", "--format", "c", "-o", "{out}/c"), 1, ("upgrade",)),
    Case("export-model-altered", ("export", "{altered}", "--format", "table", "-o", "{out}/t.bin"), 1,
         ("checksum",)),
    Case("export-model-truncated", ("export", "{truncated_model}", "--format", "c", "-o", "{out}/c"), 1,
         ("JSON",)),
    Case("export-bits-0", ("export", "{model}", "--format", "table", "-o", "{out}/t.bin", "--bits", "0"), 1,
         ("bits", "0")),
    Case("export-bits-negative", ("export", "{model}", "--format", "table", "-o", "{out}/t.bin", "--bits", "-3"),
         1, ("bits",)),
    Case("export-bits-too-many", ("export", "{model}", "--format", "c", "-o", "{out}/c", "--bits", "40"), 1,
         ("bits",)),
    Case("export-bad-c-name", ("export", "{model}", "--format", "c", "-o", "{out}/c", "--name", "1 bad", "--bits",
                               "12"), 1,
         ("identifier",)),
    Case("export-output-folder-missing", ("export", "{model}", "--format", "table", "-o", "{nodir}/t.bin",
                                          "--bits", "8"), 1, ("does not exist",)),
    Case("export-c-output-is-a-file", ("export", "{model}", "--format", "c", "-o", "{afile}", "--bits", "12"), 1,
         ("afile",)),
    Case("import-missing-file", ("import", "moteus", "{missing}", "-o", "{out}/m.json"), 1, ("missing.csv",)),
    Case("import-binary-file", ("import", "klipper", "{binary}", "-o", "{out}/k.csv"), 1, ("binary.csv",)),
    Case("import-not-a-capture", ("import", "moteus-cal", "{angles}", "-o", "{out}/c.csv"), 1, ("CAL start",)),
    Case("import-unknown-kind", ("import", "odrive", "{angles}", "-o", "{out}/x"), 2),
    Case("import-tinymovr-without-bits", ("import", "tinymovr", "{angles}", "-o", "{out}/x"), 2),
    Case("export-firmware-with-c-options", ("export", "{model}", "--format", "moteus", "--nodes", "64",
                                            "-o", "{out}/m.cfg"), 2),
    Case("export-unknown-format", ("export", "{model}", "--format", "hex", "-o", "{out}/t"), 2),
    Case("export-no-format", ("export", "{model}", "-o", "{out}/t"), 2),
    Case("export-unknown-dtype", ("export", "{model}", "--format", "table", "-o", "{out}/t", "--dtype", "int8"), 2),
    Case("export-unknown-constants", ("export", "{model}", "--format", "c", "-o", "{out}/c", "--constants",
                                      "half"), 2),
    Case("export-bits-not-a-number", ("export", "{model}", "--format", "table", "-o", "{out}/t", "--bits", "x"), 2),
    Case("export-over-its-own-model", ("export", "{model_copy}", "--format", "table", "-o", "{model_copy}",
                                       "--bits", "8"), 1, ("model_copy.json",)),
    Case("export-huge-parameters", ("export", "{huge_parameters}", "--format", "table", "-o", "{out}/h.bin",
                                    "--bits", "8"), 1, ("huge_parameters.json", "1e+308")),
    Case("correct-huge-parameters", ("correct", "{huge_parameters}", "{angles_ok}"), 1, ("huge_parameters.json",),
         answers=0),
    # ---------------------------------------------------------------- simulate
    Case("simulate-negative-encoders", ("simulate", "--encoders", "-1", "--out", "{out}/sim"), 2),
    Case("simulate-zero-encoders", ("simulate", "--encoders", "0", "--out", "{out}/sim"), 2),
    Case("simulate-too-many-encoders", ("simulate", "--encoders", "100000", "--out", "{out}/sim"), 2),
    Case("simulate-negative-seed", ("simulate", "--seed", "-5", "--out", "{out}/sim"), 2),
    Case("simulate-out-is-a-file", ("simulate", "--encoders", "1", "--out", "{afile}"), 1, ("afile", "folder")),
    Case("simulate-out-parent-missing", ("simulate", "--encoders", "1", "--out", "{nodir}"), 1,
         ("does not exist",)),
    Case("simulate-unknown-option", ("simulate", "--bogus"), 2),
    # ---------------------------------------------------------------- demo (only cases refused before any work)
    Case("demo-zero-encoders", ("demo", "--encoders", "0"), 2),
    Case("demo-negative-workers", ("demo", "--workers", "-1"), 2),
    Case("demo-negative-seed", ("demo", "--seed", "-1", "--out", "{out}/demo"), 1, ("--seed",)),
    Case("demo-out-is-a-file", ("demo", "--out", "{afile}", "--quick", "--no-progress"), 1, ("afile", "folder")),
    Case("demo-unknown-option", ("demo", "--bogus"), 2),
    # ---------------------------------------------------------------- compare
    *_data_cases("compare", "{train}", after=("--models", "fourier")),
    Case("compare-bad-train-file", ("compare", "{truncated}", "{test}"), 1, ("truncated.csv", "truncated")),
    Case("compare-unknown-model", ("compare", "{train}", "{test}", "--models", "spline"), 1, ("--models",)),
    Case("compare-epochs-0", ("compare", "{train}", "{test}", "--epochs", "0"), 2),
    Case("compare-negative-seed", ("compare", "{train}", "{test}", "--seed", "-1"), 1, ("--seed",)),
    Case("compare-one-file", ("compare", "{train}"), 2),
    # ---------------------------------------------------------------- study
    *_data_cases("study", "prune", after=("--hidden", "3", "--epochs", "2")),
    Case("study-bad-test-file", ("study", "prune", "{train}", "--test", "{nan}", "--hidden", "3", "--epochs", "2"),
         1, ("nan.csv", "finite")),
    Case("study-hidden-0", ("study", "sweep", "{train}", "--hidden", "0", "--epochs", "2"), 1, ("--hidden",)),
    Case("study-unknown-algorithm", ("study", "sweep", "{train}", "--algorithms", "trainxx", "--epochs", "2"),
         1, ("--algorithms",)),
    Case("study-negative-threshold", ("study", "prune", "{train}", "--threshold", "-1", "--hidden", "3",
                                      "--epochs", "2"), 1, ("threshold",)),
    Case("study-out-is-a-file", ("study", "prune", "{train}", "--out", "{afile}", "--hidden", "3", "--epochs", "2"),
         1, ("afile",)),
    Case("study-unknown-study", ("study", "survey", "{train}"), 2),
    Case("study-seeds-0", ("study", "sweep", "{train}", "--seeds", "0"), 2),
    Case("study-negative-seed", ("study", "sweep", "{train}", "--seed", "-1"), 2),
    # ---------------------------------------------------------------- drift
    *_data_cases("drift", "{train}"),
    Case("drift-one-run", ("drift", "{train}"), 1, ("two",)),
    Case("drift-negative-tolerance", ("drift", "{train}", "{test}", "--tolerance", "-1"), 1, ("tolerance",)),
    Case("drift-nan-tolerance", ("drift", "{train}", "{test}", "--tolerance", "nan"), 1, ("tolerance",)),
    Case("drift-unknown-method", ("drift", "{train}", "{test}", "--method", "spline"), 2),
    Case("drift-model-altered", ("drift", "{train}", "{test}", "--model", "{altered}"), 1, ("checksum",)),
    Case("drift-model-missing", ("drift", "{train}", "{test}", "--model", "{out}/none.json"), 1, ("none.json",)),
    Case("drift-tolerance-not-a-number", ("drift", "{train}", "{test}", "--tolerance", "abc"), 2),
    Case("drift-no-file", ("drift",), 2),
    # ---------------------------------------------------------------- report
    *_data_cases("report", after=("-o", "{out}/r.html", "--method", "fourier", "--no-uncertainty")),
    Case("report-output-folder-missing", ("report", "{train}", "-o", "{nodir}/r.html", "--method", "fourier"), 1,
         ("does not exist",)),
    Case("report-output-is-the-input", ("report", "{input_copy}", "-o", "{input_copy}", "--method", "lut"), 1,
         ("input calibration",)),
    Case("report-bad-test-file", ("report", "{train}", "{nan}", "-o", "{out}/r.html", "--method", "lut"), 1,
         ("nan.csv", "finite")),
    Case("report-no-output", ("report", "{train}"), 2),
    Case("report-unknown-method", ("report", "{train}", "-o", "{out}/r.html", "--method", "spline"), 2),
    Case("report-unknown-zero", ("report", "{train}", "-o", "{out}/r.html", "--zero", "maybe"), 2),
    # ---------------------------------------------------------------- selfcal
    Case("selfcal-sweep-not-a-capture", ("selfcal", "sweep", "{train}", "--pole-pairs", "7", "-o", "{out}/c.csv"),
         1, ("train.csv", "line 1", "CAL start")),
    Case("selfcal-spin-not-a-log", ("selfcal", "spin", "{train}", "-o", "{out}/c.csv"), 1,
         ("train.csv", "time_s")),
    Case("selfcal-sweep-missing", ("selfcal", "sweep", "{out}/none.txt", "--pole-pairs", "7", "-o", "{out}/c.csv"),
         1, ("none.txt",)),
    Case("selfcal-no-method", ("selfcal",), 2),
    Case("selfcal-sweep-no-pole-pairs", ("selfcal", "sweep", "{train}", "-o", "{out}/c.csv"), 2),
    Case("selfcal-spin-no-output", ("selfcal", "spin", "{train}"), 2),
    # ---------------------------------------------------------------- issues 25/26 (fw-sfoc-tiny): firmware tables
    Case("import-simplefoc-empty", ("import", "simplefoc", "{sfoc_empty}", "-o", "{out}/s.json",
                                    "--firmware-version", "1.0.9"), 1, ("sfoc_empty.csv", "no values")),
    Case("import-simplefoc-nan", ("import", "simplefoc", "{sfoc_nan}", "-o", "{out}/s.json", "--firmware-version",
                                  "1.0.9"), 1, ("sfoc_nan.csv", "line 3", "element 2", "finite")),
    Case("import-simplefoc-version-unknown", ("import", "simplefoc", "{sfoc_bare}", "-o", "{out}/s.json"), 1,
         ("sfoc_bare.csv", "--firmware-version")),
    Case("import-simplefoc-bad-version", ("import", "simplefoc", "{sfoc_bare}", "-o", "{out}/s.json",
                                          "--firmware-version", "2.0"), 2),
    Case("import-tinymovr-inf", ("import", "tinymovr", "{tiny_inf}", "-o", "{out}/t.json", "--bits", "14"), 1,
         ("tiny_inf.csv", "element 1")),
    Case("import-firmware-version-not-simplefoc", ("import", "tinymovr", "{tiny_inf}", "-o", "{out}/t.json",
                                                   "--bits", "14", "--firmware-version", "1.0.9"), 2),
    Case("export-tinymovr-24-bits", ("export", "{model}", "--format", "tinymovr", "--bits", "24", "-o",
                                     "{scratch}/t.h"), 0, prints=("round trip",)),
    Case("export-firmware-version-not-simplefoc", ("export", "{model}", "--format", "moteus", "-o", "{out}/m.cfg",
                                                   "--firmware-version", "1.0.9"), 2),
]

# ---------------------------------------------------------------- issue 17: dialects, re-signed files, environments

def _dialect_cases():
    """CSV dialect cases for every command that reads a calibration (encal._core.csv_dialect: one dialect)."""
    cases = []
    for command, before, after in (("profile", (), ()), ("fit", (), ("-o", "{scratch}/d.json", "--method", "lut")),
                                   ("evaluate", ("{model}",), ())):
        refused = {
            "decimal-comma-cell": ("decimal_comma_cell", ("line 99", "3 fields", "expected 2", "decimal comma")),
            "trailing-comma": ("trailing_comma", ("line 2", "3 fields")),
            "unbalanced-quote": ("unbalanced_quote", ("line 12", "not closed")),
            "text-after-quote": ("text_after_quote", ("line 12", "closing quote")),
            "formfeed-comment": ("formfeed_comment", ("line 7", "'oops'")),
            "u2028-comment": ("u2028_comment", ("line 7", "'oops'")),
            "nel-comment": ("nel_comment", ("line 7", "'oops'")),
            "superscript-bits": ("superscript_bits", ("line 1", "resolution_bits")),
        }
        for name, (key, says) in refused.items():
            cases.append(Case(f"{command}-{name}", (command, *before, f"{{{key}}}", *after), 1, says))
        for key in ("quoted_header", "cr_only", "crlf_bom", "repeated_rows", "quoted_cells", "spaced_names",
                    "named_extra"):
            cases.append(Case(f"{command}-{key.replace('_', '-')}-accepted", (command, *before, f"{{{key}}}", *after),
                              0))
    cases.append(Case("profile-arabic-bits", ("profile", "{arabic_bits}"), 1, ("line 1", "resolution_bits")))
    return cases


def _edited_model_cases():
    """Model files edited by hand and re-signed: every parameter's range is checked on load."""
    refused = {
        "tiny-target-gain": ("tiny_target_gain", "target_gain"),
        "tiny-input-gain": ("tiny_input_gain", "input_gain"),
        "huge-int-b2": ("huge_int_b2", "b2"),
        "huge-w1": ("huge_w1", "W1"),
        "huge-int-cos": ("huge_int_cos", "cos"),
        "huge-int-order": ("huge_int_order", "orders"),
        "huge-int-bits": ("huge_int_bits", "resolution_bits"),
        "huge-int-version": ("huge_int_version", "upgrade"),
        "sign-in-v1": ("sign_in_v1", "reading_sign"),
        "sign-zero": ("sign_zero", "reading_sign"),
        "sign-text": ("sign_text", "reading_sign"),
        "sign-missing-v2": ("sign_missing_v2", "reading_sign"),
        "sign-float": ("sign_float", "reading_sign"),
        "tiny-grid-step": ("tiny_grid_step", "grid_step_deg"),
        "negative-noise": ("negative_noise", "uncertaint"),
    }
    cases = []
    for name, (key, word) in refused.items():
        cases.append(Case(f"correct-{name}", ("correct", f"{{{key}}}", "{angles_ok}"), 1, (f"{key}.json", word),
                          answers=0))
    for name in ("tiny-target-gain", "huge-int-cos", "sign-zero"):
        key = refused[name][0]
        cases.append(Case(f"export-{name}", ("export", f"{{{key}}}", "--format", "table", "-o", "{out}/t.bin",
                                             "--bits", "8"), 1, (f"{key}.json",)))
        cases.append(Case(f"evaluate-{name}", ("evaluate", f"{{{key}}}", "{test}"), 1, (f"{key}.json",)))
    cases.append(Case("correct-reversed-model-accepted", ("correct", "{sign_reversed_ok}", "{angles_ok}"), 0,
                      answers=4))
    return cases


_BAD_EPOCHS = {"abc": "abc", "negative": "-99999999999", "float": "1e9", "huge": "99999999999999",
               "empty": "", "fullwidth": "\uff11\uff12"}

ISSUE17_CASES = [
    *_dialect_cases(),
    *_edited_model_cases(),
    # encal correct reads the same dialect: the quoted header keeps the columns, the temperature is not corrected
    Case("correct-quoted-header", ("correct", "{constant_model}", "{stdin_quoted}"), 0,
         prints=("9.500000000000\n19.500000000000",),
         answers=2),
    Case("correct-decimal-comma-on-stdin", ("correct", "{constant_model}"), 1, ("line 3", "3 fields"),
         stdin="reference_deg,encoder_deg\n1.0,10.0\n98.0,98,031005859375\n", answers=1),
    Case("correct-decimal-comma-skipped", ("correct", "{constant_model}", "--skip-bad"), 0,
         prints=("9.500000000000\nnan",),
         stdin="reference_deg,encoder_deg\n1.0,10.0\n98.0,98,031005859375\n", answers=2),
    Case("correct-formfeed-comment", ("correct", "{constant_model}"), 1, ("line 3",),
         stdin="# a\x0cb\n10\nx\n", answers=1),
    Case("correct-u2028-comment", ("correct", "{constant_model}"), 1, ("line 3",),
         stdin="# a\u2028b\n10\nx\n", answers=1),
    Case("correct-cr-only", ("correct", "{constant_model}"), 0, prints=("9.500000000000\n19.500000000000\n",),
         stdin="10\r20\r",
         answers=2),
    Case("correct-unbalanced-quote", ("correct", "{constant_model}"), 1, ("line 2", "not closed"),
         stdin='encoder_deg,note\n10,"x\n', answers=0),
    # hostile environments
    *(Case(f"{command}-source-date-epoch-{name}", (command, *argv), 1, ("SOURCE_DATE_EPOCH", repr(value)[1:-1][:8]),
           env=(("SOURCE_DATE_EPOCH", value),))
      for name, value in _BAD_EPOCHS.items()
      for command, argv in (("profile", ("{train}",)), ("fit", ("{train}", "-o", "{out}/e.json", "--method", "lut")))),
    Case("correct-source-date-epoch-abc", ("correct", "{model}", "{angles_ok}"), 1, ("SOURCE_DATE_EPOCH",),
         env=(("SOURCE_DATE_EPOCH", "abc"),), answers=0),
    Case("fit-source-date-epoch-accepted", ("fit", "{train}", "-o", "{scratch}/sde.json", "--method", "lut"), 0,
         env=(("SOURCE_DATE_EPOCH", " 86400 "),)),
    Case("profile-mplbackend-bogus", ("profile", "{train}"), 0, env=(("MPLBACKEND", "bogus"),)),
    # sizes bounded by what runs
    Case("fit-hidden-huge", ("fit", "{train}", "-o", "{out}/m.json", "--method", "ann", "--hidden", "1000000000"), 2),
    Case("fit-epochs-huge", ("fit", "{train}", "-o", "{out}/m.json", "--method", "ann", "--epochs", "10000000"), 2),
    Case("fit-n-orders-huge", ("fit", "{train}", "-o", "{out}/m.json", "--method", "fourier", "--n-orders",
                               "40000"), 2),
    Case("demo-encoders-huge", ("demo", "--encoders", "100000", "--out", "{out}/d"), 2),
    Case("demo-workers-huge", ("demo", "--workers", "1000", "--out", "{out}/d"), 2),
    Case("compare-epochs-huge", ("compare", "{train}", "{test}", "--epochs", "1000000000"), 2),
    Case("study-seeds-huge", ("study", "sweep", "{train}", "--seeds", "100000"), 2),
    Case("study-hidden-huge", ("study", "sweep", "{train}", "--hidden", "10,100000"), 1, ("--hidden", "1000")),
    # output names and devices
    Case("fit-250-character-name", ("fit", "{train}", "-o", "{long_name}", "--method", "lut"), 0),
    Case("fit-256-character-name", ("fit", "{train}", "-o", "{too_long_name}", "--method", "lut"), 1,
         ("256 bytes long",)),
    Case("profile-dev-zero", ("profile", "/dev/zero"), 1, ("/dev/zero", "line 1", "NUL")),
    Case("profile-repeated-rows-no-warning", ("profile", "{repeated_rows}"), 0, prints=("420 points",)),
]
CASES += ISSUE17_CASES

# ---------------------------------------------------------------- issue 25/26 moteus: tables, dumps, captures


def _make_moteus_files(folder, paths, document):
    """The inputs of the issue 25/26 moteus cases."""
    import math

    def table(values, scale=None, source=0):
        lines = [f"motor_position.sources.{source}.compensation_table.{i} {v}" for i, v in enumerate(values)]
        return lines + ([f"motor_position.sources.{source}.compensation_scale {scale}"] if scale is not None else [])

    values = [int(round(100 * math.sin(2 * math.pi * i / 256))) for i in range(256)]
    dump = ["motor_position.sources.0.cpr 16384", "motor_position.sources.0.offset 1000.000000",
            "motor_position.sources.0.sign -1", "motor_position.commutation_source 0"]

    def capture(pole_pairs=7, lag_deg=0.3):
        lines = ["CAL start"]
        for direction, order in ((1, range(pole_pairs * 64)), (2, range(pole_pairs * 64 - 1, -1, -1))):
            for i in order:
                turn = i / 64 / pole_pairs - (1 if direction == 1 else -1) * lag_deg / 360
                encoder = round(turn * 65536 + 40 * math.sin(2 * math.pi * turn)) % 65536
                lines.append(f"{direction} {i * 1024 % 65536} {encoder}")
        return lines + ["CAL done"]

    texts = {
        "moteus_noscale.cfg": table(values),
        "moteus_two_sources.cfg": table(values, "0.001") + table([0] * 256, "0.000000", source=1),
        "moteus_mixed.cfg": table(values) + ["motor_position.sources.1.compensation_scale 0.001"],
        "moteus_nan.cfg": table(values, "nan"),
        "moteus_old.cfg": table([f"{0.001 * math.cos(2 * math.pi * i / 32):.6f}" for i in range(32)]),
        "moteus_dump.txt": dump + table([0] * 256, "0.000000"),
        "moteus_cal.log": capture(),
        "moteus_compare_comma.txt": [f"{i / 20:.4f} {i / 20 + 0.001:.4f}".replace(".", ",") for i in range(20)],
    }
    for name, lines in texts.items():
        paths[name.replace(".", "_")] = folder / name
        paths[name.replace(".", "_")].write_text("\n".join(lines) + "\n", encoding="utf-8")
    huge = json.loads(json.dumps(document))
    huge["parameters"]["cos"][0] = 1e100
    huge.pop("sha256", None)
    paths["moteus_huge"] = folder / "moteus_huge.json"
    paths["moteus_huge"].write_text(_resigned(huge), encoding="utf-8")


MOTEUS_CASES = [
    Case("import-moteus-without-scale", ("import", "moteus", "{moteus_noscale_cfg}", "-o", "{out}/m.json"), 1,
         ("moteus_noscale.cfg", "compensation_scale")),
    Case("import-moteus-two-sources", ("import", "moteus", "{moteus_two_sources_cfg}", "-o", "{out}/m.json"), 1,
         ("moteus_two_sources.cfg", "--source")),
    Case("import-moteus-two-sources-with-source", ("import", "moteus", "{moteus_two_sources_cfg}", "-o",
                                                   "{scratch}/m2.json", "--source", "0"), 0),
    Case("import-moteus-scale-of-another-source", ("import", "moteus", "{moteus_mixed_cfg}", "-o", "{out}/m.json"), 1,
         ("source 1", "--source")),
    Case("import-moteus-nan-scale", ("import", "moteus", "{moteus_nan_cfg}", "-o", "{out}/m.json"), 1,
         ("moteus_nan.cfg", "line 257", "finite")),
    Case("import-moteus-32-bins-accepted", ("import", "moteus", "{moteus_old_cfg}", "-o", "{scratch}/old.json"), 0),
    Case("import-moteus-source-3", ("import", "moteus", "{moteus_old_cfg}", "-o", "{out}/m.json", "--source", "3"), 2),
    Case("import-moteus-cal-wrong-pole-pairs", ("import", "moteus-cal", "{moteus_cal_log}", "-o", "{out}/c.csv",
                                                "--pole-pairs", "8"), 1, ("moteus_cal.log", "pole-pair count 7")),
    Case("import-moteus-cal-lagging-accepted", ("import", "moteus-cal", "{moteus_cal_log}", "-o",
                                                "{scratch}/lagging.csv"), 0),
    Case("import-moteus-compare-decimal-comma", ("import", "moteus-compare", "{moteus_compare_comma_txt}", "-o",
                                                 "{out}/c.csv"), 1, ("moteus_compare_comma.txt", "line 1",
                                                                     "decimal commas")),
    *(Case(f"export-moteus-bits-{bits}", ("export", "{model}", "--format", "moteus", "-o", "{out}/m.cfg", "--bits",
                                          str(bits)), 1, (f"{bits}-bit", "--bits from 8")) for bits in (1, 4, 7)),
    Case("export-moteus-huge-coefficient", ("export", "{moteus_huge}", "--format", "moteus", "-o", "{out}/m.cfg"), 1,
         ("half a turn",)),
    Case("export-moteus-conf-accepted", ("export", "{model}", "--format", "moteus", "-o", "{scratch}/conf.cfg",
                                         "--conf", "{moteus_dump_txt}"), 0, prints=("sign -1", "14-bit")),
    Case("export-moteus-conf-and-sign", ("export", "{model}", "--format", "moteus", "-o", "{out}/m.cfg", "--conf",
                                         "{moteus_dump_txt}", "--sign", "1"), 2),
    Case("export-moteus-conf-other-bits", ("export", "{model}", "--format", "moteus", "-o", "{out}/m.cfg", "--conf",
                                           "{moteus_dump_txt}", "--bits", "16"), 1, ("--bits 16", "2^14")),
    Case("export-moteus-sign-0", ("export", "{model}", "--format", "moteus", "-o", "{out}/m.cfg", "--sign", "0"), 2),
    Case("export-moteus-console-accepted", ("export", "{model}", "--format", "moteus", "-o", "{scratch}/console.cfg",
                                            "--moteus-style", "console", "--sign", "-1", "--offset", "1000"), 0,
         prints=("console",)),
]
CASES += MOTEUS_CASES
# ---------------------------------------------------------------- issue 25: export and fit options


def _make_issue25_files(folder, paths, document):
    """A re-signed model whose first coefficient is 1e100 (finite, within the file's range), and one whose encoder
    name is hostile C; a model with a resolution (the catalogue's own records none)."""
    huge = json.loads(json.dumps(document))
    huge["parameters"]["cos"][0] = 1e100
    hostile = json.loads(json.dumps(document))
    hostile["encoder"]["name"] = 'enc /* x */ "q" ??/\n#define y \\'
    with_bits = json.loads(json.dumps(document))
    with_bits["encoder"]["resolution_bits"] = 14
    bad_deployment = json.loads(json.dumps(with_bits))
    bad_deployment["training"]["deployment"] = {"target": "fixed", "form": "table", "nodes": 3, "dtype": "int8"}
    for key, content in (("huge_coefficient", huge), ("hostile_name", hostile), ("model_14bit", with_bits),
                         ("bad_deployment", bad_deployment)):
        content.pop("sha256", None)
        paths[key] = Path(folder) / f"{key}.json"
        paths[key].write_text(_resigned(content), encoding="utf-8")


def _issue25_cases():
    export = ("export", "{model_14bit}")
    cases = [
        # an option of another format is a usage error naming the option and the formats it is for
        Case("export-firmware-version-with-tinymovr", (*export, "--format", "tinymovr", "--firmware-version", "1.0.9",
                                                       "-o", "{out}/t.h"), 2),
        Case("export-source-with-table", (*export, "--format", "table", "--source", "1", "-o", "{out}/t.bin"), 2),
        Case("export-full-steps-with-moteus", (*export, "--format", "moteus", "--full-steps", "100", "-o",
                                               "{out}/m.cfg"), 2),
        Case("export-name-with-table", (*export, "--format", "table", "--name", "x", "-o", "{out}/t.bin"), 2),
        Case("export-target-with-table", (*export, "--format", "table", "--target", "fixed", "-o", "{out}/t.bin"), 2),
        Case("export-table-flag-with-simplefoc", (*export, "--format", "simplefoc", "--table", "-o", "{out}/s.h"), 2),
        Case("export-dtype-with-host-formula", (*export, "--format", "c", "--dtype", "float32", "-o", "{out}/c"), 2),
        Case("export-constants-with-table", (*export, "--format", "c", "--table", "--constants", "double", "-o",
                                             "{out}/c"), 2),
        Case("export-nodes-with-formula", (*export, "--format", "c", "--target", "cortex-m4f", "--form", "formula",
                                           "--nodes", "64", "-o", "{out}/c"), 2),
        # the resolution an export needs: a usage error naming --bits
        Case("export-c-table-without-resolution", ("export", "{model}", "--format", "c", "--table", "-o", "{out}/c"),
             2),
        Case("export-tinymovr-without-resolution", ("export", "{model}", "--format", "tinymovr", "-o", "{out}/t.h"),
             2),
        # a compact table needs 4 nodes, one per code at most
        Case("export-m4f-bits-1", (*export, "--format", "c", "--target", "cortex-m4f", "--bits", "1", "-o",
                                   "{out}/c"), 1, ("--bits", "from 2 to 32")),
        Case("export-fixed-bits-1", (*export, "--format", "c", "--target", "fixed", "--bits", "1", "-o", "{out}/c"),
             1, ("--bits", "from 2 to 24")),
        Case("export-m4f-formula-bits-1-accepted", (*export, "--format", "c", "--target", "cortex-m4f", "--form",
                                                    "formula", "--bits", "1", "-o", "{scratch}/f1"), 0,
             warns=("--bits 1 differs from the 14 bits",)),
        Case("export-m4f-nodes-3", (*export, "--format", "c", "--target", "cortex-m4f", "--nodes", "3", "-o",
                                    "{out}/c"), 1, ("--nodes", "power of two")),
        Case("export-m4f-tolerance-nan", (*export, "--format", "c", "--target", "cortex-m4f", "--tolerance", "nan",
                                          "-o", "{out}/c"), 1, ("--tolerance",)),
        Case("export-fixed-tolerance-inf", (*export, "--format", "c", "--target", "fixed", "--tolerance", "inf",
                                            "-o", "{out}/c"), 1, ("--tolerance",)),
        Case("export-nodes-not-a-number", (*export, "--format", "c", "--target", "fixed", "--nodes", "1e3", "-o",
                                           "{out}/c"), 2),
        Case("export-bad-recorded-deployment", ("export", "{bad_deployment}", "--format", "c", "--target", "fixed",
                                                "-o", "{out}/c"), 1, ("bad_deployment.json", "training.deployment",
                                                                      "nodes")),
        # a hostile encoder name is escaped in the C comments (tests/cli/test_export_options.py compiles it)
        Case("export-hostile-name-accepted", ("export", "{hostile_name}", "--format", "c", "--target", "cortex-m4f",
                                              "-o", "{scratch}/hostile"), 0),
        # fit --noise: finite, > 0, at most a turn (usage); at least the errors' resolution (the data's)
        Case("fit-noise-huge", ("fit", "{train}", "-o", "{out}/m.json", "--method", "spectral", "--noise", "1e300"),
             2),
        Case("fit-noise-inf", ("fit", "{train}", "-o", "{out}/m.json", "--noise", "inf"), 2),
        Case("fit-noise-nan", ("fit", "{train}", "-o", "{out}/m.json", "--noise", "nan"), 2),
        Case("fit-noise-zero", ("fit", "{train}", "-o", "{out}/m.json", "--method", "spectral", "--noise", "0"), 2),
        Case("fit-noise-tiny", ("fit", "{train}", "-o", "{out}/m.json", "--method", "spectral", "--noise",
                                "1e-300"), 1, ("--noise", "3.41e-12", "21600")),
        Case("fit-noise-tiny-auto", ("fit", "{train}", "-o", "{out}/m.json", "--noise", "1e-300"), 1,
             ("--noise", "3.41e-12")),
        Case("fit-noise-at-a-turn-accepted", ("fit", "{train}", "-o", "{scratch}/noisy.json", "--method",
                                              "spectral", "--noise", "21600"), 0),
        Case("fit-noise-with-fourier", ("fit", "{train}", "-o", "{out}/m.json", "--method", "fourier", "--noise",
                                        "0.1"), 2),
    ]
    # a re-signed coefficient of 1e100: every C target and the dense table refuse it, naming the file
    for name, options in (("host", ()), ("host-table", ("--table",)), ("m4f", ("--target", "cortex-m4f")),
                          ("m4f-formula", ("--target", "cortex-m4f", "--form", "formula")),
                          ("fixed", ("--target", "fixed"))):
        cases.append(Case(f"export-huge-coefficient-{name}", ("export", "{huge_coefficient}", "--format", "c",
                                                              *options, "--bits", "12", "-o", "{out}/c"), 1,
                          ("huge_coefficient.json", "1e+100 arcmin", "one turn")))
    cases.append(Case("export-huge-coefficient-table", ("export", "{huge_coefficient}", "--format", "table",
                                                        "--dtype", "float32", "--bits", "12", "-o", "{out}/t.bin"), 1,
                      ("huge_coefficient.json", "1e+100 arcmin", "one turn")))
    return cases


CASES += _issue25_cases()
# issue 26: Klipper's and Mechaduino's tables are tied to the stepper's phase (--step-zero); their imports
ISSUE26_CASES = [
    Case("export-klipper-without-step-zero", ("export", "{model}", "--format", "klipper", "-o", "{out}/k.cfg"), 2),
    Case("export-mechaduino-step-zero-nan", ("export", "{model}", "--format", "mechaduino", "--bits", "14",
                                             "--step-zero", "nan", "-o", "{out}/m.c"), 2),
    Case("export-moteus-step-zero", ("export", "{model}", "--format", "moteus", "--step-zero", "0",
                                     "-o", "{out}/m.cfg"), 2),
    Case("export-klipper-step-zero", ("export", "{model}", "--format", "klipper", "--step-zero", "0.9",
                                      "--step-direction", "1", "-o", "{scratch}/k.cfg"), 0, prints=("round trip",)),
    Case("import-klipper-nan", ("import", "klipper", "{klipper_nan}", "-o", "{out}/k.csv"), 1,
         ("klipper_nan.csv, line 3", "finite", "'nan'")),
    Case("import-mechaduino-infinity", ("import", "mechaduino", "{mechaduino_inf}", "-o", "{out}/m.csv"), 1,
         ("element 16383", "finite")),
]
CASES += ISSUE26_CASES

# ---------------------------------------------------------------- issue 25: files and paths

def _make_files_and_paths_files(folder, paths, good):
    """Links to inputs, inputs where an output folder's files go, repeated column names, spreadsheet exports."""
    folder = Path(folder)
    paths["link_to_input"] = folder / "link_to_input.csv"
    paths["link_to_input"].symlink_to(paths["input_copy"])
    paths["hardlink_to_input"] = folder / "hardlink_to_input.csv"
    os.link(paths["input_copy"], paths["hardlink_to_input"])
    paths["link_to_model"] = folder / "link_to_model.json"
    paths["link_to_model"].symlink_to(paths["model_copy"])
    paths["c_folder"] = folder / "c_folder"  # export --format c -o c_folder writes encal.h there: the model
    paths["c_folder"].mkdir()
    paths["model_as_header"] = paths["c_folder"] / "encal.h"
    paths["model_as_header"].write_bytes(Path(paths["model"]).read_bytes())
    paths["study_folder"] = folder / "study_folder"  # study prune --out study_folder writes fig3_pruning.csv
    paths["study_folder"].mkdir()
    paths["study_input"] = paths["study_folder"] / "fig3_pruning.csv"
    paths["study_input"].write_text(good, encoding="utf-8")
    paths["page"] = folder / "page.html"  # report -o page.html writes page_figures/profile.png
    (folder / "page_figures").mkdir()
    paths["figure_input"] = folder / "page_figures" / "profile.png"
    paths["figure_input"].write_text(good, encoding="utf-8")
    rows = [line.split(",") for line in good.splitlines()[1:]]

    def comma(cell):
        return cell.replace(".", ",")

    texts = {
        "repeated_column": "reference_deg,encoder_deg,Encoder_Deg\n" + "".join(f"{r},{e},{e}\n" for r, e in rows),
        "repeated_extra_column": "reference_deg,encoder_deg,temp,temp\n" + "".join(f"{r},{e},20,21\n"
                                                                                 for r, e in rows),
        "repeated_spin_column": "time_s,encoder_deg,time_s\n0,1,0\n1,2,1\n",
        # A spreadsheet's exports where the decimal mark is a comma: quoted names, BOM, CRLF.
        "eu_semicolon": "\ufeff" + '"reference_deg";"encoder_deg"\r\n' + "".join(f"{comma(r)};{comma(e)}\r\n"
                                                                                for r, e in rows),
        "eu_tab_quoted": "\ufeff" + '"reference_deg"\t"encoder_deg"\r\n' + "".join(f"{comma(r)}\t{comma(e)}\r\n"
                                                                                 for r, e in rows),
        "eu_tab": "reference_deg\tencoder_deg\n" + "".join(f"{comma(r)}\t{comma(e)}\n" for r, e in rows),
        # One cell with a comma among decimal points: is the comma grouping digits (1,080 for 1080)?
        "eu_mixed": "reference_deg;encoder_deg\n" + "".join(f"{r};{comma(e) if i == 5 else e}\n"
                                                             for i, (r, e) in enumerate(rows)),
        "eu_grouped": "reference_deg\tencoder_deg\n" + "".join(f"{r}\t{'1,234.5' if i == 3 else e}\n"
                                                                for i, (r, e) in enumerate(rows)),
    }
    for key, text in texts.items():
        paths[key] = folder / f"{key}.csv"
        paths[key].write_text(text, encoding="utf-8", newline="")


_IMPORT_KINDS = (("moteus-compare",), ("moteus-cal",), ("klipper",), ("mechaduino",), ("moteus",), ("simplefoc",),
                 ("tinymovr", "--bits", "14"))

ISSUE25_CASES = [
    # 1. an output that is an input: refused (status 1) before any work, comparing files (links count)
    Case("fit-output-is-the-repeat", ("fit", "{train}", "--repeat", "{input_copy}", "-o", "{input_copy}",
                                      "--method", "spectral"), 1, ("-o", "input_copy.csv", "same file")),
    Case("fit-output-is-a-symbolic-link-to-the-input", ("fit", "{input_copy}", "-o", "{link_to_input}", "--method",
                                                        "lut"), 1,
         ("link_to_input.csv", "input_copy.csv", "same file")),
    Case("fit-output-is-a-hard-link-to-the-input", ("fit", "{input_copy}", "-o", "{hardlink_to_input}", "--method",
                                                    "lut"), 1, ("hardlink_to_input.csv", "same file")),
    *(Case(f"import-{kind[0]}-over-its-input", ("import", *kind[:1], "{input_copy}", "-o", "{input_copy}", *kind[1:]),
           1, ("-o", "input_copy.csv", "same file")) for kind in _IMPORT_KINDS),
    Case("import-over-a-link-to-its-input", ("import", "klipper", "{input_copy}", "-o", "{link_to_input}"), 1,
         ("same file",)),
    Case("report-model-is-a-test-file", ("report", "{train}", "{input_copy}", "-o", "{out}/r.html", "--model",
                                         "{input_copy}"), 1, ("--model", "input_copy.csv", "same file")),
    Case("report-model-is-the-calibration", ("report", "{input_copy}", "-o", "{out}/r.html", "--model",
                                             "{input_copy}"), 1, ("--model", "same file")),
    Case("report-model-is-the-page", ("report", "{train}", "-o", "{out}/r.html", "--model", "{out}/r.html"), 1,
         ("--model", "the output -o")),
    Case("report-figure-is-an-input", ("report", "{figure_input}", "-o", "{page}"), 1, ("profile.png", "same file")),
    Case("report-figures-folder-is-a-file", ("report", "{train}", "-o", "{out}/r.html", "--figures", "{afile}"), 1,
         ("--figures", "is a file")),
    Case("selfcal-stepper-csv-is-the-output", ("selfcal", "steps", "{train}", "{test}", "-o", "{out}/s.csv",
                                               "--stepper-csv", "{out}/s.csv"), 1, ("--stepper-csv", "same file")),
    Case("selfcal-stepper-csv-is-an-input", ("selfcal", "steps", "{train}", "{input_copy}", "-o", "{out}/s.csv",
                                             "--stepper-csv", "{input_copy}"), 1, ("--stepper-csv", "same file")),
    Case("selfcal-output-is-a-link-to-the-log", ("selfcal", "spin", "{input_copy}", "-o", "{link_to_input}"), 1,
         ("same file",)),
    Case("export-over-a-link-to-its-model", ("export", "{model_copy}", "--format", "moteus", "-o", "{link_to_model}"),
         1, ("link_to_model.json", "same file")),
    Case("export-c-header-is-the-model", ("export", "{model_as_header}", "--format", "c", "-o", "{c_folder}"), 1,
         ("encal.h", "same file")),
    Case("study-out-holds-the-input", ("study", "prune", "{study_input}", "--out", "{study_folder}", "--hidden", "3",
                                       "--epochs", "2"), 1, ("fig3_pruning.csv", "same file")),
    # an input given twice: `fit A --repeat A` took the noise from readings that are no repeats (1.5e-7 arcmin)
    Case("fit-repeat-is-the-calibration", ("fit", "{train}", "--repeat", "{train}", "-o", "{out}/m.json", "--method",
                                           "spectral"), 1, ("train.csv", "given twice")),
    Case("report-test-is-the-calibration", ("report", "{input_copy}", "{link_to_input}", "-o", "{out}/r.html"), 1,
         ("link_to_input.csv", "given twice")),
    Case("drift-one-file-twice", ("drift", "{train}", "{train}"), 1, ("given twice",)),
    # 2. every input and output path checked before any work
    Case("report-model-folder-missing", ("report", "{train}", "-o", "{out}/r.html", "--model", "{nodir}/m.json"), 1,
         ("--model", "does not exist")),
    Case("report-test-file-missing", ("report", "{train}", "{missing}", "-o", "{out}/r.html"), 1,
         ("missing.csv", "no such file")),
    Case("fit-repeat-missing", ("fit", "{train}", "--repeat", "{missing}", "-o", "{out}/m.json"), 1,
         ("missing.csv", "no such file")),
    Case("export-model-is-a-folder", ("export", "{out}", "--format", "table", "-o", "{out}/t.bin"), 1, ("folder",)),
    Case("drift-model-is-a-folder", ("drift", "{train}", "{test}", "--model", "{out}"), 1, ("folder",)),
    Case("study-test-missing", ("study", "prune", "{train}", "--test", "{missing}", "--hidden", "3"), 1,
         ("missing.csv",)),
    Case("import-input-is-a-folder", ("import", "klipper", "{out}", "-o", "{out}/k.csv"), 1, ("folder",)),
    Case("selfcal-output-folder-missing", ("selfcal", "spin", "{train}", "-o", "{nodir}/c.csv"), 1,
         ("does not exist",)),
    Case("evaluate-model-dev-zero", ("evaluate", "/dev/zero", "{test}"), 1, ("/dev/zero", "NUL")),
    Case("fit-output-is-a-device", ("fit", "{train}", "-o", "/dev/null", "--method", "lut"), 1,
         ("/dev/null", "not a regular file")),
    # 3. a column named twice; the reference and the encoder in one column
    *(Case(f"{command}-repeated-column", (command, *before, "{repeated_column}", *after), 1,
           ("repeated_column.csv", "line 1", "encoder_deg 2 times", "columns 2, 3"))
      for command, before, after in (("profile", (), ()), ("fit", (), ("-o", "{out}/m.json")),
                                     ("evaluate", ("{model}",), ()))),
    Case("profile-repeated-extra-column", ("profile", "{repeated_extra_column}"), 1, ("line 1", "temp 2 times")),
    Case("selfcal-spin-repeated-column", ("selfcal", "spin", "{repeated_spin_column}", "-o", "{out}/c.csv"), 1,
         ("line 1", "time_s 2 times")),
    Case("correct-repeated-column", ("correct", "{model}"), 1, ("line 1", "stdin", "encoder_deg 2 times"),
         stdin="encoder_deg,encoder_deg\n10,20\n", answers=0),
    Case("correct-repeated-column-after-comments", ("correct", "{model}"), 1, ("line 3", "columns 2, 3"),
         stdin='# run 1\n\n"t, s",encoder_deg,ENCODER_DEG\n1,10,20\n', answers=0),
    Case("profile-same-column-numbers", ("profile", "{train}", "--ref-col", "2", "--enc-col", "2"), 2),
    Case("fit-same-column-names", ("fit", "{train}", "-o", "{out}/m.json", "--ref-col", "Encoder_Deg",
                                   "--enc-col", "encoder_deg"), 2),
    Case("profile-same-column-by-name-and-number", ("profile", "{train}", "--ref-col", "2", "--enc-col",
                                                    "encoder_deg"), 1, ("both column 2",)),
    # 4. lines over 64 KiB refused (the answers before them written); CR line ends read as lines however long
    Case("correct-line-over-64-KiB", ("correct", "{constant_model}"), 1, ("line 2", "65536"),
         stdin="10\n" + "0" * 65535 + "25\n30\n", answers=1),
    Case("correct-line-of-64-KiB-accepted", ("correct", "{constant_model}"), 0,
         prints=("9.500000000000\n24.500000000000\n",), stdin="10\n" + "0" * 65534 + "25\n", answers=2),
    Case("correct-cr-only-over-64-KiB-accepted", ("correct", "{constant_model}"), 0, stdin="10\r" * 30000,
         answers=30000),
    # 5. a spreadsheet's exports: semicolons, tabs, decimal commas, quoted names, BOM and CRLF
    *(Case(f"{command}-{key.replace('_', '-')}-accepted", (command, *before, f"{{{key}}}", *after), 0, prints=prints,
           # "decimal_comma" has no error at all: the catalogue's model, applied to it, is said to make it worse
           warns=("can do more harm than none",) if (command, key) == ("evaluate", "decimal_comma") else ())
      for key in ("eu_semicolon", "eu_tab_quoted", "eu_tab", "semicolon", "decimal_comma")
      for command, before, after, prints in (("profile", (), (), ("180 points",)),
                                             ("fit", (), ("-o", f"{{scratch}}/{key}.json", "--method", "lut"),
                                              ("180 points",)),
                                             ("evaluate", ("{model}",), (), ("180 points",)))),
    Case("profile-eu-mixed-decimal-marks", ("profile", "{eu_mixed}"), 1, ("line 7", "decimal comma", "line 2")),
    Case("profile-eu-grouped-digits", ("profile", "{eu_grouped}"), 1, ("line 5", "'1,234.5'", "digit grouping")),
]
CASES += ISSUE25_CASES

# ---------------------------------------------------------------- issue 32: the production line (fleet, --serial)
ISSUE32_CASES = [
    Case("fleet-fit-bad-file-skipped", ("fleet", "fit", "{text_cell}", "{train}", "--store", "{scratch}/fleet.sqlite",
                                        "--jobs", "0"), 1, ("refused", "text_cell.csv", "line")),
    Case("fleet-fit-missing", ("fleet", "fit", "{missing}", "--store", "{out}/fleet.sqlite"), 1,
         ("no such file or folder",)),
    Case("fleet-fit-bad-grades", ("fleet", "fit", "{train}", "--store", "{out}/fleet.sqlite", "--grades", "A=fast"),
         1, ("--grades", "NAME=LIMIT")),
    Case("fleet-fit-store-is-a-model", ("fleet", "fit", "{train}", "--store", "{model}"), 1,
         ("cannot be used as a store",)),
    Case("fleet-fit-bad-jobs", ("fleet", "fit", "{train}", "--jobs", "-1"), 2),
    Case("fleet-no-subcommand", ("fleet",), 2),
    Case("fleet-fit-prior-missing", ("fleet", "fit", "{train}", "--store", "{out}/fleet.sqlite", "--prior-from",
                                     "{missing}"), 1, ("--prior-from", "no such file")),
    Case("fleet-fit-prior-with-auto", ("fleet", "fit", "{train}", "--prior-from", "{missing}", "--method", "auto"), 2),
    Case("fleet-report-missing-store", ("fleet", "report", "--store", "{missing}", "-o", "{out}/f.html"), 1,
         ("no such file",)),
    Case("fleet-report-no-output", ("fleet", "report", "--store", "{missing}"), 2),
    Case("correct-serial-without-store", ("correct", "--serial", "SN1"), 2),
    Case("export-serial-missing-store", ("export", "--serial", "SN1", "--store", "{missing}", "--format", "table",
                                         "-o", "{out}/t.bin"), 1, ("no such file",)),
    Case("export-model-and-serial", ("export", "{model}", "--serial", "SN1", "--store", "{missing}", "--format",
                                     "table", "-o", "{out}/t.bin"), 2),
]
CASES += ISSUE32_CASES


# ---------------------------------------------------------------- fleet8: the production line against known truth
def _make_fleet8_files(folder, paths):
    """Another program's SQLite database, which a store's reader must leave as it is (no tables, no WAL mode), and a
    store of one unit."""
    import sqlite3

    from encal.store import open_store

    paths["foreign_db"] = folder / "foreign.sqlite"
    with sqlite3.connect(paths["foreign_db"]) as connection:
        connection.execute("CREATE TABLE parts (id INTEGER)")
    connection.close()
    paths["fleet8_store"] = folder / "fleet8.sqlite"  # one unit, SN1: an output must never be written over it
    with open_store(paths["fleet8_store"]) as store:
        store.add("SN1", paths["model"].read_text(encoding="utf-8"))


FLEET8_CASES = [
    Case("fleet-report-foreign-database", ("fleet", "report", "--store", "{foreign_db}", "-o", "{out}/f.html"), 1,
         ("foreign.sqlite", "database of other tables (parts)", "not a calibration store")),
    Case("fleet-fit-into-foreign-database", ("fleet", "fit", "{train}", "--store", "{foreign_db}", "--jobs", "0"), 1,
         ("database of other tables (parts)",)),
    Case("fleet-fit-prior-from-foreign-database", ("fleet", "fit", "{train}", "--store", "{out}/fleet.sqlite",
                                                   "--prior-from", "{foreign_db}", "--jobs", "0"), 1,
         ("--prior-from", "database of other tables (parts)",)),
    Case("fleet-fit-prior-from-a-model-file", ("fleet", "fit", "{train}", "--store", "{out}/fleet.sqlite",
                                               "--prior-from", "{model}", "--jobs", "0"), 1,
         ("--prior-from", "cannot be used as a store")),
    Case("export-serial-foreign-database", ("export", "--serial", "SN1", "--store", "{foreign_db}", "--format",
                                            "table", "-o", "{out}/t.bin"), 1, ("database of other tables",)),
    Case("fleet-fit-prior-from-one-unit", ("fleet", "fit", "{train}", "--store", "{out}/fleet.sqlite", "--prior-from",
                                           "{fleet8_store}", "--jobs", "0"), 1,
         ("--prior-from", "fleet8.sqlite: a fleet prior needs 5 or more units", "got 1")),
    Case("fleet-report-output-is-the-store", ("fleet", "report", "--store", "{fleet8_store}", "-o",
                                              "{fleet8_store}"), 1, ("is the same file as the calibration store",)),
    Case("export-serial-output-is-the-store", ("export", "--serial", "SN1", "--store", "{fleet8_store}", "--format",
                                               "table", "--bits", "12", "-o", "{fleet8_store}"), 1,
         ("is the same file as the calibration store",)),
]
CASES += FLEET8_CASES


# ---------------------------------------------------------------- arc8: arcs and two-encoder joints against truth
def _make_arc8_files(folder, paths):
    """A two-encoder log of a ratio of 1, one of 16-bit counts as degrees, and two calibrations over arcs apart."""
    output = np.arange(0.0, 725.0, 5.0)
    paths["arc8_same_speed"] = folder / "arc8_same_speed.csv"  # every order confounded: profiles split by the prior
    paths["arc8_same_speed"].write_text("motor_deg,output_deg\n" + "".join(
        f"{o + 0.1 * np.sin(np.radians(o)):.6f},{o % 360:.6f}\n" for o in output), encoding="utf-8")
    paths["arc8_counts"] = folder / "arc8_counts.csv"  # 16-bit counts: each wrap's step looked like 75 degrees
    paths["arc8_counts"].write_text("motor_deg,output_deg\n" + "".join(
        f"{k * 80 % 65536},{k * 80 // 6 % 65536}\n" for k in range(900)), encoding="utf-8")
    for name, start in (("arc8_arc_a", 30.0), ("arc8_arc_b", 200.0)):  # no common position
        paths[name] = folder / f"{name}.csv"
        reference = np.arange(start, start + 60.0, 0.5)
        paths[name].write_text(_csv_text(reference, reference + _profile_arcmin(reference) / 60.0), encoding="utf-8")


ARC8_CASES = [
    Case("selfcal-dual-ratio-one", ("selfcal", "dual", "{arc8_same_speed}", "--ratio", "1", "--motor-cal",
                                    "{out}/m.csv", "--output-cal", "{out}/o.csv"), 1,
         ("arc8_same_speed.csv", "every motor order up to 30 meets an order of the other shaft")),
    Case("selfcal-dual-counts-as-degrees", ("selfcal", "dual", "{arc8_counts}", "--ratio", "6", "--motor-cal",
                                            "{out}/m.csv", "--output-cal", "{out}/o.csv"), 1,
         ("arc8_counts.csv", "expected degrees", "count x 360 / 2^B")),
    Case("drift-arcs-apart", ("drift", "{arc8_arc_a}", "{arc8_arc_b}"), 1,
         ("arc8_arc_b.csv", "fewer than two readings of each lie where both have readings")),
]
CASES += ARC8_CASES

# ---------------------------------------------------------------- issue 25: plausibility

def _make_plausibility_files(folder, paths):
    """The inputs of the plausibility cases (issue 25): wrong units, another encoder, sweeps, a long spin."""
    from encal.selfcal.synthetic import draw_magnetic_encoder, make_motor, simulate_spin
    from encal.selfcal.spin import SpinLog
    from encal.selfcal.spin_log import write_spin_log

    encoder = GRID_TRAIN + _profile_arcmin(GRID_TRAIN) / 60.0
    theta = np.radians(GRID_TRAIN)
    rng = np.random.default_rng(25)
    sweep = np.linspace(0.0, 3 * 360.0, 30_000, endpoint=False) + 0.3  # 3 turns, a 12-bit reference repeats codes
    turns = np.arange(0.0, 720.0, 0.5)  # two turns, noise-free
    texts = {
        "u16": _csv_text(GRID_TRAIN, np.round(encoder / 360.0 * 2**16) % 2**16),
        "counts14": _csv_text(GRID_TRAIN, np.round(encoder / 360.0 * 2**14) % 2**14),
        "enc_radians": _csv_text(GRID_TRAIN, np.radians(encoder)),
        "other_encoder": _csv_text(GRID_TRAIN, GRID_TRAIN + (3 * np.sin(2 * theta + 1) + 8 * np.cos(theta + 2)) / 60),
        "moved": _csv_text(GRID_TRAIN - 79.2, encoder),  # the reference's zero moved by 79.2 deg
        "quantised_sweep": _csv_text(np.round(sweep / (360.0 / 2**12)) * (360.0 / 2**12),
                                     sweep + (_profile_arcmin(sweep) + rng.normal(0.0, 0.05, sweep.size)) / 60.0),
        "two_turns": _csv_text(turns, turns + _profile_arcmin(turns) / 60.0),
    }
    for key, text in texts.items():
        paths[key] = folder / f"{key}.csv"
        paths[key].write_text(text, encoding="utf-8", newline="")
    paths["moved_model"] = encal.fit(encal.read_calibration(paths["moved"]), method="fourier").save(
        folder / "moved_model.json", reproducible=True)
    motor, magnet = make_motor(7, 12, 5), draw_magnetic_encoder(11)
    runs = [simulate_spin(motor, magnet, speed, revolutions=48, sample_rate_hz=600.0, rng=seed)
            for speed, seed in ((4.0, 1), (8.0, 2))]
    paths["long_spin"] = folder / "long_spin.csv"
    write_spin_log(paths["long_spin"], [SpinLog(run.time_s, run.encoder_deg) for run in runs])


_WORSE = ("the correction makes the errors larger", "arcmin without it")

PLAUSIBILITY_CASES = [
    # a repeat that is the calibration itself carries no noise; an identical copy is ignored with a warning
    Case("fit-repeat-is-itself", ("fit", "{train}", "--repeat", "{train}", "-o", "{out}/m.json", "--method",
                                  "spectral"), 1, ("is the same file as", "a second pass")),
    Case("fit-repeat-identical-copy", ("fit", "{train}", "--repeat", "{input_copy}", "-o", "{scratch}/copy.json",
                                       "--method", "spectral"), 0, warns=("identical", "ignored")),
    # an encoder that does not turn once per reference turn: the unit that fits is named
    Case("profile-counts-of-other-bits", ("profile", "{u16}", "--enc-unit", "counts:14"), 1,
         ("u16.csv", "does not turn once per turn", "--enc-unit counts:16")),
    Case("fit-counts-as-degrees", ("fit", "{counts14}", "-o", "{out}/m.json", "--method", "fourier"), 1,
         ("counts14.csv", "--enc-unit counts:14")),
    Case("profile-encoder-in-radians", ("profile", "{enc_radians}"), 1, ("--enc-unit rad",),
         warns=("radians", "--unit rad")),
    # a correction worse than none: said on stderr and in the verdict; the status stays 0 (a valid measurement)
    Case("evaluate-model-of-another-encoder", ("evaluate", "{model}", "{other_encoder}"), 0, warns=_WORSE,
         prints=("verdict: the correction makes the errors larger",)),
    Case("drift-another-encoder", ("drift", "{train}", "{other_encoder}"), 0, warns=_WORSE,
         prints=("verdict: the correction makes the errors larger on other_encoder.csv",)),
    Case("report-another-encoder", ("report", "{train}", "{other_encoder}", "-o", "{scratch}/other.html", "--method",
                                    "fourier", "--no-uncertainty", "--no-comparison"), 0, warns=_WORSE),
    # the zero offset a correction leaves is explained
    Case("evaluate-zero-moved-explained", ("evaluate", "{moved_model}", "{train}"), 0,
         prints=("zero offset after the correction -4752.00 arcmin", "not an error of the correction")),
    # a sweep over several turns is read as one, and a noise-free one raises no misread warning
    Case("profile-quantised-sweep-accepted", ("profile", "{quantised_sweep}"), 0, prints=("30000 points",)),
    Case("profile-noise-free-two-turns", ("profile", "{two_turns}"), 0, prints=("1440 points",)),
    # a spin log of 48 revolutions per speed
    Case("selfcal-spin-48-revolutions", ("selfcal", "spin", "{long_spin}", "--pole-pairs", "7", "-o",
                                         "{scratch}/spin.csv"), 0),
]
CASES += PLAUSIBILITY_CASES

# The fresh outside attack after issue 25 (a report, 545 cases): a periodic model fitted on an arc was wrong
# inside its own range with exit 0 (spectral: 5e8 arcmin at a midpoint; fourier: 28 of 37 arcmin left).
ATTACK_CASES = [
    *(Case(f"fit-{method}-on-an-arc", ("fit", "{arc_only}", "-o", "{out}/m.json", "--method", method, "--allow-gaps"),
           1, ("covers only an arc", f"--method {method} fits a periodic model", "--method lut"))
      for method in ("spectral", "fourier", "hybrid", "ann")),
    Case("fit-lut-on-an-arc-accepted", ("fit", "{arc_only}", "-o", "{scratch}/arc_lut.json", "--method", "lut"), 0),
]
CASES += ATTACK_CASES


# issue 31 (inplace): calibrations over an arc, a reading outside the range, two encoders of one joint
ISSUE31_CASES = [
    Case("fit-arc-accepted", ("fit", "{arc}", "-o", "{scratch}/arc.json"), 0, prints=("arc model", "holds there only")),
    Case("profile-arc-no-harmonics", ("profile", "{arc}"), 0, prints=("defined over the full turn only",)),
    Case("correct-outside-the-arc", ("correct", "{arc_model}"), 1, ("200 deg", "outside the calibrated range",
                                                                   "--outside"), stdin="200\n"),
    Case("correct-outside-pass", ("correct", "{arc_model}", "--outside", "pass"), 0, answers=1, stdin="200\n"),
    Case("export-arc-without-rule", ("export", "{arc_model}", "--format", "table", "--bits", "12", "-o",
                                     "{out}/t.bin"), 1, ("calibrated over", "--outside clamp")),
    Case("export-moteus-arc-without-rule", ("export", "{arc_model}", "--format", "moteus", "--bits", "14", "-o",
                                            "{out}/m.txt"), 1, ("calibrated over", "--outside")),
    Case("export-outside-full-turn", ("export", "{model}", "--format", "table", "--outside", "clamp", "-o",
                                      "{out}/t.bin"), 2),
    Case("selfcal-dual-not-a-log", ("selfcal", "dual", "{train}", "--ratio", "6", "--motor-cal", "{out}/m.csv",
                                    "--output-cal", "{out}/o.csv"), 1, ("motor_deg", "output_deg")),
    Case("selfcal-dual-no-ratio", ("selfcal", "dual", "{train}", "--motor-cal", "{out}/m.csv",
                                   "--output-cal", "{out}/o.csv"), 2),
]
CASES += ISSUE31_CASES

# task klipper-dir: --step-direction (Klipper only: which way the stepper's positive steps turn the reference)
STEP_DIRECTION_CASES = [
    Case("export-klipper-step-direction-0", ("export", "{model}", "--format", "klipper", "--step-zero", "0",
                                             "--step-direction", "0", "-o", "{out}/k.cfg"), 2),
    Case("export-klipper-step-direction-word", ("export", "{model}", "--format", "klipper", "--step-zero", "0",
                                                "--step-direction", "reversed", "-o", "{out}/k.cfg"), 2),
    Case("export-klipper-step-direction-without-step-zero", ("export", "{model}", "--format", "klipper",
                                                             "--step-direction", "-1", "-o", "{out}/k.cfg"), 2),
    Case("export-mechaduino-step-direction", ("export", "{model}", "--format", "mechaduino", "--bits", "14",
                                              "--step-zero", "0", "--step-direction", "-1", "-o", "{out}/m.c"), 2),
    Case("export-moteus-step-direction", ("export", "{model}", "--format", "moteus", "--step-direction", "-1",
                                          "-o", "{out}/m.cfg"), 2),
    Case("export-klipper-without-step-direction", ("export", "{model}", "--format", "klipper", "--step-zero", "0.9",
                                                   "-o", "{out}/k.cfg"), 2),
    Case("export-klipper-step-direction-accepted", ("export", "{model}", "--format", "klipper", "--step-zero", "0.9",
                                                    "--step-direction", "-1", "-o", "{scratch}/k_against.cfg"), 0,
         prints=("round trip", "--step-direction -1")),
]
CASES += STEP_DIRECTION_CASES

# ---------------------------------------------------------------- task fuzz5: mutation fuzzing of the input files


def _joint_rows(outputs_deg):
    """Rows ``motor_deg,output_deg`` of a 6:1 joint at these output angles, each encoder with a small error."""
    rows = []
    for output in outputs_deg:
        motor = 6.0 * output
        rows.append(f"{motor + 0.2 * np.sin(np.radians(3 * motor)):.6f},"
                    f"{output + 0.05 * np.sin(np.radians(output)):.6f}\n")
    return rows


def _make_fuzz5_files(folder, paths):
    """The reproducers the mutation fuzzer of task fuzz5 found, minimised."""
    tiny = ["0"] * 64
    tiny[17] = "2147483647"  # 2^31 - 1 ticks of a 13-bit sensor: 262,144 turns
    texts = {
        # a float entry beyond float32 (C reads 1e308f as infinity): was a message naming neither file nor entry
        "fuzz5_sfoc_huge.h": "float calibrationLut[4] = {0.001f, 1e308f, 0.0f, -0.001f};\n",
        # 256 radians (a wrong unit, a flipped byte) was read as a correction of 14,668 degrees
        "fuzz5_sfoc_256.h": "float calibrationLut[4] = {0.001f, 256f, 0.0f, -0.001f};\n",
        "fuzz5_tiny_huge.h": "int32_t rec_table[64] = {" + ", ".join(tiny) + "};\n",
        "fuzz5_tiny_63.h": "int32_t rec_table[] = {" + ", ".join(["0"] * 63) + "};\n",
        "fuzz5_tiny_1e308.h": "int32_t rec_table[64] = {1e308, " + ", ".join(["0"] * 63) + "};\n",
        "fuzz5_tiny_half.h": "int32_t rec_table[64] = {" + ", ".join(["0"] * 63) + ", 1.5};\n",
        "fuzz5_moteus_scale.cfg": "".join(f"motor_position.sources.0.compensation_table.{i} {i % 7 - 3}\n"
                                          for i in range(256)) + "motor_position.sources.0.compensation_scale 1e308\n",
        # one glitched angle of 6e23 degrees in a log was read (the written calibration 180 arcmin uncertain)
        "fuzz5_sweep.csv": "electrical_deg,encoder_deg\n0,0\n6.02e23,1\n",
        "fuzz5_dual.csv": "motor_deg,output_deg\n0,0\n1,6.02e23\n",
        "fuzz5_spin.csv": "time_s,encoder_deg\n0,0\n0.1,1e12\n",
        # a table whose commas became '|' is one element: the message quoted all of it (10 MB for a long line)
        "fuzz5_sfoc_long.h": "float calibrationLut[2] = {0.1f| " + "0.2f| " * 100 + "0.3f};\n",
        "fuzz5_klipper_long.cfg": "[angle s]\ncalibrate:\n    1.0| " + "2.0| " * 100 + "3.0\n",
        # the output turned 150 degrees: the message did not say in which file
        "fuzz5_dual_short.csv": "motor_deg,output_deg\n" + "".join(f"{6 * o},{o}\n" for o in range(151)),
        # a 6:1 joint log: --ratio 12 doubled the motor's profile, exit 0; rows out of time order were fitted (a motor
        # profile of 0 +- 1e-147 arcmin)
        "fuzz5_joint.csv": "motor_deg,output_deg\n" + "".join(_joint_rows(range(400))),
        "fuzz5_joint_shuffled.csv": "motor_deg,output_deg\n" + "".join(_joint_rows([*range(10), 200, *range(11, 200),
                                                                                      10, *range(201, 400)])),
        # one row's epoch label mistyped: drift gave that 'epoch' of one point a verdict, exit 0
        "fuzz5_epochs.csv": "reference_deg,encoder_deg,epoch\n" + "".join(
            f"{r!r},{float(r + _profile_arcmin(r) / 60.0)!r},{'Epoch1' if i == 50 else 'epoch1'}\n"
            for i, r in enumerate(GRID_TRAIN.tolist())),
        # a 'conf enumerate' dump without the source's sign line was exported for sign 1 (mirrored on a -1 source)
        "fuzz5_dump_no_sign.txt": "motor_position.sources.0.cpr 16384\nmotor_position.sources.0.offset 1000\n",
        "fuzz5_dump_no_offset.txt": "motor_position.sources.0.cpr 16384\nmotor_position.sources.0.sign -1\n",
        "fuzz5_dump_offset_1e300.txt": "motor_position.sources.0.sign -1\nmotor_position.sources.0.offset 1e300\n",
        # two resolutions declared: the first was taken silently (a 12-bit LSB on 16-bit readings)
        "fuzz5_two_bits.csv": "# resolution_bits: 12\n# resolution_bits: 16\n" + Path(paths["train"]).read_text(),
        # -1e308 revolutions is -inf degrees: the message named no line
        "fuzz5_compare.txt": "".join(f"{i / 20} {-1e308 if i == 3 else i / 20}\n" for i in range(20)),
        # a lookup[] angle of 6.02e23 degrees was written to the calibration, wrapped into a turn
        "fuzz5_mechaduino.h": "const float lookup[16384] = {\n" + ", ".join(
            ["6.02e23" if i == 5 else f"{i * 360 / 16384:.3f}" for i in range(16384)]) + "\n};\n",
    }
    for name, text in texts.items():
        paths[name.replace(".", "_")] = folder / name
        paths[name.replace(".", "_")].write_text(text, encoding="utf-8")


FUZZ5_CASES = [
    Case("import-simplefoc-beyond-float32", ("import", "simplefoc", "{fuzz5_sfoc_huge_h}", "-o", "{out}/s.json",
                                             "--firmware-version", "1.0.9"), 1,
         ("fuzz5_sfoc_huge.h", "element 1 of calibrationLut[]", "half a turn")),
    Case("import-simplefoc-256-radians", ("import", "simplefoc", "{fuzz5_sfoc_256_h}", "-o", "{out}/s.json",
                                          "--firmware-version", "1.0.8"), 1,
         ("fuzz5_sfoc_256.h", "element 1 of calibrationLut[] (256)", "half a turn")),
    Case("import-tinymovr-int32-max", ("import", "tinymovr", "{fuzz5_tiny_huge_h}", "-o", "{out}/t.json", "--bits",
                                       "13"), 1, ("fuzz5_tiny_huge.h", "element 17 of rec_table[]", "half a turn")),
    Case("import-tinymovr-63-entries", ("import", "tinymovr", "{fuzz5_tiny_63_h}", "-o", "{out}/t.json", "--bits",
                                        "13"), 1, ("fuzz5_tiny_63.h", "64 rec_table entries, got 63")),
    Case("import-tinymovr-1e308", ("import", "tinymovr", "{fuzz5_tiny_1e308_h}", "-o", "{out}/t.json", "--bits",
                                   "13"), 1, ("fuzz5_tiny_1e308.h", "element 0 of rec_table[]", "half a turn")),
    Case("import-tinymovr-fraction", ("import", "tinymovr", "{fuzz5_tiny_half_h}", "-o", "{out}/t.json", "--bits",
                                      "13"), 1, ("fuzz5_tiny_half.h", "element 63 of rec_table[] is 1.5", "whole")),
    Case("import-moteus-scale-1e308", ("import", "moteus", "{fuzz5_moteus_scale_cfg}", "-o", "{out}/m.json"), 1,
         ("fuzz5_moteus_scale.cfg", "compensation_table.0 on line 1", "compensation_scale 1e+308", "half a turn")),
    Case("selfcal-sweep-angle-6e23", ("selfcal", "sweep", "{fuzz5_sweep_csv}", "--pole-pairs", "7", "-o",
                                      "{out}/c.csv"), 1, ("fuzz5_sweep.csv", "line 3, column 1", "within +-1e+09")),
    Case("selfcal-dual-angle-6e23", ("selfcal", "dual", "{fuzz5_dual_csv}", "--ratio", "6", "--motor-cal",
                                     "{out}/m.csv", "--output-cal", "{out}/o.csv"), 1,
         ("fuzz5_dual.csv", "line 3, column 2", "within +-1e+09")),
    Case("import-simplefoc-long-element", ("import", "simplefoc", "{fuzz5_sfoc_long_h}", "-o", "{out}/s.json",
                                           "--firmware-version", "1.0.9"), 1,
         ("fuzz5_sfoc_long.h", "element 0", "| 0.2f| 0...'")),
    Case("import-klipper-long-item", ("import", "klipper", "{fuzz5_klipper_long_cfg}", "-o", "{out}/k.csv"), 1,
         ("fuzz5_klipper_long.cfg", "line 3", "| 2.0| 2.0| '")),
    Case("selfcal-dual-less-than-a-turn", ("selfcal", "dual", "{fuzz5_dual_short_csv}", "--ratio", "6", "--motor-cal",
                                           "{out}/m.csv", "--output-cal", "{out}/o.csv"), 1,
         ("fuzz5_dual_short.csv", "turned 150 deg", "at least one full turn")),
    Case("export-moteus-conf-without-sign", ("export", "{model}", "--format", "moteus", "-o", "{out}/m.cfg", "--conf",
                                             "{fuzz5_dump_no_sign_txt}"), 1,
         ("fuzz5_dump_no_sign.txt", "no motor_position.sources.0.sign line")),
    Case("export-moteus-conf-without-offset", ("export", "{model}", "--format", "moteus", "-o", "{out}/m.cfg",
                                               "--conf", "{fuzz5_dump_no_offset_txt}"), 1,
         ("fuzz5_dump_no_offset.txt", "no motor_position.sources.0.offset line")),
    Case("export-moteus-conf-offset-1e300", ("export", "{model}", "--format", "moteus", "-o", "{out}/m.cfg",
                                             "--conf", "{fuzz5_dump_offset_1e300_txt}"), 1,
         ("fuzz5_dump_offset_1e300.txt", "line 2", "offset is '1e300'")),
    Case("profile-two-resolutions", ("profile", "{fuzz5_two_bits_csv}"), 1,
         ("fuzz5_two_bits.csv", "line 2", "resolution_bits is 16 but line 1 says 12")),
    Case("import-moteus-compare-1e308", ("import", "moteus-compare", "{fuzz5_compare_txt}", "-o", "{out}/c.csv"), 1,
         ("fuzz5_compare.txt", "line 4, column 2", "-1e+308")),
    Case("import-mechaduino-6e23", ("import", "mechaduino", "{fuzz5_mechaduino_h}", "-o", "{out}/c.csv"), 1,
         ("fuzz5_mechaduino.h", "element 5 of lookup[]", "within +-1e+09")),
    Case("selfcal-dual-wrong-ratio", ("selfcal", "dual", "{fuzz5_joint_csv}", "--ratio", "12", "--motor-cal",
                                      "{out}/m.csv", "--output-cal", "{out}/o.csv"), 1,
         ("fuzz5_joint.csv", "the gear ratio is 12", "is it --ratio 6?")),
    Case("selfcal-dual-right-ratio", ("selfcal", "dual", "{fuzz5_joint_csv}", "--ratio", "6", "--motor-cal",
                                      "{scratch}/fuzz5_m.csv", "--output-cal", "{scratch}/fuzz5_o.csv"), 0),
    Case("selfcal-dual-out-of-order", ("selfcal", "dual", "{fuzz5_joint_shuffled_csv}", "--ratio", "6", "--motor-cal",
                                       "{out}/m.csv", "--output-cal", "{out}/o.csv"), 1,
         ("fuzz5_joint_shuffled.csv", "between readings 10 and 11", "at most 90 deg")),
    Case("drift-epoch-of-one-point", ("drift", "{fuzz5_epochs_csv}"), 1,
         ("fuzz5_epochs.csv", "epoch Epoch1 has 1 calibration point", "at least 8 in each epoch")),
    Case("report-epoch-of-one-point", ("report", "{fuzz5_epochs_csv}", "-o", "{out}/r.html", "--no-uncertainty"), 1,
         ("fuzz5_epochs.csv", "epoch Epoch1 has 1 calibration point")),
    Case("selfcal-spin-angle-1e12", ("selfcal", "spin", "{fuzz5_spin_csv}", "-o", "{out}/c.csv"), 1,
         ("fuzz5_spin.csv", "line 3, column 2", "within +-1e+09")),
]
CASES += FUZZ5_CASES


# ------------------------------------------------- strict6: number cells and angle bounds in every reader
def _make_strict6_files(folder, paths):
    """Numbers only Python reads ('1_0' is 10; a full-width or Arabic-Indic digit is its digit), each read with exit
    0 before strict6, and readings of ``encal correct`` beyond +-1e9 degrees (1e308 gave 295.99)."""
    good = Path(paths["train"]).read_text(encoding="utf-8")
    octal = ["0"] * 64
    octal[3] = "010"  # C reads 8, float() 10
    lookup = [f"{i * 360 / 16384:.3f}" for i in range(16384)]
    lookup[7] = "０.154"  # a full-width zero
    table = [f"motor_position.sources.0.compensation_table.{i} {'1_0' if i == 5 else i % 7 - 3}\n" for i in range(256)]
    texts = {
        "strict6_underscore.csv": _edit_cell(good, 5, 0, "1_0.0"),
        "strict6_fullwidth.csv": _edit_cell(good, 10, 1, "\uff120.01"),
        "strict6_arabic.csv": _edit_cell(good, 6, 0, "\u0661\u0662"),
        "strict6_spin.csv": "time_s,encoder_deg\n0,0\n0.1,1_0\n",
        "strict6_sweep.csv": "electrical_deg,encoder_deg\n0,0\n\u0661\u0662,1\n",
        "strict6_dual.csv": "motor_deg,output_deg\n0,0\n1_0,1\n",
        "strict6_capture.log": "CAL start\n1 0 5\n1 1_024 10\n2 0 5\nCAL done\n",
        "strict6_klipper.cfg": "[angle s]\ncalibrate:\n    1.0, 1_0.0, 3.0\n",
        "strict6_sfoc.h": "float calibrationLut[4] = {0.001f, 1_0.0f, 0.0f, -0.001f};\n",
        "strict6_tiny_octal.h": "int32_t rec_table[64] = {" + ", ".join(octal) + "};\n",
        "strict6_mechaduino.h": "const float lookup[16384] = {\n" + ", ".join(lookup) + "\n};\n",
        "strict6_moteus.cfg": "".join(table) + "motor_position.sources.0.compensation_scale 0.001\n",
        "strict6_compare.txt": "".join(f"{i / 20} {'0.0_5' if i == 1 else i / 20}\n" for i in range(20)),
        "strict6_dump.txt": "motor_position.sources.0.cpr 16384\nmotor_position.sources.0.offset 1_000\n"
                            "motor_position.sources.0.sign -1\n",
        "strict6_angles.txt": "10\n20\n1e308\n30\n",
    }
    for name, text in texts.items():
        paths[name.replace(".", "_")] = folder / name
        paths[name.replace(".", "_")].write_text(text, encoding="utf-8")


STRICT6_CASES = [
    Case("strict6-profile-underscore", ("profile", "{strict6_underscore_csv}"), 1,
         ("strict6_underscore.csv", "line 7, column 1", "'1_0.0'", "underscore", "'10.0'")),
    Case("strict6-fit-fullwidth-digit", ("fit", "{strict6_fullwidth_csv}", "-o", "{out}/m.json"), 1,
         ("strict6_fullwidth.csv", "line 12, column 2", "U+FF12", "'20.01'")),
    Case("strict6-evaluate-arabic-indic-digits", ("evaluate", "{model}", "{strict6_arabic_csv}"), 1,
         ("strict6_arabic.csv", "line 8, column 1", "U+0661", "'12'")),
    Case("strict6-correct-1e308-stdin", ("correct", "{model}", "-"), 1, ("line 1 of stdin", "1e308", "+-1e+09"),
         stdin="1e308\n12\n", answers=0),
    Case("strict6-correct-beyond-1e9", ("correct", "{model}", "-"), 1, ("line 2 of stdin", "+-1e+09"),
         stdin="12\n-1000000001\n", answers=1),
    Case("strict6-correct-1e9-accepted", ("correct", "{model}", "-"), 0, stdin="1e9\n-1000000000\n", answers=2),
    Case("strict6-correct-1e308-file", ("correct", "{model}", "{strict6_angles_txt}"), 1,
         ("line 3 of", "strict6_angles.txt", "+-1e+09"), answers=2),
    Case("strict6-correct-1e308-skip-bad", ("correct", "{model}", "-", "--skip-bad"), 0, prints=("nan",),
         stdin="1e308\n12\n", answers=2),
    Case("strict6-correct-1e308-csv-column", ("correct", "{model}", "-"), 1, ("line 3 of stdin", "+-1e+09"),
         stdin="encoder_deg,x\n10,1\n1e308,2\n", answers=1),
    Case("strict6-correct-underscore", ("correct", "{model}", "-"), 1, ("line 2 of stdin", "'1_0'", "underscore"),
         stdin="12\n1_0\n", answers=1),
    Case("strict6-correct-fullwidth-digit", ("correct", "{model}", "-"), 1, ("line 1 of stdin", "U+FF11"),
         stdin="\uff112\n", answers=0),
    Case("strict6-selfcal-spin-underscore", ("selfcal", "spin", "{strict6_spin_csv}", "-o", "{out}/c.csv"), 1,
         ("strict6_spin.csv", "line 3, column 2", "underscore")),
    Case("strict6-selfcal-sweep-arabic-indic", ("selfcal", "sweep", "{strict6_sweep_csv}", "--pole-pairs", "7", "-o",
                                                "{out}/c.csv"), 1, ("strict6_sweep.csv", "line 3, column 1", "U+0661")),
    Case("strict6-selfcal-dual-underscore", ("selfcal", "dual", "{strict6_dual_csv}", "--ratio", "6", "--motor-cal",
                                             "{out}/m.csv", "--output-cal", "{out}/o.csv"), 1,
         ("strict6_dual.csv", "line 3, column 1", "underscore")),
    Case("strict6-import-moteus-cal-underscore", ("import", "moteus-cal", "{strict6_capture_log}", "-o", "{out}/c.csv"),
         1, ("strict6_capture.log", "line 3", "phase is '1_024'", "underscore")),
    Case("strict6-import-klipper-underscore", ("import", "klipper", "{strict6_klipper_cfg}", "-o", "{out}/k.csv"), 1,
         ("strict6_klipper.cfg", "line 3", "'1_0.0'", "underscore")),
    Case("strict6-import-simplefoc-underscore", ("import", "simplefoc", "{strict6_sfoc_h}", "-o", "{out}/s.json",
                                                 "--firmware-version", "1.0.9"), 1,
         ("strict6_sfoc.h", "element 1 of calibrationLut[]", "underscore")),
    Case("strict6-import-tinymovr-octal", ("import", "tinymovr", "{strict6_tiny_octal_h}", "-o", "{out}/t.json",
                                           "--bits", "13"), 1, ("strict6_tiny_octal.h", "element 3 of rec_table[]",
                                                                "octal")),
    Case("strict6-import-mechaduino-fullwidth", ("import", "mechaduino", "{strict6_mechaduino_h}", "-o",
                                                 "{out}/c.csv"), 1,
         ("strict6_mechaduino.h", "element 7 of lookup[]", "U+FF10")),
    Case("strict6-import-moteus-underscore", ("import", "moteus", "{strict6_moteus_cfg}", "-o", "{out}/m.json"), 1,
         ("strict6_moteus.cfg", "line 6", "'1_0'", "underscore")),
    Case("strict6-import-moteus-compare-underscore", ("import", "moteus-compare", "{strict6_compare_txt}", "-o",
                                                      "{out}/c.csv"), 1,
         ("strict6_compare.txt", "line 2, column 2", "underscore")),
    Case("strict6-export-moteus-conf-underscore", ("export", "{model}", "--format", "moteus", "-o", "{out}/m.cfg",
                                                   "--conf", "{strict6_dump_txt}"), 1,
         ("strict6_dump.txt", "line 2", "'1_000'", "underscore")),
    Case("strict6-fit-noise-underscore", ("fit", "{train}", "-o", "{out}/m.json", "--noise", "1_0"), 2),
    Case("strict6-export-bits-fullwidth", ("export", "{model}", "--format", "table", "-o", "{out}/t.csv", "--bits",
                                           "\uff11\uff14"), 2),
    Case("strict6-export-tolerance-underscore", ("export", "{model}", "--format", "c", "--target", "cortex-m4f", "-o",
                                                 "{out}/t.c", "--tolerance", "0_5"), 2),
    Case("strict6-drift-tolerance-underscore", ("drift", "{train}", "{train}", "--tolerance", "1_0"), 2),
    Case("strict6-fit-budget-fullwidth", ("fit", "{train}", "-o", "{out}/m.json", "--budget", "\uff14KiB"), 2),
    Case("strict6-fit-orders-underscore", ("fit", "{train}", "-o", "{out}/m.json", "--method", "fourier", "--orders",
                                           "1,1_6"), 2),  # was orders 1 and 16
    Case("strict6-source-date-epoch-underscore", ("profile", "{train}"), 1, ("SOURCE_DATE_EPOCH", "'86_400'"),
         env=(("SOURCE_DATE_EPOCH", "86_400"),)),
    Case("strict6-study-hidden-underscore", ("study", "sweep", "{train}", "--hidden", "1_0", "--epochs", "2"), 1,
         ("--hidden", "'1_0'")),
]
CASES += STRICT6_CASES


# ---------------------------------------------------------------- store6: stores of an older or a newer layout


def _make_store6_files(paths):
    """Two stores in the scratch folder (opening converts or touches them, so they are no checked input): one of
    layout 1 holding SN-Müller's older calibration under the composed spelling and its newer under the decomposed
    (NFD) one, and one of a newer layout than this encal reads."""
    import sqlite3
    import unicodedata

    from encal.store import open_store
    from tests.store.old_layout import write_layout_1_store

    model_json = Path(paths["model"]).read_text(encoding="utf-8")
    # the older record's model is no model file: the export succeeds only when it takes the newer, decomposed one
    write_layout_1_store(str(Path(paths["scratch"]) / "store6_old.sqlite"), [
        {"serial": unicodedata.normalize(form, "SN-Müller"), "epoch": 1, "model_json": text}
        for form, text in (("NFC", "{}"), ("NFD", model_json))])
    newer = Path(paths["scratch"]) / "store6_newer.sqlite"
    with open_store(newer) as store:
        store.add("SN1", model_json)
    with sqlite3.connect(newer) as connection:
        connection.execute("UPDATE encal_store SET value = '99' WHERE key = 'schema_version'")
    connection.close()


STORE6_CASES = [
    # a store of layout 1 is converted when opened: the unit's two spellings are one unit, its latest model found
    Case("export-serial-decomposed-in-an-old-store", ("export", "--serial", "SN-Müller", "--store",
                                                      "{scratch}/store6_old.sqlite", "--format", "table", "--bits",
                                                      "12", "-o", "{scratch}/store6.bin"), 0),
    Case("export-serial-store-of-a-newer-layout", ("export", "--serial", "SN1", "--store",
                                                   "{scratch}/store6_newer.sqlite", "--format", "table", "--bits",
                                                   "12", "-o", "{out}/t.bin"), 1,
         ("store6_newer.sqlite", "written by a newer encal (layout 99", "upgrade encal")),
]
CASES += STORE6_CASES


# ---------------------------------------------------------------- fuzz6: this session's surfaces, mutated
def _make_fuzz6_files(folder, paths):
    """A bidirectional run whose reference is read afresh (within 1e-3 deg of targets 10 deg apart; a reversal of
    0.5 arcmin), and the same with a NO-BREAK SPACE before one direction."""
    rng = np.random.default_rng(6)
    target = np.tile(np.arange(0.0, 360.0, 10.0), 2)
    direction = np.repeat([1, -1], 36)
    ref = target + rng.uniform(-1e-3, 1e-3, target.size)
    encoder = ref + (np.sin(np.radians(target)) + 0.25 * direction) / 60.0
    rows = [f"{r:.9f},{e:.9f},{d:+d}" for r, e, d in zip(ref, encoder, direction)]
    paths["fuzz6_afresh"] = folder / "fuzz6_afresh.csv"
    paths["fuzz6_afresh"].write_text("reference_deg,encoder_deg,direction\n" + "\n".join(rows) + "\n",
                                     encoding="utf-8")
    rows[3] = rows[3].rsplit(",", 1)[0] + ",\u00a0+1"
    paths["fuzz6_nbsp_direction"] = folder / "fuzz6_nbsp_direction.csv"
    paths["fuzz6_nbsp_direction"].write_text("reference_deg,encoder_deg,direction\n" + "\n".join(rows) + "\n",
                                             encoding="utf-8")


FUZZ6_CASES = [
    # the per-direction fit (the default) swallowed these, recording the tolerance and no reversal, exit 0
    Case("fuzz6-fit-target-tolerance-joins-targets", ("fit", "{fuzz6_afresh}", "-o", "{out}/m.json",
                                                      "--target-tolerance", "10"), 1,
         ("fuzz6_afresh.csv", "within the target tolerance 10 deg", "as one target")),
    Case("fuzz6-fit-target-tolerance-matches-nothing", ("fit", "{fuzz6_afresh}", "-o", "{out}/m.json",
                                                        "--target-tolerance", "1e-6"), 1,
         ("fuzz6_afresh.csv", "no reference angle was approached in both directions within 1e-06 deg")),
    Case("fuzz6-fit-target-tolerance-accepted", ("fit", "{fuzz6_afresh}", "-o", "{scratch}/fuzz6.json",
                                                 "--target-tolerance", "0.01", "--method", "lut"), 0),
    Case("fuzz6-fit-nbsp-before-a-direction", ("fit", "{fuzz6_nbsp_direction}", "-o", "{out}/m.json"), 1,
         ("fuzz6_nbsp_direction.csv", "line 5, column 3", "direction is")),
]
CASES += FUZZ6_CASES


# ---------------------------------------------------------------- metrology8: ISO 230-2's sense of ↑ and its targets
def _make_metrology8_files(folder, paths):
    """An ISO linear cycle (up over targets 10 deg apart, then down, twice) whose direction column calls the pass up
    'ccw' (-1) and the pass down 'cw' (+1): labels opposite to the standard's ↑ (the positive direction)."""
    target = np.arange(0.0, 360.0, 10.0)
    rows = []
    for _ in range(2):
        for angles, label, sign in ((target, "ccw", -1), (target[::-1], "cw", 1)):
            encoder = angles + (np.sin(np.radians(angles)) + 0.25 * sign) / 60.0
            rows += [f"{float(a)!r},{float(e)!r},{label}" for a, e in zip(angles, encoder)]
    paths["metrology8_swapped"] = folder / "metrology8_swapped.csv"
    paths["metrology8_swapped"].write_text("reference_deg,encoder_deg,direction\n" + "\n".join(rows) + "\n",
                                           encoding="utf-8")


METROLOGY8_CASES = [
    Case("metrology8-profile-labels-opposite-to-iso-up", ("profile", "{metrology8_swapped}"), 0,
         prints=("turned towards decreasing reference angles", "swap the labels of the direction column")),
    Case("metrology8-profile-tolerance-joins-targets", ("profile", "{fuzz6_afresh}", "--target-tolerance", "10"), 1,
         ("fuzz6_afresh.csv", "as one target", "above the scatter of one target's angles and below the spacing")),
]
CASES += METROLOGY8_CASES


# ---------------------------------------------------------------- noise9: a self-calibration's reading noise comment
def _make_noise9_files(folder, paths):
    """Calibrations whose ``# reading_noise_arcmin`` comment (encal selfcal writes it) is negative, or given twice."""
    body = _csv_text(GRID_TRAIN, GRID_TRAIN + _profile_arcmin(GRID_TRAIN) / 60.0)
    for name, comments in (("noise9_negative", "# reading_noise_arcmin: -1\n"),
                           ("noise9_twice", "# reading_noise_arcmin: 2\n# reading_noise_arcmin: 3\n")):
        paths[name] = folder / f"{name}.csv"
        paths[name].write_text(comments + body, encoding="utf-8")


NOISE9_CASES = [
    Case("noise9-fit-negative-reading-noise", ("fit", "{noise9_negative}", "-o", "{out}/m.json"), 1,
         ("noise9_negative.csv", "line 1", "reading_noise_arcmin is '-1'", "correct or remove the comment")),
    Case("noise9-report-two-reading-noises", ("report", "{noise9_twice}", "-o", "{out}/r.html"), 1,
         ("noise9_twice.csv", "line 2", "but line 1 says 2", "remove one of the comments")),
]
CASES += NOISE9_CASES

# ---------------------------------------------------------------- sweepnoise: selfcal steps --single-reads
SWEEPNOISE_CASES = [
    Case("sweepnoise-steps-single-reads-of-one-calibration", ("selfcal", "steps", "{train}", "--single-reads", "-o",
                                                             "{out}/s.csv"), 2),
]
CASES += SWEEPNOISE_CASES

# A command with no case in this catalogue fails test_every_command_is_catalogued.

_DRIVER = r'''
import io, json, os, sys, traceback
from encal.cli import main

cases = json.load(open(sys.argv[1], encoding="utf-8"))
results = []
for case in cases:
    stdout = io.TextIOWrapper(io.BytesIO(), encoding="utf-8")
    stderr = io.StringIO()
    sys.stdin = io.TextIOWrapper(io.BytesIO(case["stdin"].encode("utf-8")), encoding="utf-8")
    sys.stdout, sys.stderr = stdout, stderr
    saved = {name: os.environ.get(name) for name in case["env"]}
    os.environ.update(case["env"])
    try:
        status = main(case["argv"])
    except SystemExit as exc:
        status = exc.code if isinstance(exc.code, int) else 1
    except BaseException:
        traceback.print_exc(file=stderr)
        status = "crashed"
    finally:
        sys.stdin, sys.stdout, sys.stderr = sys.__stdin__, sys.__stdout__, sys.__stderr__
        for name, value in saved.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value
    stdout.flush()
    results.append({"status": status, "stderr": stderr.getvalue(),
                    "stdout": stdout.buffer.getvalue().decode("utf-8", "replace")})
with open(sys.argv[2], "w", encoding="utf-8") as handle:
    json.dump(results, handle)
'''


def _argv(case, files):
    return [part.format(**files) for part in case.argv]


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    return _make_files(tmp_path_factory.mktemp("catalogue"))


def _same_encal():
    """The environment with the encal this test imported first on PYTHONPATH: the subprocesses run in
    other directories, where a relative PYTHONPATH (``src`` in a git worktree) would find another copy."""
    source = str(Path(encal.__file__).resolve().parents[1])
    return {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [source, os.environ.get("PYTHONPATH")]))}


@pytest.fixture(scope="module")
def outcomes(files, tmp_path_factory):
    """Run every case of the catalogue in one subprocess; {case id: result}."""
    work = tmp_path_factory.mktemp("driver")
    request = [{"argv": _argv(case, files), "stdin": case.stdin, "env": dict(case.env)} for case in CASES]
    (work / "cases.json").write_text(json.dumps(request), encoding="utf-8")
    inputs = {key: Path(path).read_bytes() for key, path in files.items()
              if key != "too_long_name" and Path(path).is_file()}
    subprocess.run([sys.executable, "-c", _DRIVER, str(work / "cases.json"), str(work / "results.json")],
                   cwd=work, check=True, timeout=600, env=_same_encal())
    results = json.loads((work / "results.json").read_text(encoding="utf-8"))
    outcome = {case.id: result for case, result in zip(CASES, results)}
    outcome["inputs before"] = inputs
    return outcome


def check_outcome(case, status, stdout, stderr):
    """The contract of the module docstring, for one case."""
    assert "Traceback" not in stderr, stderr
    assert status == case.status, f"exit status {status}, expected {case.status}; stderr: {stderr!r}"
    lines = stderr.splitlines()
    prefix = f"encal {case.command}: "
    warnings = [line for line in lines if line.startswith(prefix + "warning: ")]
    if case.warns:
        assert len(warnings) == 1, lines
        for word in case.warns:
            assert word in warnings[0]
    else:
        assert not warnings, lines
    others = [line for line in lines if line not in warnings]
    if status == 2:
        assert any(line.startswith("usage:") for line in others), stderr
        assert others[-1].startswith(("encal", "usage:")) and "error" in others[-1], stderr
        return
    if status == 1:
        assert len(others) == 1, f"expected one error line, got {others}"
        line = others[0]
        assert line.startswith(prefix + "error: "), line
        for word in case.says:
            assert word.lower() in line.lower(), f"{word!r} not in {line!r}"
    else:
        assert not others, f"unexpected stderr: {others}"
    for word in case.prints:
        assert word in stdout, stdout
    if case.answers is not None:
        assert len(stdout.splitlines()) == case.answers, stdout


@pytest.mark.parametrize("case", [pytest.param(case, id=case.id, marks=case.marks) for case in CASES])
def test_catalogue(case, outcomes):
    """Every case exits as catalogued: status, one error line naming what and where, no traceback."""
    result = outcomes[case.id]
    check_outcome(case, result["status"], result["stdout"], result["stderr"])


def test_every_command_is_catalogued():
    """Each command of ``encal --help`` has bad-data (status 1) and usage (status 2) cases above."""
    parser = build_parser()
    commands = next(action for action in parser._actions if action.dest == "command").choices
    for command in commands:
        statuses = {case.status for case in CASES if case.command == command}
        assert {1, 2} <= statuses, f"add catalogue cases for 'encal {command}'"


def test_refused_commands_wrote_nothing(outcomes, files):
    """After the whole catalogue, the folder the refused commands named holds nothing at all."""
    assert sorted(p.name for p in Path(files["out"]).iterdir()) == []
    assert not Path(files["nodir"]).parent.exists()
    assert [p.name for p in Path(files["scratch"]).iterdir() if p.name.endswith(".tmp")] == []


def test_inputs_are_never_changed(outcomes, files):
    """No command changed a file it read, refused or not (`fit X.csv -o X.csv` included)."""
    changed = [key for key, content in outcomes["inputs before"].items()
               if Path(files[key]).read_bytes() != content]
    assert changed == []


# --------------------------------------------------------------------------- real processes

#: Bad data, a warning, standard input and a usage mistake: what a process adds to main() (its exit status,
#: its real stdin and stderr, the interpreter's own warnings and tracebacks).
_REAL = ["fit-nan", "profile-radians", "correct-bad-stdin-line", "fit-hidden-0"]


@pytest.mark.parametrize("case_id", _REAL)
def test_real_process(case_id, files, tmp_path):
    """A few catalogue cases as `python -m encal` processes: the same status and stderr."""
    case = next(case for case in CASES if case.id == case_id)
    process = subprocess.run([sys.executable, "-m", "encal", *_argv(case, files)], input=case.stdin.encode(),
                             capture_output=True, cwd=tmp_path, timeout=120, env=_same_encal())
    check_outcome(case, process.returncode, process.stdout.decode(), process.stderr.decode())


def test_auto_on_few_points_does_not_blame_an_unset_option(files, tmp_path, capsys):
    """`encal fit` (method auto) on 15 points either fits or says what to do without naming an unset option."""
    status = main(["fit", files["fifteen_points"], "-o", str(tmp_path / "few.json")])
    err = capsys.readouterr().err
    assert status == 0 or (status == 1 and "folds" not in err and "--method" in err), err


# --------------------------------------------------------------------------- whole or not at all

def _leftovers(folder):
    return sorted(p.name for p in Path(folder).iterdir() if p.name.endswith(".tmp"))


@pytest.fixture
def calibration_file(tmp_path):
    path = tmp_path / "cal.csv"
    path.write_text(_good_csv(), encoding="utf-8")
    return path


@pytest.fixture
def existing_model(tmp_path):
    path = tmp_path / "model.json"
    path.write_text("previous content\n", encoding="utf-8")
    return path


def test_late_bad_option_writes_nothing(calibration_file, tmp_path, capsys):
    """An option found bad only when fitting starts leaves no model file and no temporary file."""
    target = tmp_path / "new.json"
    assert main(["fit", str(calibration_file), "-o", str(target), "--method", "ann", "--algorithm", "nope",
                 "--epochs", "2"]) == 1
    assert len(capsys.readouterr().err.splitlines()) == 1
    assert not target.exists()
    assert _leftovers(tmp_path) == []


def test_late_bad_option_keeps_the_existing_file(calibration_file, existing_model, tmp_path, capsys):
    before = existing_model.read_bytes()
    assert main(["fit", str(calibration_file), "-o", str(existing_model), "--method", "ann", "--algorithm",
                 "nope"]) == 1
    assert existing_model.read_bytes() == before
    assert _leftovers(tmp_path) == []


class _Boom(Exception):
    pass


@pytest.mark.parametrize("where", ["serialise", "write", "fsync", "rename"])
def test_failure_while_saving_leaves_nothing(where, calibration_file, existing_model, tmp_path, monkeypatch,
                                             capsys):
    """A failure at any step of saving: no temporary file is left and the old file is untouched."""
    import encal._core.atomic as atomic
    import encal.models.modelfile as modelfile

    failure = OSError(28, "No space left on device")
    if where == "serialise":
        monkeypatch.setattr(modelfile, "dumps", lambda document: (_ for _ in ()).throw(failure))
    elif where == "write":
        real_fdopen = os.fdopen

        def fdopen(*args, **kwargs):
            handle = real_fdopen(*args, **kwargs)
            handle.write = lambda data: (_ for _ in ()).throw(failure)
            return handle

        monkeypatch.setattr(atomic.os, "fdopen", fdopen)
    elif where == "fsync":
        monkeypatch.setattr(atomic.os, "fsync", lambda fd: (_ for _ in ()).throw(failure))
    else:
        monkeypatch.setattr(atomic.os, "replace", lambda src, dst: (_ for _ in ()).throw(failure))
    before = existing_model.read_bytes()
    assert main(["fit", str(calibration_file), "-o", str(existing_model), "--method", "fourier"]) == 1
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and "No space left" in err[0], err
    assert existing_model.read_bytes() == before
    assert _leftovers(tmp_path) == []


def test_interrupted_write_leaves_nothing(calibration_file, tmp_path, monkeypatch, capsys):
    """Ctrl-C while the file is written: status 130, no model, no temporary file."""
    import encal._core.atomic as atomic

    monkeypatch.setattr(atomic.os, "fsync", lambda fd: (_ for _ in ()).throw(KeyboardInterrupt()))
    target = tmp_path / "m.json"
    assert main(["fit", str(calibration_file), "-o", str(target), "--method", "lut"]) == 130
    assert not target.exists()
    assert _leftovers(tmp_path) == []


def test_failed_calibration_write_keeps_the_old_file(tmp_path, monkeypatch):
    """write_calibration failing half-way through its rows leaves the previous file as it was."""
    import encal.data.calibration as calibration

    path = tmp_path / "cal.csv"
    path.write_text("old\n", encoding="utf-8")
    cal = encal.Calibration(GRID_TRAIN, GRID_TRAIN)
    calls = iter(range(10**6))

    def cell(value):
        if next(calls) == 100:
            raise _Boom("disk vanished")
        return repr(float(value))

    monkeypatch.setattr(calibration, "_cell", cell)
    with pytest.raises(_Boom):
        encal.write_calibration(path, cal)
    assert path.read_text(encoding="utf-8") == "old\n"
    assert _leftovers(tmp_path) == []


@pytest.mark.parametrize("argv", [
    ["export", "{model}", "--format", "table", "-o", "{target}", "--bits", "0"],
    ["export", "{altered}", "--format", "table", "-o", "{target}"],
])
def test_failed_export_writes_nothing(argv, files, tmp_path, capsys):
    target = tmp_path / "table.bin"
    assert main([part.format(target=target, **files) for part in argv]) == 1
    assert not target.exists()
    assert _leftovers(tmp_path) == []



# --------------------------------------------------------------------------- the same judgements in Python

def _write(tmp_path, reference, encoder, extra=None, name="cal.csv"):
    header = "reference_deg,encoder_deg" + "".join(f",{key}" for key in (extra or {}))
    rows = [",".join([repr(float(r)), repr(float(e)), *(str(v[i]) for v in (extra or {}).values())])
            for i, (r, e) in enumerate(zip(reference, encoder))]
    path = tmp_path / name
    path.write_text(header + "\n" + "\n".join(rows) + "\n", encoding="utf-8")
    return path


@pytest.mark.parametrize("convention", ["0..2pi", "-pi..pi"])
def test_radians_warn_in_python(convention, tmp_path):
    """read_calibration warns with an EncalWarning naming the likely unit; with allow_gaps it goes on."""
    radians = np.radians(GRID_TRAIN) - (np.pi if convention == "-pi..pi" else 0.0)
    path = _write(tmp_path, radians, radians + 1e-4)
    with pytest.warns(encal._core.errors.EncalWarning, match="radians"):
        cal = encal.read_calibration(path, allow_gaps=True)
    assert len(cal) == GRID_TRAIN.size


def test_degrees_never_warn(tmp_path):
    """A calibration over a whole turn in degrees reads without any warning (warnings are errors here)."""
    path = _write(tmp_path, GRID_TRAIN, GRID_TRAIN + _profile_arcmin(GRID_TRAIN) / 60.0)
    assert len(encal.read_calibration(path)) == GRID_TRAIN.size


def test_hysteresis_between_directions_is_not_a_fold(tmp_path):
    """Forward and reverse runs 0.8 degree apart at the same targets: each run increases, nothing folds."""
    reference = np.concatenate([GRID_TRAIN, GRID_TRAIN])
    direction = np.repeat([1, -1], GRID_TRAIN.size)
    encoder = reference + 0.4 * direction
    path = _write(tmp_path, reference, encoder, extra={"direction": [f"{d:+d}" for d in direction]})
    assert len(encal.read_calibration(path)) == reference.size


def test_epochs_with_different_offsets_are_not_a_fold(tmp_path):
    reference = np.concatenate([GRID_TRAIN, GRID_TRAIN + 1.0])
    epoch = ["a"] * GRID_TRAIN.size + ["b"] * GRID_TRAIN.size
    encoder = reference + np.where(np.array(epoch) == "a", 0.0, 2.0)
    path = _write(tmp_path, reference, encoder, extra={"epoch": epoch})
    assert len(encal.read_calibration(path)) == reference.size


def test_a_single_glitch_is_refused_and_named(tmp_path):
    """One reading 5 degrees off: refused, naming the reference angles around it."""
    encoder = GRID_TRAIN + 0.01
    encoder[50] -= 5.0
    path = _write(tmp_path, GRID_TRAIN, encoder)
    with pytest.raises(encal.CalibrationError, match="reference 100 deg"):
        encal.read_calibration(path)


@pytest.mark.parametrize("row, shift_deg, named", [(0, -80.0, "280 deg at reference 0 deg (a turn on)"),
                                                    (-1, 100.0, "reads 98.02 deg at reference 358 deg"),
                                                    (0, 5.0, "reference 0 deg"), (-1, -5.0, "reference 358 deg")])
def test_a_glitch_in_the_first_or_last_row_is_refused_as_in_any_other(tmp_path, row, shift_deg, named):
    """Task fuzz5: a glitch in the first row that reads back, or in the last that reads ahead, was accepted with a
    warning (nothing before the first point to fall below), and `encal fit --method lut` wrote a table that corrected
    280 deg to 0; the same glitch in row 50 is refused. The turn is now closed by the first point again."""
    encoder = GRID_TRAIN + _profile_arcmin(GRID_TRAIN) / 60.0
    encoder[row] += shift_deg
    path = _write(tmp_path, GRID_TRAIN, encoder)
    with pytest.raises(encal.CalibrationError, match=re.escape(named) + ".*back although the reference went forward"):
        encal.read_calibration(path)
    with pytest.raises(encal.CalibrationError, match="back although"):  # arrays: the check of encal.fit
        encal.fit(encal.Calibration(GRID_TRAIN, encoder), method="lut")


def test_an_arc_is_not_closed_into_a_turn(tmp_path):
    """An arc (10-130 deg) whose error differs by 2 degrees at its two ends is no fold: only a whole turn is closed."""
    reference = np.arange(10.0, 131.0, 2.0)
    path = _write(tmp_path, reference, reference + np.linspace(0.0, 2.0, reference.size))
    assert len(encal.read_calibration(path)) == reference.size


def test_noise_below_the_fold_threshold_is_accepted(tmp_path):
    """Dense, noisy readings (0.1 degree apart, 0.05 degree noise) go back a little now and then: accepted."""
    reference = np.arange(0.0, 360.0, 0.1)
    noise = np.random.default_rng(0).normal(0.0, 0.05, reference.size)
    path = _write(tmp_path, reference, reference + noise)
    assert len(encal.read_calibration(path)) == reference.size


@pytest.mark.parametrize("bits", [0, 33, -1, 2.5, True])
def test_calibration_refuses_impossible_resolutions(bits):
    with pytest.raises(encal.CalibrationError, match="resolution_bits"):
        encal.Calibration(GRID_TRAIN, GRID_TRAIN, resolution_bits=bits)
