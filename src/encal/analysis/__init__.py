"""Analysis of an error profile given as arrays (encoder angle in degrees, error in arc-minutes): its
statistics and harmonics (:mod:`~encal.analysis.profile`), its isolated points (:mod:`~encal.analysis.outliers`)."""
