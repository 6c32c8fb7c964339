"""The calibration: the :class:`~encal.data.calibration.Calibration` and its CSV, read and checked
(:mod:`~encal.data.calibration`); its directions of travel and their reversal (ISO 230-2,
:mod:`~encal.data.reversal`)."""
