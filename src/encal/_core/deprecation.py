"""Old import paths that keep working for one release, with a :class:`DeprecationWarning`.

encal 0.2 moved its modules into packages that are its layers (``docs/architecture.md``). A module at an
old path (``encal.calibration``) is a shim: it imports nothing until one of its names is used, then warns
once per name and hands over the name from the new module (``encal.data.calibration``).
"""

import importlib
import warnings

__all__ = ["moved_module", "REMOVED_IN"]

#: The release that removes the old paths.
REMOVED_IN = "0.3"


def moved_module(old, new, *, public=None):
    """``(__getattr__, __dir__)`` for the shim module ``old`` whose names now live in module ``new``.

    Parameters
    ----------
    old : str
        The old dotted module name, the shim's ``__name__``.
    new : str
        The dotted name of the module that defines the names now.
    public : str, optional
        Where a user should import the names from, when not ``new`` (``'encal'`` for the public API).

    Returns
    -------
    tuple of (callable, callable)
        The shim's module-level ``__getattr__`` and ``__dir__`` (PEP 562).
    """

    def __getattr__(name):
        if name.startswith("__"):
            raise AttributeError(name)
        module = importlib.import_module(new)
        try:
            value = getattr(module, name)
        except AttributeError:
            raise AttributeError(f"module {old!r} has no attribute {name!r}") from None
        warnings.warn(f"{old} is deprecated and will be removed in encal {REMOVED_IN}: import {name} from "
                      f"{public or new} instead.", DeprecationWarning, stacklevel=2)
        return value

    def __dir__():
        return sorted(name for name in dir(importlib.import_module(new)) if not name.startswith("_"))

    return __getattr__, __dir__
