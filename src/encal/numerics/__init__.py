"""Numerical building blocks below the models: trigonometric sums at arbitrary angles (a non-uniform
FFT), the Fourier series, the network's forward pass, the periodic smoothing spline, the inverse of a
triangular (Cholesky) factor by blocks."""
