"""The exceptions fbgforge raises, each a subclass of the built-in it is a kind of.

* :class:`FbgforgeError`: the base of every fbgforge exception (``except
  fbgforge.FbgforgeError`` catches them all);
* :class:`InputError` (a ``ValueError``): a bad value, a bad option or data that does
  not hold (a log without rows, shifts that do not match the gratings);
* :class:`DesignError` (an :class:`InputError`): a design spec that does not hold,
  with the ``file`` and the ``field`` at fault;
* :class:`FileError` (an ``OSError``): a file that cannot be read or written;
  :class:`MissingFileError` (a :class:`FileError` and a ``FileNotFoundError``): an
  input file that does not exist;
* :class:`InstrumentLostError` (a ``ConnectionError``): :func:`fbgforge.live` gave up
  reconnecting, or the followed log could no longer be read.

Messages are the library's (the command line prints the same after ``error:``), with
parameters named as the Python functions name them (``force_n``, not ``--force-n``).

>>> import fbgforge
>>> try:
...     fbgforge.load_design("no/such/design.toml")
... except FileNotFoundError as e:
...     print(type(e).__name__, e.filename)
MissingFileError no/such/design.toml
"""

import errno

__all__ = [
    "FbgforgeError",
    "InputError",
    "DesignError",
    "FileError",
    "MissingFileError",
    "InstrumentLostError",
]


class FbgforgeError(Exception):
    """Base of every fbgforge exception."""


class InputError(FbgforgeError, ValueError):
    """A bad value: an option, an array or data that does not hold."""


class DesignError(InputError):
    """A design spec that does not hold.

    Attributes
    ----------
    file : str or None
        The design file, when the spec came from one.
    field : str or None
        Dotted path of the field at fault, e.g. ``"module.cap_wall_mm"``.
    """

    def __init__(self, message, file=None, field=None):
        super().__init__(message)
        self.file = file
        self.field = field


class FileError(FbgforgeError, OSError):
    """A file that cannot be read or written."""

    def __init__(self, message, filename=None, errno_=None):
        OSError.__init__(self, errno_, message, filename)
        self.message = message

    def __str__(self):
        return self.message


class MissingFileError(FileError, FileNotFoundError):
    """An input file that does not exist; ``filename`` names it."""

    def __init__(self, message, filename=None):
        super().__init__(message, filename, errno.ENOENT)


class InstrumentLostError(FbgforgeError, ConnectionError):
    """The live source was lost: (re)connecting given up, or the log unreadable.

    Attributes
    ----------
    summary : dict
        The run's summary (frames read, dropped, bad, ...).
    """

    def __init__(self, message, summary=None):
        super().__init__(message)
        self.summary = summary
