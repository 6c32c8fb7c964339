"""Calibration without a precision reference: from a spin, an electrical-angle sweep or full steps."""
