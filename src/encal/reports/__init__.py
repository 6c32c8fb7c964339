"""What a user reads about an encoder: the HTML report of a calibration (:mod:`~encal.reports.encoder`)
and the drift between repeated calibrations (:mod:`~encal.reports.drift`)."""
