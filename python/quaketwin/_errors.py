"""The exceptions and the warning category of quaketwin, and the hand-over
of the library's log lines to Python's ``warnings`` and ``logging``.

The native module (python/src/lib.rs) raises these classes: each error of
the Rust library becomes the class of its kind, which also derives from the
matching built-in exception, so ``except FileNotFoundError`` or ``except
ValueError`` catch what they would catch from any Python library.
"""

import logging
import os
import sys
import warnings


class QuaketwinError(Exception):
    """Base class of every error quaketwin raises.

    The message is the library's: it names the file, zip member, channel,
    line or byte offset where it applies.
    """

    __module__ = "quaketwin"


class UsageError(QuaketwinError, ValueError):
    """Bad settings, pipeline file or arguments (exit code 2 on the command
    line): a value out of its range, an unknown setting, a misspelt option."""

    __module__ = "quaketwin"


class InputError(QuaketwinError, ValueError):
    """Input data that cannot be used as it is: a damaged record, a manifest
    that contradicts the files, a table of the wrong schema."""

    __module__ = "quaketwin"


class _PathMessage:
    """``str()`` of an ``OSError`` subclass raised by the library: its own
    message (which names the path), not ``[Errno 2] …: 'path'``."""

    def __str__(self) -> str:
        return self.strerror if self.strerror else super().__str__()  # type: ignore[misc]


class PathNotFoundError(_PathMessage, QuaketwinError, FileNotFoundError):
    """A path given to quaketwin (an event, a pipeline, a twin, a reference
    run, an archive) does not exist.  ``filename`` is the path, ``errno``
    ``ENOENT``."""

    __module__ = "quaketwin"


class PathPermissionError(_PathMessage, QuaketwinError, PermissionError):
    """A path given to quaketwin cannot be read or written for lack of
    permission.  ``filename`` is the path."""

    __module__ = "quaketwin"


class PathError(_PathMessage, QuaketwinError, OSError):
    """Another failure of the operating system on a path (a directory where
    a file was expected, a full disk …).  ``filename`` is the path."""

    __module__ = "quaketwin"


class QuaketwinWarning(UserWarning):
    """Something to know about the results (the library's warnings: modes
    not promoted, windows skipped, a response applied with a caveat)."""

    __module__ = "quaketwin"


_PACKAGE_DIR = os.path.dirname(os.path.abspath(__file__)) + os.sep
_LOG = logging.getLogger("quaketwin")


def _deliver(lines: list) -> None:
    """Hands the library's lines of one call to Python (called by the native
    module when the call ends): warnings to ``warnings.warn`` as
    ``QuaketwinWarning``, attributed to the first caller outside this
    package; progress and notes to the ``quaketwin`` logger at INFO, details
    at DEBUG."""
    frame = sys._getframe(1)
    level = 2
    while frame is not None and frame.f_code.co_filename.startswith(_PACKAGE_DIR):
        frame = frame.f_back
        level += 1
    for kind, text in lines:
        if kind == "warning":
            warnings.warn(text, QuaketwinWarning, stacklevel=level)
        elif kind == "detail":
            _LOG.debug(text)
        else:
            _LOG.info(text)
