"""Designs: load, edit in memory, compare, pickle and write back a design spec."""

import os
import tempfile
from contextlib import contextmanager
from pathlib import Path

from . import _fbgforge

__all__ = ["Design", "load_design", "shipped_design", "shipped_designs"]


class Design:
    """A loaded, checked design spec: a module, an array, or both.

    Make one with :func:`load_design`, :func:`shipped_design`,
    :meth:`Design.from_toml` or :meth:`Design.from_dict`; every way runs the same
    checks as the command line, so a ``Design`` always holds a spec the geometry, the
    model and the verifier accept. It is immutable: :meth:`replace` returns an edited
    copy. Two designs are equal (``==``) when their specs are; a design pickles.

    Attributes
    ----------
    name : str
        The design's name.
    kind : {"module", "array", "module+array"}
        What it describes.
    gratings : list of str
        Grating names in spec order (module gratings, then array gratings).
    cells : list of str
        The array's cell labels (``A``, ``B``, … row-major from −x, −y); empty for
        a module.
    path : pathlib.Path or None
        The file it was loaded from (None when made in memory).

    Examples
    --------
    >>> import fbgforge
    >>> d = fbgforge.shipped_design("clip-on-34mm")
    >>> d.name, d.kind
    ('clip-on-34mm', 'module')
    >>> thin = d.replace(**{"module.cap_wall_mm": 1.2}, name="thin-cap")
    >>> thin.to_dict()["module"]["cap_wall_mm"], thin == d
    (1.2, False)
    >>> fbgforge.Design.from_toml(thin.to_toml()) == thin
    True
    """

    __slots__ = ("_d", "_path")

    def __init__(self, handle, path=None):
        if not isinstance(handle, _fbgforge._Design):
            raise TypeError(
                "make a Design with fbgforge.load_design(path), Design.from_toml(text) "
                "or Design.from_dict(d)"
            )
        self._d = handle
        self._path = None if path is None else Path(path)

    # -- constructors ---------------------------------------------------------

    @classmethod
    def from_toml(cls, text):
        """A design from TOML text.

        Parameters
        ----------
        text : str
            The spec, as a design file holds it.

        Returns
        -------
        Design

        Examples
        --------
        >>> import fbgforge
        >>> text = fbgforge.shipped_design("clip-on-16mm").to_toml()
        >>> fbgforge.Design.from_toml(text).name
        'clip-on-16mm'
        """
        return cls(_fbgforge._Design.from_toml(text))

    @classmethod
    def from_dict(cls, spec):
        """A design from a dict of the TOML's tables and fields (as :meth:`to_dict`
        gives; ``None`` values are left out, as absent optional fields).

        Parameters
        ----------
        spec : dict

        Returns
        -------
        Design

        Examples
        --------
        >>> import fbgforge
        >>> spec = fbgforge.shipped_design("clip-on-22mm").to_dict()
        >>> spec["module"]["dome_height_mm"] = 4.0
        >>> fbgforge.Design.from_dict(spec).to_dict()["module"]["dome_height_mm"]
        4.0
        """
        return cls(_fbgforge._Design.from_value(spec))

    # -- views ----------------------------------------------------------------

    @property
    def name(self):
        return self._d.name

    @property
    def kind(self):
        return self._d.kind

    @property
    def gratings(self):
        return self._d.gratings

    @property
    def cells(self):
        return self._d.cells

    @property
    def path(self):
        return self._path

    def to_dict(self):
        """The spec as a dict: every table and field, defaults filled in.

        Returns
        -------
        dict
        """
        return self._d.to_dict()

    def to_toml(self):
        """The spec as TOML text (loads back to an equal design).

        Returns
        -------
        str
        """
        return self._d.to_toml()

    def replace(self, changes=None, /, **fields):
        """A copy with some fields changed, checked as a loaded design is.

        Parameters
        ----------
        changes : dict, optional
            Field paths to new values; a path is dotted (``"module.cap_wall_mm"``)
            and indexes lists by number (``"module.gratings.0.center_height_mm"``).
        **fields
            More of the same. A keyword without a dot is a field's own name: a
            top-level field, else the one field of that name in the design's tables
            (``cap_wall_mm=1.2`` sets ``module.cap_wall_mm``; a name two tables share
            raises KeyError naming their paths, to be given dotted:
            ``**{"module.cap_wall_mm": 1.2}``). Fields inside lists are always
            dotted (``"module.gratings.0.center_height_mm"``).

        Returns
        -------
        Design
            The edited design (``path`` None: it is not the file's any more).

        Raises
        ------
        DesignError
            When the edited spec does not hold (names the field).
        KeyError
            When a path names no field.

        Examples
        --------
        >>> import fbgforge
        >>> d = fbgforge.shipped_design("clip-on-34mm")
        >>> d.replace({"module.gratings.0.center_height_mm": 14.0}).to_dict()["module"]["gratings"][0]["center_height_mm"]
        14.0
        >>> d.replace(cap_wall_mm=1.2).to_dict()["module"]["cap_wall_mm"]
        1.2
        """
        spec = self.to_dict()
        for path, value in (changes or {}).items():
            _set_path(spec, path, value)
        for name, value in fields.items():
            _set_path(spec, _resolve_name(spec, name), value)
        return Design.from_dict(spec)

    # -- protocol -------------------------------------------------------------

    def __eq__(self, other):
        if not isinstance(other, Design):
            return NotImplemented
        return self._d.same(other._d)

    def __hash__(self):
        return hash(self.to_toml())

    def __reduce__(self):
        return (_from_state, (self.to_toml(), None if self._path is None else str(self._path)))

    def __repr__(self):
        where = f", path={str(self._path)!r}" if self._path is not None else ""
        return f"Design(name={self.name!r}, kind={self.kind!r}{where})"


def _from_state(text, path):
    return Design(_fbgforge._Design.from_toml(text), path)


def _resolve_name(spec, name):
    """The dotted path of a keyword: itself when dotted or a top-level field, else the
    one field of that name in the spec's tables (not inside lists)."""
    if "." in name or name in spec:
        return name
    found = []

    def walk(node, prefix):
        for k, v in node.items():
            if k == name:
                found.append(prefix + k)
            if isinstance(v, dict):
                walk(v, prefix + k + ".")

    walk(spec, "")
    if len(found) == 1:
        return found[0]
    if not found:
        raise KeyError(f"{name}: no field of that name in the design (a dotted path such as \"module.cap_wall_mm\" names one)")
    raise KeyError(f"{name}: several fields have that name ({', '.join(found)}); give the dotted path")


def _set_path(spec, path, value):
    keys = path.split(".")
    node = spec
    for i, k in enumerate(keys):
        last = i == len(keys) - 1
        if isinstance(node, list):
            try:
                idx = int(k)
                node[idx]
            except (ValueError, IndexError):
                raise KeyError(f"{path}: `{k}` is not an index of a list of {len(node)}") from None
            if last:
                node[idx] = value
            else:
                node = node[idx]
        elif isinstance(node, dict):
            if last:
                node[k] = value
            else:
                if k not in node or node[k] is None:
                    node[k] = {}
                node = node[k]
        else:
            raise KeyError(f"{path}: `{'.'.join(keys[:i])}` is a value, not a table")


def load_design(path):
    """Load and check a design spec (TOML).

    Parameters
    ----------
    path : str or os.PathLike
        The design file.

    Returns
    -------
    Design

    Raises
    ------
    MissingFileError
        When the file does not exist (a ``FileNotFoundError``).
    DesignError
        When the spec does not hold; names the file and the field (a ``ValueError``).

    Examples
    --------
    >>> import fbgforge
    >>> fbgforge.load_design("designs/tactile-array-60x80.toml").cells
    ['A', 'B', 'C', 'D', 'E', 'F', 'G', 'H']
    """
    path = os.fspath(path)
    return Design(_fbgforge._Design.load(path), path)


def shipped_design(name):
    """A design shipped with the package (the repository's ``designs/``).

    Parameters
    ----------
    name : str
        One of :func:`shipped_designs`, with or without ``.toml``.

    Returns
    -------
    Design

    Examples
    --------
    >>> import fbgforge
    >>> fbgforge.shipped_design("tactile-array-60x80").kind
    'array'
    """
    return Design(_fbgforge._Design.shipped(name))


def shipped_designs():
    """Names of the designs shipped with the package.

    Returns
    -------
    list of str

    Examples
    --------
    >>> import fbgforge
    >>> "clip-on-34mm" in fbgforge.shipped_designs()
    True
    """
    return list(_fbgforge._Design.shipped_names())


def as_design(design):
    """A Design from a Design or a path."""
    if isinstance(design, Design):
        return design
    if isinstance(design, (str, os.PathLike)):
        return load_design(design)
    raise TypeError(f"design must be a Design or a path, not {type(design).__name__}")


@contextmanager
def design_file(design):
    """A path holding the design: its own file, or a temporary copy of an in-memory
    design (for the use cases that read a design file themselves)."""
    design = as_design(design)
    if design.path is not None and design.path.exists():
        yield str(design.path)
        return
    with tempfile.TemporaryDirectory(prefix="fbgforge-") as tmp:
        p = Path(tmp) / f"{design.name}.toml"
        p.write_text(design.to_toml())
        yield str(p)
