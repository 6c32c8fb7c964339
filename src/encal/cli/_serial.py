"""``--serial S --store DB``: the model a command uses taken from the calibration store (issue 32).

``encal export`` and ``encal correct`` take a model file, or, with ``--serial``, the latest model of that
unit in the store. These helpers keep each command's edit to a few lines.
"""

__all__ = ["add_serial_options", "model_or_serial", "model_input"]


def add_serial_options(parser):
    """``--serial`` and ``--store``."""
    parser.add_argument("--serial", metavar="S",
                        help="use the latest model of the unit with this serial number in --store instead of "
                             "MODEL.json (written by 'encal fleet fit')")
    parser.add_argument("--store", metavar="DB",
                        help="the calibration store of --serial: an SQLite file or a postgresql:// URL")


def model_input(args):
    """The ``check_paths`` inputs entry of the model: ``(path, 'model')``, or with --serial the store's file, so that an
    output is never written over it (``export --serial S --store s.sqlite -o s.sqlite`` replaced the store with the
    table, exit 0); a missing store is said by :func:`model_or_serial`, and a PostgreSQL URL is no file."""
    if args.serial is None:
        return (args.model, "model")
    from pathlib import Path

    from ..store._store import is_url

    store = getattr(args, "store", None)
    return (store if store is not None and not is_url(store) and Path(store).is_file() else None, "store")


def model_or_serial(args, parser):
    """Check that MODEL.json or --serial is given (a usage error otherwise); with --serial, return the model.

    Returns
    -------
    str or encal.models.base.Model
        ``args.model`` (a path), or the unit's latest model from the store; ``args.model`` then names it
        for messages ('SN0042 epoch 3 in store.sqlite').
    """
    if args.serial is None:
        if args.store is not None:
            parser.error("--store names the store of --serial; expected it with --serial")
        if args.model is None:
            parser.error("expected MODEL.json, or --serial S --store DB")
        return args.model
    if args.model is not None:
        parser.error(f"MODEL.json {args.model} and --serial {args.serial} both name the model; expected one of them")
    if args.store is None:
        parser.error("--serial needs --store DB: the calibration store to find the unit's model in")
    from pathlib import Path

    from .._core.errors import InputError
    from ..store import open_store
    from ..store._store import is_url

    if not is_url(args.store):
        problem = stored_file_problem(Path(args.store))
        if problem:
            raise InputError(f"--store {args.store}: {problem}; expected a store written by 'encal fleet fit'")
    with open_store(args.store) as store:
        record = store.latest_model(args.serial)
        model = record.model()
        args.model = f"{record.serial} epoch {record.epoch} in {store.location}"
    return model


def stored_file_problem(path):
    """Why ``path`` cannot be a store to read (a folder, no file, an empty file), or None.

    An empty file is an empty SQLite database to SQLite: opening it would write a store's tables into it, a command
    that only reads changing its input (fuzz6).
    """
    if path.is_dir():
        return "a folder"
    if not path.is_file():
        return "no such file"
    if path.stat().st_size == 0:
        return "an empty file"
    return None
