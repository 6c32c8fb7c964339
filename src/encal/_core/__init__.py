"""The foundation every other package stands on: angles and their units, the exception and warning
classes, the checks of public parameters, size limits, atomic files, signals, progress, BLAS threads,
the CSV dialect and the reading of numbers. It imports nothing else of encal."""
