"""Numerical building blocks below the models: the network's forward pass, the Fourier series, the
periodic smoothing spline."""
