"""Result objects: the library's result structs as small Python objects, with numpy
arrays for the numbers (NaN where a value is missing, never None inside an array),
the grating and cell names beside them, ``to_dict()`` for the whole document the
command line's ``--json`` prints (NaN where it prints null) and ``to_pandas()`` for a
table (pandas is imported only then).

Each object keeps the library's whole document, so a field the library adds shows in
``to_dict()`` (and in ``to_pandas()`` for per-row fields) with no change here.
"""

import copy
from pathlib import Path

import numpy as np

__all__ = [
    "Result",
    "Prediction",
    "BuildResult",
    "PeakLog",
    "VerifyReport",
    "SensingMatrix",
    "Reconstruction",
    "Sweep",
    "Optimization",
    "Placement",
    "SynthLog",
    "LiveFrame",
]


def _pandas():
    try:
        import pandas
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise ImportError("to_pandas() needs pandas: pip install pandas") from e
    return pandas


def _number(v):
    return np.nan if v is None else float(v)


def _numbers(rows, key):
    """A float array of one field of each row (NaN where a row has none)."""
    return np.array([_number(r.get(key)) for r in rows], dtype=np.float64)


def _band(rows, key, side):
    return np.array(
        [np.nan if r.get(key) is None else float(r[key][side]) for r in rows], dtype=np.float64
    )


def _flatten(row, prefix=""):
    """A row's nested dicts as dotted columns; lists stay as cells."""
    out = {}
    for k, v in row.items():
        name = f"{prefix}{k}"
        if isinstance(v, dict):
            out.update(_flatten(v, name + "."))
        else:
            out[name] = v
    return out


def _table(rows):
    return _pandas().DataFrame([_flatten(r) for r in rows])


def _fmt(v, digits=4):
    """A value as a repr shows it: numbers to `digits` significant figures."""
    if v is None:
        return "—"
    if isinstance(v, (bool, np.bool_)):
        return str(bool(v))
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, (float, np.floating)):
        return "nan" if np.isnan(v) else f"{float(v):.{digits}g}"
    return str(v)


def _grid(header, rows, limit=12):
    """A small aligned table (at most `limit` rows, then how many more) for a repr."""
    cells = [[str(h) for h in header]] + [[_fmt(c) for c in r] for r in rows[:limit]]
    widths = [max(len(r[j]) for r in cells) for j in range(len(header))]
    lines = ["  " + "  ".join(c.ljust(w) for c, w in zip(r, widths)).rstrip() for r in cells]
    if len(rows) > limit:
        lines.append(f"  … {len(rows) - limit} more")
    return "\n".join(lines)


def _scalars(doc, limit=6):
    """The first scalar fields of a document, as `name=value`."""
    out = [f"{k}={_fmt(v)!s}" for k, v in doc.items() if not isinstance(v, (dict, list))]
    return ", ".join(out[:limit])


def _flat_row(row):
    """A row with no list cells: a pair of numbers becomes ``name_low``/``name_high``
    (``band_pm_per_n`` → ``band_low_pm_per_n``, …), a list of words one ``; ``-joined
    string."""
    out = {}
    for k, v in row.items():
        if isinstance(v, list) and len(v) == 2 and all(isinstance(x, (int, float)) or x is None for x in v):
            stem, unit = (k.split("_pm_per_n")[0], "_pm_per_n") if k.endswith("_pm_per_n") else (k, "")
            out[f"{stem}_low{unit}"] = _number(v[0])
            out[f"{stem}_high{unit}"] = _number(v[1])
        elif isinstance(v, list) and all(isinstance(x, str) for x in v):
            out[k] = "; ".join(v)
        else:
            out[k] = v
    return out


def _lead(table, first):
    """`table` with the columns `first` leading, the numeric columns next, the rest last."""
    lead = [c for c in first if c in table.columns]
    numeric = [c for c in table.columns if c not in lead and table[c].dtype.kind in "fiub"]
    rest = [c for c in table.columns if c not in lead and c not in numeric]
    return table[lead + numeric + rest]


class Result:
    """Base of the result objects: the library's document behind attributes."""

    __slots__ = ("_doc",)

    def __init__(self, doc):
        self._doc = doc

    def to_dict(self):
        """The whole document, as the command line's ``--json`` prints it (NaN where
        the JSON has null).

        Returns
        -------
        dict
        """
        return copy.deepcopy(self._doc)

    def __repr__(self):
        scalars = _scalars(self._doc)
        rest = [k for k, v in self._doc.items() if isinstance(v, (dict, list))]
        more = f"; {', '.join(rest[:6])}{', …' if len(rest) > 6 else ''}" if rest else ""
        return f"<{type(self).__name__}: {scalars}{more}>"


class Prediction(Result):
    """Predicted sensitivity K of each grating and configuration (one row each).

    Attributes
    ----------
    rows : list of dict
        One dict per grating and configuration (case, insert), as the library
        returns it.
    gratings, cases, inserts, cores, models : list of str
        Per row (``inserts`` holds None for Case II).
    sensitivity_pm_per_n, shift_pm, strain : numpy.ndarray
        Per row: K (pm/N), the shift at ``force_n`` (pm, temperature-compensated),
        the grating's strain.
    band_low_pm_per_n, band_high_pm_per_n : numpy.ndarray
        Per row: the prediction band between the bounding contact readings (NaN
        where there is none).
    paper_statements : dict or None
        Which of the paper's Case I statements the prediction keeps (K > 0,
        1 < |K_II|/|K_I| ≲ 2, K_I rising as the insert softens), as
        ``fbgforge predict --json`` gives them.
    """

    __slots__ = ()

    @property
    def rows(self):
        return self._doc["predictions"]

    @property
    def paper_statements(self):
        return self._doc.get("paper_statements")

    @property
    def force_n(self):
        return self._doc["force_n"]

    @property
    def gratings(self):
        return [r["grating"] for r in self.rows]

    @property
    def cases(self):
        return [r["case"] for r in self.rows]

    @property
    def inserts(self):
        return [r["insert"] for r in self.rows]

    @property
    def cores(self):
        return [r["core"] for r in self.rows]

    @property
    def models(self):
        return [r["model"] for r in self.rows]

    @property
    def sensitivity_pm_per_n(self):
        return _numbers(self.rows, "sensitivity_pm_per_n")

    @property
    def shift_pm(self):
        return _numbers(self.rows, "shift_pm")

    @property
    def strain(self):
        return _numbers(self.rows, "strain")

    @property
    def band_low_pm_per_n(self):
        return _band(self.rows, "band_pm_per_n", 0)

    @property
    def band_high_pm_per_n(self):
        return _band(self.rows, "band_pm_per_n", 1)

    def __repr__(self):
        rows = [
            (r["grating"], r["core"], r["case"], r.get("insert") or "—", r["sensitivity_pm_per_n"], r["model"])
            for r in self.rows
        ]
        return (
            f"<Prediction at {_fmt(self.force_n)} N: {len(rows)} rows\n"
            + _grid(["grating", "core", "case", "insert", "K pm/N", "model"], rows)
            + ">"
        )

    def to_pandas(self):
        """One row per grating and configuration: the identifying columns first
        (``grating``, ``core``, ``case``, ``insert``), then the numbers (K, shift,
        strain, the band and interval as ``*_low``/``*_high`` columns), then the
        rest; warnings joined by ``; ``.

        Returns
        -------
        pandas.DataFrame
        """
        return _lead(_table([_flat_row(r) for r in self.rows]), ["grating", "core", "case", "insert"])


class BuildResult(Result):
    """What :func:`fbgforge.build` wrote.

    Attributes
    ----------
    dir : pathlib.Path
        The output folder.
    files : list of pathlib.Path
        Every file written, manifest.json last.
    manifest : dict
        manifest.json.
    parts : list of str
        The parts built.
    """

    __slots__ = ()

    @property
    def dir(self):
        return Path(self._doc["dir"])

    @property
    def files(self):
        return [Path(f) for f in self._doc["files"]]

    @property
    def manifest(self):
        return self._doc["manifest"]

    @property
    def parts(self):
        return [p["name"] for p in self.manifest["parts"]]

    def to_pandas(self):
        """One row per part: triangles, volumes, volume error, files.

        Returns
        -------
        pandas.DataFrame
        """
        return _table(self.manifest["parts"]).set_index("name")


class PeakLog(Result):
    """An interrogator log as numpy columns.

    Attributes
    ----------
    format, clock : str
        The log's format and whether its times are ``absolute`` or ``relative``.
    column_names : list of str
        The log's names for its channels or gratings.
    rows : int
    time_s : numpy.ndarray
        Time of each row, s.
    row_start : numpy.ndarray
        Index of each row's first peak in ``peaks`` (rows + 1 entries).
    peaks : dict of numpy.ndarray
        One entry per peak: ``row``, ``time_s``, ``channel``, ``wavelength_nm``.
    warnings : dict
        Counted problems by kind: ``count`` and the ``first`` one named.
    """

    __slots__ = ()

    def __getattr__(self, name):
        try:
            return self._doc[name]
        except KeyError:
            raise AttributeError(name) from None

    def to_pandas(self):
        """The peaks as a long table: one row per peak.

        Returns
        -------
        pandas.DataFrame
        """
        return _pandas().DataFrame(self._doc["peaks"])


class VerifyReport(Result):
    """The verification of a printed part: measurement and verdict.

    Attributes
    ----------
    verdict : str
        The overall verdict (``pass``, ``fail``, ``in_band``, …; the command line's
        exit status follows it).
    case : str
        The load case judged.
    gratings : list of str
        Strain gratings measured.
    measured_sensitivity_pm_per_n, predicted_sensitivity_pm_per_n : numpy.ndarray
        Per judged grating: the fitted K and the model's.
    statuses : list of str
        Per judged grating: its verdict.
    sensitivity_pm_per_n, r_squared, max_lag_s, quality_q_pm_per_n_s : numpy.ndarray
        Per measured grating (``gratings``): the fitted K (pm/N), R², the largest
        lag (s) and Q (pm/(N·s)); every other per-grating number of the measurement
        (``hysteresis_percent_span``, ``resolution_n``, ``drift_pm_per_s``, …) is an
        attribute of the same kind.
    measurement : dict
        Everything measured (fits, lags, Q, clocks), as ``verify --json`` has it.
    """

    __slots__ = ()

    @property
    def verdict(self):
        return self._doc["verdict"]["overall"]

    @property
    def case(self):
        return self._doc["verdict"].get("case")

    @property
    def measurement(self):
        return self._doc["measurement"]

    @property
    def gratings(self):
        return [g["grating"] for g in self.measurement["gratings"]]

    @property
    def measured_sensitivity_pm_per_n(self):
        return _numbers(self._doc["verdict"]["gratings"], "measured_sensitivity_pm_per_n")

    @property
    def predicted_sensitivity_pm_per_n(self):
        return _numbers(self._doc["verdict"]["gratings"], "predicted_sensitivity_pm_per_n")

    @property
    def statuses(self):
        return [g["status"] for g in self._doc["verdict"]["gratings"]]

    # Every figure of merit per measured grating, as an array (NaN where none):
    # r_squared, max_lag_s, quality_q_pm_per_n_s, sensitivity_pm_per_n, …
    @property
    def sensitivity_pm_per_n(self):
        return _numbers(self.measurement["gratings"], "sensitivity_pm_per_n")

    @property
    def r_squared(self):
        return _numbers(self.measurement["gratings"], "r_squared")

    @property
    def max_lag_s(self):
        return _numbers(self.measurement["gratings"], "max_lag_s")

    @property
    def quality_q_pm_per_n_s(self):
        return _numbers(self.measurement["gratings"], "quality_q_pm_per_n_s")

    def __getattr__(self, name):
        # Any other per-grating number of the measurement (hysteresis_percent_span,
        # resolution_n, drift_pm_per_s, …), as an array per grating.
        if name.startswith("_"):
            raise AttributeError(name)
        rows = self._doc["measurement"]["gratings"]
        if rows and name in rows[0] and all(isinstance(r.get(name), (int, float, type(None))) for r in rows):
            return _numbers(rows, name)
        raise AttributeError(name)

    def __repr__(self):
        judged = {g["grating"]: g for g in self._doc["verdict"]["gratings"]}
        rows = []
        for g in self.measurement["gratings"]:
            v = judged.get(g["grating"], {})
            rows.append(
                (
                    g["grating"],
                    g.get("sensitivity_pm_per_n"),
                    v.get("predicted_sensitivity_pm_per_n"),
                    g.get("r_squared"),
                    g.get("max_lag_s"),
                    g.get("quality_q_pm_per_n_s"),
                    v.get("status", "—"),
                )
            )
        head = f"<VerifyReport {self._doc.get('design', '')}: {self.verdict}"
        head += f" (Case {self.case})\n" if self.case else "\n"
        return head + _grid(["grating", "K pm/N", "model pm/N", "R²", "max lag s", "Q pm/(N·s)", "status"], rows) + ">"

    def to_pandas(self):
        """One row per grating: the measurement and, where judged, the verdict
        (columns ``verdict.*``).

        Returns
        -------
        pandas.DataFrame
        """
        judged = {g["grating"]: g for g in self._doc["verdict"]["gratings"]}
        rows = []
        for g in self.measurement["gratings"]:
            row = {k: v for k, v in g.items() if k != "pulses"}
            v = judged.get(g["grating"])
            if v is not None:
                row["verdict"] = {k: x for k, x in v.items() if k != "grating"}
            rows.append(row)
        return _table(rows).set_index("grating")


class SensingMatrix(Result):
    """A sensing matrix A (pm/g): one row per grating, one column per cell.

    Parameters
    ----------
    sensitivity_pm_per_g : array-like
        gratings × cells, pm/g.
    gratings : list of str, optional
        Row names (default ``fbg1``, ``fbg2``, …, as the command line names the rows
        of a matrix file without header).
    cells : list of str, optional
        Column names (default ``A``, ``B``, …).
    ulimit_g : float, optional
        The largest load a cell takes, g (default 250, the paper's).

    Examples
    --------
    >>> import fbgforge
    >>> m = fbgforge.SensingMatrix([[1.0, 0.5], [0.2, 0.9]])
    >>> m.gratings, m.cells, m.shape
    (['fbg1', 'fbg2'], ['A', 'B'], (2, 2))
    """

    __slots__ = ()

    def __init__(self, sensitivity_pm_per_g, gratings=None, cells=None, ulimit_g=250.0, *, _doc=None):
        if _doc is None:
            a = np.array(sensitivity_pm_per_g, dtype=np.float64, copy=True)
            if a.ndim != 2:
                raise ValueError(f"a sensing matrix is 2-D (gratings × cells), got {a.ndim} dimensions")
            m, n = a.shape
            gratings = [f"fbg{i + 1}" for i in range(m)] if gratings is None else [str(g) for g in gratings]
            cells = [_cell_label(j) for j in range(n)] if cells is None else [str(c) for c in cells]
            if len(gratings) != m or len(cells) != n:
                raise ValueError(
                    f"{len(gratings)} grating and {len(cells)} cell names for a {m} × {n} matrix"
                )
            _doc = {"gratings": gratings, "cells": cells, "sensitivity_pm_per_g": a, "ulimit_g": ulimit_g}
        super().__init__(_doc)

    @property
    def gratings(self):
        return list(self._doc["gratings"])

    @property
    def cells(self):
        return list(self._doc["cells"])

    @property
    def sensitivity_pm_per_g(self):
        return self._doc["sensitivity_pm_per_g"]

    @property
    def shape(self):
        return self.sensitivity_pm_per_g.shape

    @property
    def ulimit_g(self):
        u = self._doc.get("ulimit_g")
        return 250.0 if u is None else u

    @property
    def warnings(self):
        """Counted problems of the calibration log (measured matrices)."""
        return self._doc.get("warnings", {})

    def to_pandas(self):
        """The matrix with gratings as the index and cells as the columns.

        Returns
        -------
        pandas.DataFrame
        """
        return _pandas().DataFrame(self.sensitivity_pm_per_g, index=self.gratings, columns=self.cells)


class ArrayCalibration(SensingMatrix):
    """An array calibration: the measured sensing matrix (a :class:`SensingMatrix`,
    NaN for cells never loaded alone) with its per-entry scatter, the faults found,
    the paper's Table 2 for every staircase, additivity tests, the verdicts against
    the design's prediction and, when asked, the sheet fit.

    Attributes
    ----------
    usable : bool
        No fault makes the matrix unusable (the command line exits 3 otherwise).
    complete : bool
        Every cell was loaded alone at least once.
    sd_pm_per_g : numpy.ndarray
        Standard deviation of each entry, pm/g (the form ``reconstruct --matrix-sd``
        reads).
    faults : list of dict
        ``kind``, ``severity``, ``gratings``, ``cells``, ``reason``, ``evidence``.
    metrology : list of dict
        Table 2 per (cell, grating): ``sensitivity_pm_per_g``,
        ``sensitivity_sem_pm_per_g``, ``r``, ``resolution_g``,
        ``linearity_percent_span``, ``hysteresis_percent_span``, ``cycles``, ...
    additivity : list of dict
        One per configuration of simultaneous loads.
    verdicts : dict
        PASS / FAIL / NOT JUDGED per grating against the prediction.
    sheet_fit : dict or None
        The sheet's unknowns (with ``fit_sheet=True``).
    """

    __slots__ = ()

    @property
    def usable(self):
        return bool(self._doc["usable"])

    @property
    def complete(self):
        return bool(self._doc["complete"])

    @property
    def sd_pm_per_g(self):
        return self._doc["sd_pm_per_g"]

    @property
    def faults(self):
        return list(self._doc["faults"])

    @property
    def metrology(self):
        return list(self._doc["metrology"])

    @property
    def additivity(self):
        return list(self._doc["additivity"])

    @property
    def comparison(self):
        return self._doc["comparison"]

    @property
    def verdicts(self):
        return {g["grating"]: g["status"] for g in self._doc["comparison"]["gratings"]}

    @property
    def sheet_fit(self):
        return self._doc.get("sheet_fit")

    @property
    def files(self):
        return self._doc["files"]

    @property
    def charts(self):
        return [Path(p) for p in self._doc.get("charts", [])]

    def table2(self):
        """The paper's Table 2, one row per (cell, grating).

        Returns
        -------
        pandas.DataFrame
        """
        rows = [{k: v for k, v in m.items() if k != "curve"} for m in self.metrology]
        return _table(rows)


def _cell_label(j):
    s = ""
    j += 1
    while j > 0:
        j, r = divmod(j - 1, 26)
        s = chr(ord("A") + r) + s
    return s


class Reconstruction(Result):
    """Cell loads reconstructed from grating shifts.

    Attributes
    ----------
    loads_g : numpy.ndarray
        frames × cells, g (1-D, one per cell, when one frame went in).
    cells, gratings : list of str
        Column names of the loads; the gratings the shifts were matched to.
    time_s : numpy.ndarray or None
        Each frame's time, s, when the shifts had a ``time_s`` column.
    converged : numpy.ndarray of bool
        Per frame: whether the method met its own test.
    residual_pm : numpy.ndarray
        Per frame: ‖A x − y‖, pm.
    flags : list of list of str
        Per frame: why it should not be trusted (``inconsistent``, ``ceiling``,
        ``overload``, ``below_range``, ``ambiguous``, ``unusable``; empty when it
        can be), the words of ``fbgforge reconstruct``'s CSV. A method that stopped
        short (``bnb`` at its work budget) shows as ``certified`` False, not a flag.
    certified : numpy.ndarray of bool
        Per frame: whether the answer is the proven optimum of the method's objective.
    suspect_gratings : list of dict
        Gratings found dead or stuck across the frames and left out (name, reason).
    per_frame : dict of numpy.ndarray
        Every per-frame field of the library's result (``converged``,
        ``residual_pm``, ``certified``, ``chi2``, ``flags``, ``iterations`` and any it
        adds), one entry per frame.
    method, reason : str
        The method used and why (named, or the default choice's reason).
    setup : dict
        The method's set-up: penalty, max_loads, resolution_pm, timings, the default
        choice's candidates, ``suspect_gratings`` and ``flag_counts``.
    """

    __slots__ = ()

    @property
    def loads_g(self):
        return self._doc["loads_g"]

    @property
    def cells(self):
        return list(self._doc["cells"])

    @property
    def gratings(self):
        return list(self._doc["gratings"])

    @property
    def time_s(self):
        return self._doc["time_s"]

    @property
    def per_frame(self):
        return dict(self._doc["per_frame"])

    @property
    def converged(self):
        return self._doc["per_frame"]["converged"]

    @property
    def residual_pm(self):
        return self._doc["per_frame"]["residual_pm"]

    @property
    def setup(self):
        return dict(self._doc["setup"])

    @property
    def method(self):
        return self._doc["setup"]["method"]

    @property
    def reason(self):
        return self._doc["setup"]["reason"]

    @property
    def suspect_gratings(self):
        return list(self._doc["setup"].get("suspect_gratings", []))

    def __repr__(self):
        loads = np.atleast_2d(self.loads_g)
        flags = self._doc["per_frame"].get("flags")
        rows = []
        for i, frame in enumerate(loads):
            f = flags[i] if flags is not None and i < len(flags) else []
            rows.append([i, *[round(float(x), 1) for x in frame], ";".join(f) if isinstance(f, list) else f])
        head = f"<Reconstruction: {loads.shape[0]} frames × {loads.shape[1]} cells, loads g (method {self.method})\n"
        return head + _grid(["frame", *self.cells, "flags"], rows, limit=5) + ">"

    def __getattr__(self, name):
        # A per-frame field the library adds (flags, certified, …).
        try:
            return self._doc["per_frame"][name]
        except KeyError:
            raise AttributeError(name) from None

    def to_pandas(self):
        """One row per frame: a column per cell (g), then every per-frame field; the
        index is the shifts' index (a DataFrame's), else ``time_s``, else the frame.

        Returns
        -------
        pandas.DataFrame
        """
        pd = _pandas()
        loads = np.atleast_2d(self.loads_g)
        cols = {c: loads[:, j] for j, c in enumerate(self.cells)}
        cols.update(self._doc["per_frame"])
        index = self._doc.get("index")
        if index is None and self.time_s is not None:
            index = pd.Index(self.time_s, name="time_s")
        return pd.DataFrame(cols, index=index)


class Sweep(Result):
    """A parameter swept: the predicted shift and K of each series at each value.

    Attributes
    ----------
    param, label : str
        The parameter and its axis label (with unit).
    force_n : float
    series : list of str
        Each series' label: grating, case and insert.
    values : numpy.ndarray
        The parameter's values.
    shift_pm, sensitivity_pm_per_n : numpy.ndarray
        series × values.
    band_low_pm_per_n, band_high_pm_per_n : numpy.ndarray
        series × values; NaN where a series has no band.
    """

    __slots__ = ()

    @property
    def param(self):
        return self._doc["param"]

    @property
    def label(self):
        return self._doc["label"]

    @property
    def force_n(self):
        return self._doc["force_n"]

    def _series(self):
        return self._doc["series"]

    @property
    def series(self):
        out = []
        for s in self._series():
            tail = f" · {s['insert']}" if s.get("insert") else ""
            out.append(f"{s['grating']} · Case {s['case']}{tail}")
        return out

    @property
    def values(self):
        s = self._series()
        return np.array(s[0]["x"] if s else [], dtype=np.float64)

    def _grid(self, key):
        return np.array([s[key] for s in self._series()], dtype=np.float64).reshape(len(self._series()), -1)

    @property
    def shift_pm(self):
        return self._grid("shift_pm")

    @property
    def sensitivity_pm_per_n(self):
        return self._grid("sensitivity_pm_per_n")

    def _band(self, side):
        n = len(self.values)
        rows = []
        for s in self._series():
            b = s.get("band_pm_per_n") or []
            rows.append([b[i][side] for i in range(n)] if len(b) == n else [np.nan] * n)
        return np.array(rows, dtype=np.float64).reshape(len(rows), n)

    @property
    def band_low_pm_per_n(self):
        return self._band(0)

    @property
    def band_high_pm_per_n(self):
        return self._band(1)

    def to_pandas(self):
        """A long table: one row per series and value.

        Returns
        -------
        pandas.DataFrame
        """
        rows = []
        lo, hi = self.band_low_pm_per_n, self.band_high_pm_per_n
        for k, s in enumerate(self._series()):
            for i, x in enumerate(s["x"]):
                rows.append(
                    {
                        self.param: x,
                        "grating": s["grating"],
                        "case": s["case"],
                        "insert": s.get("insert"),
                        "shift_pm": s["shift_pm"][i],
                        "sensitivity_pm_per_n": s["sensitivity_pm_per_n"][i],
                        "band_low_pm_per_n": lo[k, i],
                        "band_high_pm_per_n": hi[k, i],
                    }
                )
        return _pandas().DataFrame(rows)


class Optimization(Result):
    """A module optimisation: the best design, every material choice, the runs.

    Attributes
    ----------
    design : Design
        The optimised design (also written to ``design_path``).
    design_path, report_dir : pathlib.Path
        Where the design and the report (summary.json, charts) were written.
    objective : float
        The best objective, in ``objective_unit``.
    outcome : dict
        The whole outcome, as ``optimize --json`` prints it (new fields such as a
        Pareto front appear here).
    """

    __slots__ = ("design",)

    def __init__(self, doc, design):
        super().__init__(doc["outcome"])
        self.design = design
        self._doc["_paths"] = (doc["design_path"], doc["report_dir"])

    def to_dict(self):
        d = copy.deepcopy(self._doc)
        d.pop("_paths", None)
        return d

    @property
    def outcome(self):
        return self.to_dict()

    @property
    def design_path(self):
        return Path(self._doc["_paths"][0])

    @property
    def report_dir(self):
        return Path(self._doc["_paths"][1])

    @property
    def objective_unit(self):
        return self._doc.get("objective_unit")

    @property
    def objective(self):
        best = self._doc["choices"][self._doc["best_choice"]].get("best") or {}
        return _number(best.get("objective"))

    def to_pandas(self):
        """One row per material choice: its best objective and variables (NaN where
        it found no feasible design).

        Returns
        -------
        pandas.DataFrame
        """
        names = list(self._doc.get("variables", []))
        rows = []
        for c in self._doc["choices"]:
            best = c.get("best") or {}
            x = best.get("x") or [np.nan] * len(names)
            row = {"choice": str(c.get("choice")), "objective": _number(best.get("objective"))}
            row.update({str(n): v for n, v in zip(names, x)})
            row["evaluations"] = sum(r.get("evaluations", 0) for r in c.get("runs", []))
            rows.append(row)
        return _pandas().DataFrame(rows)


class Placement(Optimization):
    """A grating placement: the placed design, start and optimised layouts scored.

    Attributes
    ----------
    design : Design
        The placed design.
    gratings : list of str
    start_y_mm, y_mm : numpy.ndarray
        Each grating's position along its fiber before and after.
    start_objective, best_objective : float
        On the training seeds.
    """

    __slots__ = ()

    @property
    def objective(self):
        return self._doc["best_objective"]

    @property
    def start_objective(self):
        return self._doc["start_objective"]

    @property
    def best_objective(self):
        return self._doc["best_objective"]

    @property
    def gratings(self):
        return [g["name"] for g in self.design.to_dict()["array"]["gratings"]]

    @property
    def start_y_mm(self):
        return np.array(self._doc["start_x"], dtype=np.float64)

    @property
    def y_mm(self):
        return np.array([g["y_mm"] for g in self.design.to_dict()["array"]["gratings"]], dtype=np.float64)

    def to_pandas(self):
        """One row per grating: its fiber, start and placed position.

        Returns
        -------
        pandas.DataFrame
        """
        gs = self.design.to_dict()["array"]["gratings"]
        return _pandas().DataFrame(
            {
                "fiber": [g["fiber"] for g in gs],
                "start_y_mm": self.start_y_mm,
                "y_mm": self.y_mm,
            },
            index=_pandas().Index(self.gratings, name="grating"),
        )


class SynthLog(Result):
    """A synthetic log set and its known answers.

    Attributes
    ----------
    log : pathlib.Path
        The wavelength log.
    force, truth : pathlib.Path or None
        The force log and truth.json (module runs).
    truth_values : dict or None
        The known answers (K, lags, clock offset) of a module run.
    matrix : SensingMatrix or None
        The true matrix of an array calibration run (also in ``matrix_truth``).
    """

    __slots__ = ()

    def _path(self, key):
        v = self._doc.get(key)
        return None if v is None else Path(v)

    @property
    def log(self):
        return self._path("log")

    @property
    def force(self):
        return self._path("force")

    @property
    def truth(self):
        return self._path("truth")

    @property
    def matrix_truth(self):
        return self._path("matrix_truth")

    @property
    def truth_values(self):
        return self._doc.get("truth_values")

    @property
    def matrix(self):
        m = self._doc.get("matrix")
        if m is None:
            return None
        return SensingMatrix(m["sensitivity_pm_per_g"], m["gratings"], m["cells"])


class LiveFrame(Result):
    """One reading of a live stream.

    Attributes
    ----------
    serial : int or None
        The instrument's frame counter.
    time_s : float
        The frame's own time, s (NaN when the source has none).
    outputs : list of str
        Cell labels (array) or strain gratings (module), in the order of the values.
    loads_g : numpy.ndarray or None
        Array: load per cell, g.
    forces_n : numpy.ndarray or None
        Module: force per strain grating, N (NaN where its peak was missing).
    latency_us, age_us : float
        Receive → reading; instrument timestamp → reading (NaN unless the stream's
        clock is this machine's wall clock).
    """

    __slots__ = ("outputs",)

    def __init__(self, doc, outputs):
        super().__init__(doc)
        self.outputs = outputs

    def __getattr__(self, name):
        try:
            return self._doc[name]
        except KeyError:
            if name in ("loads_g", "forces_n", "converged", "residual_pm", "delta_t_k"):
                return None
            raise AttributeError(name) from None

    @property
    def values(self):
        """The loads (array) or forces (module), named by ``outputs``."""
        return self.loads_g if self.loads_g is not None else self.forces_n
