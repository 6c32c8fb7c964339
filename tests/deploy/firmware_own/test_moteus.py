"""encal's moteus tables through moteus's own fw/motor_position.h (compiled; tests/deploy/firmware_own/moteus.py).

Every configuration of issue 26 (14/16 bits, encoder reversed, reference zero 0 to 30 degrees, source sign -1,
offset 1000, console or --restore-config file, a conf dump/restore of the scale) is applied by the firmware's
own code to every raw code; encal's stated round trip must be what the firmware does.
"""

import numpy as np
import pytest

from tests.deploy.firmware_own import agrees
from tests.deploy.firmware_own import moteus as harness

pytestmark = pytest.mark.skipif(harness.unavailable() is not None, reason=harness.unavailable() or "")


def test_every_configuration_does_what_encal_states():
    rows = list(harness.matrix())
    assert len(rows) == 48
    failed = [row for row in rows if not agrees(row)]
    assert failed == []
    for row in rows:
        assert row.refused or row.measured_rms < 0.02  # a 1.78-arcmin-RMS correction, applied within 0.02
        assert not row.refused or row.refused.count(". ") == 0


def test_the_harness_sees_a_table_written_for_another_sign_or_offset():
    """Known truth the other way: the table of sign 1, offset 0 on a source with sign -1 or offset 1000 misses
    by about the correction itself (issue 26 measured 1.79 and 1.26 arcmin against 2.39)."""
    from encal.deploy.firmware import export_moteus

    model = harness._model(14, False, 0.0)
    written = export_moteus(model, bits=14)
    for sign, offset in ((-1, 0), (1, 1000)):
        rms, _ = harness.measure(written, model, 14, sign, offset)
        assert rms > 100 * written.rms_error_arcmin and rms > 0.5


def test_the_scale_survives_a_conf_dump_and_restore():
    """conf get prints %f: a scale with more than six decimals changes on a dump/restore; encal's does not."""
    from encal.deploy.firmware import export_moteus

    model = harness._model(16, False, 0.0)
    written = export_moteus(model, bits=16)
    scale_line = written.text.splitlines()[-1]
    assert scale_line.split()[-1] == f"{float(scale_line.split()[-1]):.6f}"
    precise = float(scale_line.split()[-1]) + 0.49e-6  # a nine-digit scale, as encal wrote before issue 26
    altered = type(written)(**{**written.__dict__, "text": written.text.replace(scale_line.split()[-1],
                                                                                   f"{precise:.9g}")})
    before = harness.measure(altered, model, 16)[0]
    after = harness.measure(altered, model, 16, dump_and_restore=True)[0]
    assert abs(after - before) > 1e-3  # the device holds another scale after the dump and restore
    assert harness.measure(written, model, 16, dump_and_restore=True) == harness.measure(written, model, 16)


def test_restore_config_lines_are_what_the_device_receives():
    """moteus_tool --restore-config prefixes 'conf set': encal's restore file has no prefix, and its comments are
    cut as do_restore_config cuts them."""
    from encal.deploy.firmware import export_moteus

    model = harness._model(14, False, 0.0)
    restore = export_moteus(model, bits=14).text
    console = export_moteus(model, bits=14, style="console").text
    assert not any(line.startswith("conf set") for line in restore.splitlines())
    assert harness.device_commands(restore) == console.splitlines()
    assert np.all([line.startswith("conf set motor_position.sources.0.compensation_") for line in
                   harness.device_commands(restore)])
