"""A production line: many units fitted into the calibration store, the fleet's statistics, a fleet prior.

- :mod:`encal.fleet.batch`: fit every calibration of a folder in parallel into a :mod:`encal.store`,
  resumable, a bad file refused in one sentence without stopping the batch (``encal fleet fit``);
- :mod:`encal.fleet.statistics`: the fleet's mean profile and spread per harmonic order, robust scores
  of the units that stand out, drift of a unit across its epochs;
- :mod:`encal.fleet.report`: the HTML page of ``encal fleet report``;
- :mod:`encal.fleet.prior`: the spectral model's prior learned from the fleet (empirical Bayes over units).
"""
