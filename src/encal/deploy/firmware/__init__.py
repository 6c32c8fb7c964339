"""Firmware formats: encal's correction in the tables that motor-control firmware loads, and back.

One module per firmware; each writes that firmware's own format, implements its
run-time rule in NumPy to state the round-trip error on every code, and reads
the format (and the firmware's calibration output) back:

- :mod:`~encal.deploy.firmware.moteus`: compensation table lines (``--restore-config`` or ``conf set``),
  ``compare_encoders`` output, the raw ``CAL start`` ... ``CAL done`` capture;
- :mod:`~encal.deploy.firmware.simplefoc`: ``CalibratedSensor``'s ``calibrationLut``;
- :mod:`~encal.deploy.firmware.klipper`: the ``[angle]`` section's ``calibrate:`` list;
- :mod:`~encal.deploy.firmware.mechaduino`: the ``lookup[16384]`` array;
- :mod:`~encal.deploy.firmware.tinymovr`: the 64-entry rectification table.
"""

from ._common import FirmwareExport, correction_model, read_c_array
from .klipper import export_klipper, read_klipper
from .mechaduino import export_mechaduino, read_mechaduino
from .moteus import export_moteus, read_cal_capture, read_compare_encoders, read_moteus_conf
from .simplefoc import export_simplefoc, read_simplefoc
from .tinymovr import export_tinymovr, read_tinymovr

#: format name -> export function (model, **options) -> FirmwareExport
EXPORTERS = {"moteus": export_moteus, "simplefoc": export_simplefoc, "klipper": export_klipper,
             "mechaduino": export_mechaduino, "tinymovr": export_tinymovr}

__all__ = ["FirmwareExport", "EXPORTERS", "correction_model", "read_c_array",
           "export_moteus", "read_moteus_conf", "read_compare_encoders", "read_cal_capture",
           "export_simplefoc", "read_simplefoc", "export_klipper", "read_klipper",
           "export_mechaduino", "read_mechaduino", "export_tinymovr", "read_tinymovr"]
