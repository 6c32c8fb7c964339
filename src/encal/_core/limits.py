"""Upper bounds of the size options: what runs on a workstation, and why, in one table.

Every size a user can ask for (hidden nodes, epochs, encoders, seeds, processes, ...) is bounded by
what can run in the memory and time of a workstation, so that a typo (``--hidden 1000000000``) is one
sentence instead of gigabytes of memory, hours of work or an export that fails at the end. The
command line checks them as it parses (exit status 2) and the library's entry points with
:func:`check_size` (an ``InputError``).
"""

from .parameters import check_int

__all__ = ["SIZE_LIMITS", "check_size", "size_message"]

#: option -> (largest value, why no more)
SIZE_LIMITS = {
    "hidden": (1000, "hidden nodes: a 1:N:1 network trains with a (3N+1)-square matrix every epoch and its C "
                     "export checks it on 65,536 angles (N = 100,000 needed 48.8 GiB); the paper's sweep ends "
                     "at 110"),
    "epochs": (1_000_000, "epochs: a million is hours of training for a network, far past where any stops"),
    "encoders": (1000, "encoders: each is a set of simulated calibrations and fits"),
    "seeds": (1000, "seeds: each is one more training of every network of the study"),
    "workers": (64, "worker processes: each is a Python interpreter; the studies' fits are small"),
    "n_orders": (32767, "Fourier orders: the largest order a model file and a C int hold"),
    "folds": (1000, "cross-validation folds: each is one more fit of every candidate"),
    "pole_pairs": (1000, "pole pairs: no motor has more"),
    "slots": (10000, "stator slots: no motor has more"),
}


def size_message(name, low, value):
    """The sentence for a size ``value`` outside ``[low, SIZE_LIMITS[name][0]]``."""
    high, why = SIZE_LIMITS[name]
    return f"expected a whole number from {low} to {high} ({why}), got {value}"


def check_size(name, value, where, low=1, *, limit=None):
    """Refuse a size outside ``[low, SIZE_LIMITS[name][0]]`` with :class:`InputError`; return it as an int.

    Parameters
    ----------
    name : str
        Key of :data:`SIZE_LIMITS` (the parameter's name).
    value : int
    where : str
        The function the parameter belongs to, for the message.
    limit : str, optional
        Key of :data:`SIZE_LIMITS` when the parameter's name is another (``"epochs['trainlm']"``).
    """
    high, why = SIZE_LIMITS[name if limit is None else limit]
    return check_int(value, name, where, low=low, high=high, note=why)
