"""quaketwin from Python: a thin layer over the Rust library (docs/python.md).

Reading and identifying in memory::

    import quaketwin
    event = quaketwin.read("sample-records/synthetic-4storey-ambient")
    modes = event.modal({"method": "ssi-cov"})
    modes.plot()                      # mode shapes (matplotlib)
    stream = event.to_obspy()         # an ObsPy Stream

Running pipelines as the command line does: ``run``, ``hysteresis``,
``update``, ``track`` (same files, the JSON summary as a dict);
``quaketwin.fleet`` runs many events over a Dask cluster.

Errors are ``QuaketwinError`` subclasses that also derive from the matching
built-in (``PathNotFoundError`` is a ``FileNotFoundError``, ``UsageError``
and ``InputError`` are ``ValueError``\\ s); the library's warnings are
``QuaketwinWarning``\\ s through ``warnings``, its other lines go to the
``quaketwin`` logger.
"""

from . import _native
from ._api import (
    event_partition,
    hysteresis,
    inspect,
    locate_table,
    modal,
    read_event,
    run,
    table_file,
    track,
    update,
)
from ._errors import (
    InputError,
    PathError,
    PathNotFoundError,
    PathPermissionError,
    QuaketwinError,
    QuaketwinWarning,
    UsageError,
)
from ._event import Event, read
from ._modes import Modes

__version__: str = _native.__version__

__all__ = [
    "Event",
    "InputError",
    "Modes",
    "PathError",
    "PathNotFoundError",
    "PathPermissionError",
    "QuaketwinError",
    "QuaketwinWarning",
    "UsageError",
    "event_partition",
    "hysteresis",
    "inspect",
    "locate_table",
    "modal",
    "read",
    "read_event",
    "run",
    "table_file",
    "track",
    "update",
]


def __getattr__(name: str):
    # `quaketwin.fleet` without `import quaketwin.fleet`: imported on first
    # use (it needs Dask distributed and fsspec, an optional extra).
    if name == "fleet":
        import importlib

        return importlib.import_module(".fleet", __name__)
    raise AttributeError(f"module 'quaketwin' has no attribute {name!r}")


def __dir__():
    # `fleet` is listed (tab completion) before its first use.
    return sorted(set(globals()) | {"fleet"})
