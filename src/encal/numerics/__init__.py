"""Numerical building blocks below the models: the network's forward pass, the periodic smoothing spline."""
