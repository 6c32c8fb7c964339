"""Imports every back-end module so that each registers its algorithms."""
from . import trainbr, trainlm  # noqa: F401
from . import conjugate_gradient, gradient_descent, quasi_newton, rprop  # noqa: F401
