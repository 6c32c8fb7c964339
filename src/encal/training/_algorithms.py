"""Imports every back-end module so that each registers its algorithms."""
