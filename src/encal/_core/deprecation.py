"""Old import paths that keep working for one release, with a :class:`DeprecationWarning`.

encal 0.2 moved its modules into packages that are its layers (``docs/architecture.md``). An old path
(``encal.calibration``) is no file: :func:`install_moved_modules` answers its import with a small module
that imports nothing until one of its names is used, then warns and hands over the name from the module
that defines it now (``encal.data.calibration``).
"""

import importlib
import importlib.abc
import importlib.util
import sys
import types
import warnings

__all__ = ["REMOVED_IN", "moved_module", "install_moved_modules"]

#: The release that removes the old paths.
REMOVED_IN = "0.3"


def moved_module(old, new, *, public_names=()):
    """A module at the old path ``old`` whose names now live in the module ``new``.

    Parameters
    ----------
    old, new : str
        The old and the new dotted module names.
    public_names : collection of str, default=()
        The names a user should import from ``encal`` itself; the warning names ``new`` for the others.

    Returns
    -------
    module
        A module whose ``__getattr__`` (PEP 562) imports ``new``, warns, and returns ``new``'s name.
    """
    module = types.ModuleType(old, f"Deprecated path: moved to {new}; it works until encal {REMOVED_IN}.")

    def __getattr__(name):
        if name.startswith("__"):
            raise AttributeError(name)
        try:
            value = getattr(importlib.import_module(new), name)
        except AttributeError:
            raise AttributeError(f"module {old!r} has no attribute {name!r}") from None
        where = "encal" if name in public_names else new
        warnings.warn(f"{old} is deprecated and will be removed in encal {REMOVED_IN}: import {name} from {where} "
                      "instead.", DeprecationWarning, stacklevel=2)
        return value

    def __dir__():
        return sorted(name for name in dir(importlib.import_module(new)) if not name.startswith("_"))

    module.__getattr__, module.__dir__ = __getattr__, __dir__
    return module


class _MovedModules(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Finds an old module path of the table and makes its :func:`moved_module`."""

    def __init__(self, moved, public_names):
        self.moved, self.public_names = dict(moved), frozenset(public_names)

    def find_spec(self, fullname, path=None, target=None):
        if fullname not in self.moved:
            return None
        is_package = any(other.startswith(fullname + ".") for other in self.moved)
        return importlib.util.spec_from_loader(fullname, self, is_package=is_package)

    def create_module(self, spec):
        module = moved_module(spec.name, self.moved[spec.name], public_names=self.public_names)
        if spec.submodule_search_locations is not None:
            module.__path__ = []  # a package, so that its old submodules are found here too
        return module

    def exec_module(self, module):
        pass


def install_moved_modules(moved, public_names=()):
    """Answer the import of every old path of ``moved`` (old dotted name -> new dotted name), once per process."""
    if not any(isinstance(finder, _MovedModules) for finder in sys.meta_path):
        # First, before the finder of files: an old package's folder left behind with only its __pycache__ (an
        # editable install after a `git pull` that moved it) would otherwise be imported as an empty namespace.
        sys.meta_path.insert(0, _MovedModules(moved, public_names))
