"""The use cases: each function calls one library use case (through the compiled
``_fbgforge``) and returns its result object (:mod:`fbgforge._results`)."""

import os

import numpy as np

from . import _fbgforge
from ._design import Design, as_design, design_file
from ._results import (
    ArrayCalibration,
    BuildResult,
    Optimization,
    PeakLog,
    Placement,
    Prediction,
    Reconstruction,
    SensingMatrix,
    Sweep,
    SynthLog,
    VerifyReport,
)
from .errors import InputError

__all__ = [
    "predict",
    "build",
    "read_log",
    "verify",
    "sensing_matrix",
    "methods",
    "reconstruct",
    "sweep",
    "optimize",
    "place",
    "synth_log",
    "calibrate_array",
]


def _path(p, name):
    if p is None:
        return None
    if not isinstance(p, (str, os.PathLike)):
        raise TypeError(f"{name} must be a path (str or os.PathLike), not {type(p).__name__}")
    return os.fspath(p)


def _names(v, name):
    """A list of names from a list or a comma-separated string."""
    if v is None:
        return None
    if isinstance(v, str):
        return [x.strip() for x in v.split(",") if x.strip()]
    try:
        out = [str(x) for x in v]
    except TypeError:
        raise TypeError(f"{name} must be a str or a list of str, not {type(v).__name__}") from None
    return out


def predict(design, force_n=10.0, delta_t_k=0.0, case=None, fidelity="auto", band=True, mesh_level=None, spectrum=True):
    """Predict each strain grating's sensitivity K (pm/N) with the model policy.

    Parameters
    ----------
    design : Design or path
        A module design.
    force_n : float, default 10
        Apex force, N: the shifts and strains are given at this force.
    delta_t_k : float, default 0
        Temperature change, K (adds the thermal shift and its compensation).
    case : {"I", "II"}, optional
        One load case only (Case I needs an insert); default every configuration.
    fidelity : {"auto", "closed-form", "fem"}, default "auto"
        Which model answers: the policy (Case I by the FE model), the closed form
        throughout, or the FE model throughout.
    band : bool, default True
        Also compute each row's prediction band and design interval (the bounding
        contact readings, the contact window's ends, Case II's stated-cylinders
        reading: more FE solves; none under ``fidelity="closed-form"``, which runs
        no FE). Each row states ``model_error_fraction`` either way, and with the
        band ``design_interval_pm_per_n`` and ``limit_check`` (the strain at the
        largest force from the interval's far end).
    mesh_level : int, optional
        Finite-element mesh level, 1 to 4 (fine): each level halves every element
        size (relative to the 34 mm module) and is extrapolated with the level below
        (level 1 with level 0, which never answers alone); the step of that
        extrapolation is each FE row's stated discretisation error
        (``model_error["discretisation_fraction"]``). Default: the policy picks per
        configuration the cheapest level from 1 up to 3 that states a model error of
        at most 15 %; each row names its level (``mesh_level``).
    spectrum : bool, default True
        Also give each row's reflection spectrum over the design's force range
        (``spectrum``: peak shift, FWHM change, one clean peak or not and the force
        where it stops; the transfer-matrix model on the FE strain profile along the
        grating, no extra FE solve), as ``fbgforge predict`` does; ``False`` skips
        it (``--no-spectrum``), about a third of the time on the shipped modules.

    Returns
    -------
    Prediction
        One row per grating and configuration; ``to_dict()`` is the document
        ``fbgforge predict --json`` prints.

    Examples
    --------
    >>> import fbgforge
    >>> p = fbgforge.predict("designs/clip-on-34mm.toml", force_n=1.0, case="II")
    >>> p.gratings[:2], round(float(p.sensitivity_pm_per_n[0]), 2)
    (['lambda_11', 'lambda_12'], -165.52)
    """
    d = as_design(design)
    rows, statements = _fbgforge.predict(
        d._d,
        float(force_n),
        float(delta_t_k),
        case,
        fidelity,
        bool(band),
        None if mesh_level is None else int(mesh_level),
        bool(spectrum),
    )
    return Prediction(
        {
            "delta_t_k": float(delta_t_k),
            "design": d.name,
            "fidelity": fidelity,
            "force_n": float(force_n),
            "starting_mesh_level": 1 if mesh_level is None else int(mesh_level),
            "mesh_levels_used": sorted({r["mesh_level"] for r in rows if r.get("mesh_level") is not None}),
            "predictions": rows,
            "paper_statements": statements,
        }
    )


def build(design, out_dir, tolerance_mm=None, parts=None):
    """Build the printable parts as STL and STEP, with manifest.json.

    Every part is meshed and checked and the module assembled in software before
    anything is written; each file goes through a temporary file and a rename.

    Parameters
    ----------
    design : Design or path
    out_dir : path
        Output folder (made if missing).
    tolerance_mm : float, optional
        Meshing tolerance, mm (default half the printer's resolution, or finer where
        a gap between mating parts needs it; a coarser one that would let mating
        meshes overlap is refused).
    parts : str or list of str, optional
        A part (``"cap"``), a comma-separated list (``"cap,core"``) or a list
        (``["cap", "core"]``); default every part.

    Returns
    -------
    BuildResult
        ``dir``, ``files``, ``manifest`` (manifest.json as a dict), ``parts``.

    Examples
    --------
    >>> import fbgforge, tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     r = fbgforge.build("designs/clip-on-10mm.toml", tmp, parts="cap")
    ...     sorted(f.name for f in r.files)
    ['cap.step', 'cap.stl', 'manifest.json', 'parts.3mf']
    """
    d = as_design(design)
    doc = _fbgforge.build(d._d, _path(out_dir, "out_dir"), tolerance_mm, _names(parts, "parts"))
    return BuildResult(doc)


def read_log(path, format=None, date_order=None):
    """Read an interrogator log (ENLIGHT Peaks or Sensors, I-MON, CSV) into numpy
    columns.

    Parameters
    ----------
    path : path
    format : {"enlight-peaks", "enlight-sensors", "imon", "csv"}, optional
        Detected if omitted.
    date_order : {"dmy", "mdy"}, optional
        Order of day and month in slash dates (told by the file or the format if
        omitted).

    Returns
    -------
    PeakLog
        ``time_s``, ``row_start``, ``peaks`` (row, time_s, channel, wavelength_nm per
        peak), ``warnings``; ``to_pandas()`` is the long table of peaks.

    Examples
    --------
    >>> import fbgforge
    >>> log = fbgforge.read_log("fixtures/logs/plain.csv")
    >>> log.format, log.rows, log.column_names
    ('csv', 3, ['lambda_11', 'lambda_12', 'lambda_temp'])
    """
    return PeakLog(_fbgforge.read_log(_path(path, "path"), format, date_order))


def verify(
    design,
    log,
    force,
    *,
    case=None,
    insert=None,
    core=None,
    k_tolerance=0.08,
    window_nm=None,
    clock_offset_s=None,
    force_start=None,
    max_offset_s=60.0,
    resolution_pm=None,
    format=None,
    date_order=None,
    force_time_column=None,
    force_force_column=None,
    force_scale_to_n=None,
    force_date_order=None,
    report_dir=None,
):
    """Verify a printed part: fit K, R², lag and Q from its logs and judge them
    against the model.

    Parameters
    ----------
    design : Design or path
    log : path
        The interrogator's wavelength log.
    force : path
        The force stand's log.
    case : {"I", "II"}, optional
        Default: I when ``insert`` is named, else II.
    insert, core : str, optional
        The insert (Case I) and the core printed (default the first).
    k_tolerance : float, default 0.08
        Relative tolerance of K against the model.
    window_nm, clock_offset_s, force_start, max_offset_s, resolution_pm : optional
        As ``fbgforge verify``'s flags of the same names.
    format, date_order : optional
        Of the wavelength log.
    force_time_column, force_force_column, force_scale_to_n, force_date_order : optional
        Of the force log.
    report_dir : path, optional
        Also write the report folder (report.json, charts and CSVs) there.

    Returns
    -------
    VerifyReport
        ``verdict``, per-grating K measured and predicted, ``to_pandas()``;
        ``to_dict()`` is ``fbgforge verify --json``'s document, its reasons and
        warnings naming this function's parameters (``clock_offset_s``, not
        ``--clock-offset-s``), as the report folder's texts do.

    Examples
    --------
    >>> import fbgforge, tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     s = fbgforge.synth_log("designs/clip-on-34mm.toml", tmp, k_pm_per_n=12.0, rate_hz=10)
    ...     r = fbgforge.verify("designs/clip-on-34mm.toml", s.log, s.force)
    >>> r.gratings[0], round(float(r.measured_sensitivity_pm_per_n[0]))
    ('lambda_11', 12)
    """
    with design_file(design) as dpath:
        doc = _fbgforge.verify(
            dpath,
            _path(log, "log"),
            _path(force, "force"),
            case,
            insert,
            core,
            float(k_tolerance),
            window_nm,
            clock_offset_s,
            force_start,
            float(max_offset_s),
            resolution_pm,
            format,
            date_order,
            force_time_column,
            force_force_column,
            force_scale_to_n,
            force_date_order,
            _path(report_dir, "report_dir"),
        )
    return VerifyReport(doc)


def sensing_matrix(design):
    """The model sensing matrix of an array design.

    Parameters
    ----------
    design : Design or path
        A design with an ``[array]``.

    Returns
    -------
    SensingMatrix
        ``sensitivity_pm_per_g`` (gratings × cells, pm/g), ``gratings``, ``cells``,
        ``ulimit_g``.

    Examples
    --------
    >>> import fbgforge
    >>> m = fbgforge.sensing_matrix("designs/tactile-array-60x80.toml")
    >>> m.shape, m.ulimit_g
    ((6, 8), 250.0)
    """
    d = as_design(design)
    return SensingMatrix(None, _doc=_fbgforge.sensing_matrix(d._d))


def methods():
    """Names of the reconstruction methods.

    Returns
    -------
    list of str

    Examples
    --------
    >>> import fbgforge
    >>> "bnb" in fbgforge.methods()
    True
    """
    return list(_fbgforge.methods())


def _model_matrix(model):
    if isinstance(model, SensingMatrix):
        return model
    if isinstance(model, (Design, str, os.PathLike)):
        return sensing_matrix(model)
    return SensingMatrix(model)


def _shift_frames(shifts, matrix_gratings, gratings):
    """The shifts as frames × gratings in the matrix's order, by name: (y, one frame,
    time_s or None, index or None)."""
    pd = None
    try:
        import pandas as pd  # noqa: F811
    except ImportError:
        pass
    index = None
    if pd is not None and isinstance(shifts, pd.DataFrame):
        if gratings is not None:
            raise InputError(
                "shifts is a DataFrame: its column names say which grating each column is; "
                "gratings= is for arrays without names"
            )
        names = [str(c) for c in shifts.columns]
        values = shifts.to_numpy(dtype=np.float64)
        one = False
        index = shifts.index
    elif pd is not None and isinstance(shifts, pd.Series):
        if gratings is not None:
            raise InputError("shifts is a Series: its index names the gratings; gratings= is for arrays")
        names = [str(c) for c in shifts.index]
        values = shifts.to_numpy(dtype=np.float64)[None, :]
        one = True
    elif isinstance(shifts, dict):
        if gratings is not None:
            raise InputError("shifts is a dict: its keys name the gratings; gratings= is for arrays")
        names = [str(k) for k in shifts]
        cols = [np.atleast_1d(np.asarray(v, dtype=np.float64)) for v in shifts.values()]
        one = all(np.ndim(v) == 0 for v in shifts.values())
        if len({len(c) for c in cols}) > 1:
            raise InputError("shifts dict: the columns differ in length")
        values = np.column_stack(cols) if cols else np.zeros((0, 0))
    else:
        arr = np.asarray(shifts, dtype=np.float64)
        if arr.ndim not in (1, 2):
            raise InputError(f"shifts has {arr.ndim} dimensions; expected one frame (gratings,) or frames × gratings")
        one = arr.ndim == 1
        values = np.atleast_2d(arr)
        width = values.shape[1]
        if gratings is None:
            raise InputError(
                f"shifts without names ({width} columns): say which grating each column is with "
                f"gratings=[...] (the matrix's gratings: {', '.join(matrix_gratings)}), or "
                "gratings='matrix' for columns in the matrix's row order; or pass a DataFrame "
                "whose columns are the grating names"
            )
        if isinstance(gratings, str) and gratings == "matrix":
            if width != len(matrix_gratings):
                raise InputError(
                    f"gratings='matrix' states one column per grating in the matrix's order, "
                    f"but the shifts have {width} columns and the matrix {len(matrix_gratings)} gratings"
                )
            names = list(matrix_gratings)
        else:
            names = _names(gratings, "gratings")
            if len(names) != width:
                raise InputError(f"gratings= names {len(names)} columns but the shifts have {width}")
    time_col, cols = _fbgforge.shift_columns(names, list(matrix_gratings))
    y = np.ascontiguousarray(values[:, cols])
    time_s = None if time_col is None else values[:, time_col].copy()
    return y, one, time_s, index


def reconstruct(
    model,
    shifts,
    *,
    gratings=None,
    method=None,
    ulimit_g=None,
    min_load_g=None,
    penalty=None,
    max_loads=None,
    resolution_pm=0.5,
    budget_us=100.0,
    normalise=True,
    common_mode=False,
    matrix_sd_pct=None,
    keep_all_gratings=False,
    significance=None,
):
    """Reconstruct cell loads x (g) from grating shifts y (pm), y = A x.

    Shifts are matched to the sensing matrix's gratings **by name**, never by
    position: a pandas DataFrame by its column names (in any order; an optional
    ``time_s`` column becomes the frames' times), a Series by its index, a dict by its
    keys. An array without names is refused unless ``gratings=`` names its columns
    (a list, in the array's column order) or ``gratings="matrix"`` states that the
    columns are the matrix's gratings in its row order (the column count is checked).
    A column that is not a grating, a repeated one or a grating without a column is
    refused, the rule ``fbgforge reconstruct`` applies to a shifts file's header.

    Parameters
    ----------
    model : Design, path, SensingMatrix or array-like
        An array design (its model matrix and ulimit), a measured or given
        :class:`SensingMatrix`, or a bare gratings × cells array (gratings named
        ``fbg1``, ``fbg2``, …, as a matrix file without header).
    shifts : DataFrame, Series, dict or array-like
        One frame or frames × gratings, pm.
    gratings : list of str or "matrix", optional
        Names of an unnamed array's columns (see above).
    method : str, optional
        One of :func:`methods`; default the array's default choice within
        ``budget_us`` per frame, made from the matrix alone.
    ulimit_g : float, optional
        Largest load of a cell, g (default the design's or the matrix's).
    min_load_g : float, optional
        Smallest load that counts, g (default the paper's rule, ulimit / 10).
    penalty : float, optional
        A named method's penalty weight (default: from ``resolution_pm``).
    max_loads : int, optional
        Most cells loaded at once (default 4).
    resolution_pm : float, default 0.5
        The interrogator's noise, pm: sets the ℓ0 penalty (16 σ²).
    budget_us : float, default 100
        The default choice's time budget per frame, µs.
    normalise : bool, default True
        Normalise the matrix's columns.
    common_mode : bool, default False
        Fit a common offset per frame (temperature) whatever the frames say; by
        default the stream diagnosis fits one when the frames call for it.
    matrix_sd_pct : float, optional
        Per-entry uncertainty of the matrix, % of each entry.
    keep_all_gratings : bool, default False
        No stream diagnosis: no grating named and left out or corrected.
    significance : float, optional
        Significance of the frame test behind the flags (default 0.05): a right
        answer is flagged with at most this probability, on any array.

    Returns
    -------
    Reconstruction
        ``loads_g`` (frames × cells, or one row of cells for one frame), ``cells``,
        per-frame ``converged`` and ``residual_pm``, ``method`` and ``reason``;
        ``to_pandas()`` keeps the DataFrame's index.

    Examples
    --------
    >>> import numpy as np, fbgforge
    >>> m = fbgforge.sensing_matrix("designs/tactile-array-60x80.toml")
    >>> x = np.zeros(8); x[1] = 100.0                       # 100 g on cell B
    >>> y = m.sensitivity_pm_per_g @ x                      # one frame, matrix order
    >>> r = fbgforge.reconstruct(m, y, gratings="matrix")
    >>> r.cells[int(np.argmax(r.loads_g))], round(float(r.loads_g.max()))
    ('B', 100)
    """
    m = _model_matrix(model)
    y, one, time_s, index = _shift_frames(shifts, m.gratings, gratings)
    a = np.ascontiguousarray(m.sensitivity_pm_per_g, dtype=np.float64)
    loads, per_frame, setup = _fbgforge.reconstruct(
        a,
        m.gratings,
        y,
        method,
        float(m.ulimit_g if ulimit_g is None else ulimit_g),
        min_load_g,
        penalty,
        max_loads,
        float(resolution_pm),
        float(budget_us),
        bool(normalise),
        bool(common_mode),
        None if matrix_sd_pct is None else float(matrix_sd_pct),
        bool(keep_all_gratings),
        None if significance is None else float(significance),
    )
    return Reconstruction(
        {
            "loads_g": loads[0] if one else loads,
            "cells": m.cells,
            "gratings": m.gratings,
            "time_s": time_s,
            "index": index,
            "per_frame": per_frame,
            "setup": setup,
        }
    )


def sweep(
    design,
    param,
    values=None,
    *,
    start=None,
    stop=None,
    steps=41,
    spacing="linear",
    force_n=50.0,
    case=None,
    fidelity="auto",
    band=True,
):
    """Sweep one design parameter: the predicted shift and K of every grating and
    configuration at each value (each step re-checks the edited design).

    Parameters
    ----------
    design : Design or path
        A module design.
    param : str
        ``e1_mpa``, ``e2_mpa``, ``es_mpa``, ``outer_diameter_mm``, ``cap_wall_mm``, …
        (an unknown name lists them all).
    values : array-like, optional
        The values; or give ``start`` and ``stop``.
    start, stop : float, optional
        The range's ends (``stop`` > ``start``).
    steps : int, default 41
        Values in the range, both ends included.
    spacing : {"linear", "log"}, default "linear"
        Even steps, or even ratios (for a modulus over decades).
    force_n : float, default 50
        Apex force, N.
    case : {"I", "II"}, optional
        One load case only.
    fidelity : {"auto", "closed-form", "fem"}, default "auto"
    band : bool, default True
        The prediction band (two more FE solves per configuration and step).

    Returns
    -------
    Sweep
        ``values``, ``series`` labels, ``shift_pm`` and ``sensitivity_pm_per_n``
        (series × values), the band; ``to_pandas()`` is the long table.

    Examples
    --------
    >>> import fbgforge
    >>> s = fbgforge.sweep("designs/clip-on-34mm.toml", "e1_mpa", start=1, stop=100,
    ...                    steps=3, spacing="log", case="II", fidelity="closed-form")
    >>> s.values.tolist(), s.shift_pm.shape[1]
    ([1.0, 10.0, 100.0], 3)
    """
    d = as_design(design)
    vals = None if values is None else [float(v) for v in np.ravel(values)]
    doc = _fbgforge.sweep(
        d._d,
        str(param),
        vals,
        None if start is None else float(start),
        None if stop is None else float(stop),
        int(steps),
        spacing,
        float(force_n),
        case,
        fidelity,
        bool(band),
    )
    return Sweep(doc)


def optimize(
    design,
    *,
    objective="q",
    vary=("outer_diameter_mm", "cap_wall_mm", "core_wall_mm", "dome_height_ratio"),
    bounds=None,
    max_force_n=20.0,
    max_strain_microstrain=3000.0,
    min_clearance_mm=None,
    cores=None,
    inserts=None,
    materials=None,
    measured=None,
    solver="both",
    starts=2,
    max_iters=200,
    swarm_iters=80,
    seed=2024,
    landscape=None,
    out=None,
    report_dir=None,
):
    """Optimise a module design for Q = |K|·R²/Δt_max or for |K|, over its
    dimensions and every material choice; writes the optimised design and a report.

    Parameters
    ----------
    design : Design or path
        The start design (a module).
    objective : {"q", "sensitivity"}, default "q"
    vary : str or list of str
        Variables searched (``outer_diameter_mm``, ``cap_wall_mm``, ``core_wall_mm``,
        ``dome_height_ratio``, ``overall_height_mm``).
    bounds : dict or str, optional
        Search bounds replacing the defaults: ``{"outer_diameter_mm": (10, 22)}`` or
        ``"outer_diameter_mm=10:22"``.
    max_force_n, max_strain_microstrain, min_clearance_mm : float, optional
        Constraints: the force the module must take, the largest grating strain at it,
        the smallest printable fit clearance.
    cores, inserts : str or list of str, optional
        Materials to try (``"none"`` among inserts is a hollow core).
    materials, measured : path, optional
        A material library replacing the shipped one; ``verify --json`` of a printed
        prototype to calibrate the Q model.
    solver : {"nelder-mead", "particle-swarm", "both"}, default "both"
    starts, max_iters, swarm_iters, seed : int
        Random starts per solver, iteration limits, seed.
    landscape : str or list of str, optional
        The two variables of the landscape chart.
    out, report_dir : path, optional
        Where the design (default ``out/optimize/<name>.toml``) and the report go.

    Returns
    -------
    Optimization
        ``design`` (the optimised :class:`Design`), ``objective``, ``design_path``,
        ``report_dir``, ``to_pandas()`` (one row per material choice); ``to_dict()``
        is ``optimize --json``'s document.

    Examples
    --------
    >>> import fbgforge, tempfile, os
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     o = fbgforge.optimize("designs/clip-on-34mm.toml", objective="sensitivity",
    ...                           vary="cap_wall_mm", inserts="none", solver="nelder-mead",
    ...                           starts=0, max_iters=20, out=os.path.join(tmp, "d.toml"))
    ...     o.design_path.exists()
    True
    >>> o.objective > 0, o.design.kind
    (True, 'module')
    """
    if isinstance(bounds, dict):
        bounds = ",".join(f"{k}={lo}:{hi}" for k, (lo, hi) in bounds.items())
    with design_file(design) as dpath:
        doc = _fbgforge.optimize(
            dpath,
            objective,
            ",".join(_names(vary, "vary")),
            bounds,
            float(max_force_n),
            float(max_strain_microstrain),
            min_clearance_mm,
            _names(cores, "cores"),
            _names(inserts, "inserts"),
            _path(materials, "materials"),
            _path(measured, "measured"),
            solver,
            int(starts),
            int(max_iters),
            int(swarm_iters),
            int(seed),
            None if landscape is None else ",".join(_names(landscape, "landscape")),
            _path(out, "out"),
            _path(report_dir, "report_dir"),
        )
    return Optimization(doc, Design(doc["design"], doc["design_path"]))


def place(
    design,
    *,
    objective="protocol",
    method="wsupport",
    vary_fibers=False,
    solver="both",
    max_iters=90,
    agreement_samples=40,
    out=None,
    report_dir=None,
):
    """Optimise where the gratings of a flat array sit on their fibers (and, with
    ``vary_fibers``, where the fibers run); writes the placed design and a report.

    Parameters
    ----------
    design : Design or path
        An array design.
    objective : {"protocol", "coherence"}, default "protocol"
        Recovery rate and SNR on the seeded protocol, or the mutual-coherence proxy.
    method : str, default "wsupport"
        The reconstruction method the protocol uses.
    vary_fibers : bool, default False
    solver : {"nelder-mead", "particle-swarm", "both"}, default "both"
    max_iters : int, default 90
    agreement_samples : int, default 40
        Random layouts for checking the proxy against the protocol (0: skip).
    out, report_dir : path, optional
        Where the design (default ``out/place/<name>.toml``) and the report go.

    Returns
    -------
    Placement
        ``design`` (placed), ``gratings``, ``start_y_mm`` and ``y_mm``, the start and
        best objective; ``to_pandas()`` one row per grating.

    Examples
    --------
    >>> import fbgforge, tempfile, os
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     p = fbgforge.place("designs/tactile-array-60x80.toml", objective="coherence",
    ...                        solver="nelder-mead", max_iters=5, agreement_samples=0,
    ...                        out=os.path.join(tmp, "placed.toml"))
    >>> p.gratings == p.design.gratings, p.y_mm.shape
    (True, (6,))
    """
    with design_file(design) as dpath:
        doc = _fbgforge.place(
            dpath,
            objective,
            method,
            bool(vary_fibers),
            solver,
            int(max_iters),
            int(agreement_samples),
            _path(out, "out"),
            _path(report_dir, "report_dir"),
        )
    return Placement(doc, Design(doc["design"], doc["design_path"]))


def synth_log(
    design,
    out_dir,
    *,
    format="enlight-peaks",
    core=None,
    k_pm_per_n=12.0,
    rate_hz=20.0,
    force_rate_hz=100.0,
    pulses_n=(10, 20, 30, 40, 50, 25),
    pulse_s=4.0,
    shape="haversine",
    ramp_s=1.0,
    steps=10,
    cycles=8,
    delay_s=0.0,
    rest_s=6.0,
    tau_s=0.4,
    instant_fraction=0.3,
    force_start_s=-1.7,
    noise_pm=0.3,
    force_noise_n=0.01,
    drift_pm_per_s=0.05,
    temperature_ramp_k_per_s=0.0,
    dropout=0.0,
    seed=1,
    decimal_comma=False,
    bom=False,
    metadata_lines=45,
    twelve_hour=False,
    schedule=None,
    from_model=False,
    case=None,
    insert=None,
):
    """Write a synthetic interrogator log with known answers: a module pressed by a
    pulse train (log, force log, truth.json), or with ``schedule`` an array loaded cell
    by cell (log and the true matrix).

    Parameters
    ----------
    design : Design or path
    out_dir : path
        Output folder.
    format : {"enlight-peaks", "enlight-sensors", "imon", "csv"}, default "enlight-peaks"
    core : str, optional
        The core whose gratings respond (default the first).
    k_pm_per_n : float, default 12
        Static K of the core's first grating (the k-th gets K·(1 − 0.15 k)).
    rate_hz, force_rate_hz : float
        Sample rates of the wavelength and force logs, Hz.
    pulses_n : list of float
        Peak force of each pulse, N.
    pulse_s, rest_s : float
        Duration of each pulse and of the rest between pulses, s.
    shape : {"haversine", "trapezoid", "staircase", "sine"}
        The force-stand protocol (``ramp_s``, ``steps`` and ``cycles`` shape it).
    delay_s, tau_s, instant_fraction : float
        Transport delay, SLS time constant, lag-free fraction of the response.
    force_start_s : float
        Wavelength-log time at which the force recording starts, s.
    noise_pm, force_noise_n, drift_pm_per_s, temperature_ramp_k_per_s, dropout : float
        Noise, drift, a temperature ramp, the chance a peak drops out of a row.
    seed : int
    decimal_comma, bom, metadata_lines, twelve_hour :
        How the log is written.
    schedule : path, optional
        Array calibration instead: ``start_s,end_s,cell,load_g``.
    from_model : bool, default False
        Every grating of the core gets the K the design's model predicts (instead of
        ``k_pm_per_n``), for ``case`` and ``insert``: a log on which ``verify`` of the
        same configuration PASSes.
    case : {"I", "II"}, optional
        With ``from_model``: the load case (default "II", or "I" when ``insert`` is
        given).
    insert : str, optional
        With ``from_model``: the insert of Case I.

    Returns
    -------
    SynthLog
        ``log``, ``force``, ``truth`` paths, ``truth_values`` (or ``matrix`` for an
        array calibration run).

    Examples
    --------
    >>> import fbgforge, tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     s = fbgforge.synth_log("designs/clip-on-34mm.toml", tmp, k_pm_per_n=8.0)
    ...     s.log.name, s.force.name, s.truth_values["gratings"][0]["sensitivity_pm_per_n"]
    ('log.txt', 'force.csv', 8.0)

    A log that follows the model, and its verdict:

    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     s = fbgforge.synth_log("designs/clip-on-34mm.toml", tmp, from_model=True)
    ...     fbgforge.verify("designs/clip-on-34mm.toml", s.log, s.force).verdict
    'pass'
    """
    d = as_design(design)
    if from_model and schedule is not None:
        raise InputError("from_model is for a module's log; schedule makes an array's calibration run")
    settings = {
        "from_model": bool(from_model),
        "case": None if case is None else str(case),
        "insert": insert,
        "schedule": _path(schedule, "schedule"),
        "core": core,
        "k_pm_per_n": float(k_pm_per_n),
        "rate_hz": float(rate_hz),
        "force_rate_hz": float(force_rate_hz),
        "pulses_n": [float(p) for p in pulses_n],
        "pulse_s": float(pulse_s),
        "shape": shape,
        "ramp_s": float(ramp_s),
        "steps": int(steps),
        "cycles": int(cycles),
        "delay_s": float(delay_s),
        "rest_s": float(rest_s),
        "tau_s": float(tau_s),
        "instant_fraction": float(instant_fraction),
        "force_start_s": float(force_start_s),
        "noise_pm": float(noise_pm),
        "force_noise_n": float(force_noise_n),
        "drift_pm_per_s": float(drift_pm_per_s),
        "temperature_ramp_k_per_s": float(temperature_ramp_k_per_s),
        "dropout": float(dropout),
        "seed": int(seed),
    }
    style = {
        "decimal_comma": bool(decimal_comma),
        "bom": bool(bom),
        "metadata_lines": int(metadata_lines),
        "twelve_hour": bool(twelve_hour),
    }
    doc = _fbgforge.synth_log(d._d, _path(out_dir, "out_dir"), format, settings, style)
    return SynthLog(doc)


def calibrate_array(
    design,
    log,
    schedule,
    *,
    format=None,
    date_order=None,
    window_nm=None,
    out=None,
    resolution_pm=None,
    model_tolerance=None,
    fit_sheet=False,
    charts=True,
):
    """Calibrate an array from a loading run: the measured sensing matrix with its
    per-entry scatter, the faults that make it unusable, the paper's Table 2 for every
    staircase, additivity, and the matrix against the design's prediction (as
    ``fbgforge calibrate-array --json``).

    Parameters
    ----------
    design : Design or path
        An array design.
    log : path
        The wavelength log of the run.
    schedule : path
        ``start_s,end_s,cell,load_g``: one line per load resting on a cell (a
        staircase: one line per step with the total mass; simultaneous loads:
        overlapping lines on different cells); times in s from the log's first row, a
        hint (the load changes are found in the data).
    format, date_order : optional
        Of the log.
    window_nm : float, optional
        Half-width of the gratings' wavelength windows, nm.
    out : path, optional
        Write the matrix as CSV (the format ``fbgforge reconstruct`` reads) when it is
        usable and complete, ``<out>.sd.csv`` beside it, ``<out>.calibration.json``;
        with a fault the matrix goes to ``<out>.faulty.csv`` instead.
    resolution_pm : float, optional
        The interrogator's resolution, pm (default 0.5).
    model_tolerance : float, optional
        The model's relative band (default 0.4).
    fit_sheet : bool
        Also fit the sheet's unknowns (modulus, thickness, table interface).
    charts : bool
        With ``out``, also write the additivity and calibration-curve charts (SVG)
        with their CSVs beside it.

    Returns
    -------
    ArrayCalibration
        A :class:`SensingMatrix` (pm/g) with ``usable``, ``faults``, ``metrology``,
        ``additivity``, ``verdicts``, ``sd_pm_per_g``, ``sheet_fit``.

    Examples
    --------
    >>> import fbgforge, tempfile, os
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     sched = os.path.join(tmp, "schedule.csv")
    ...     rows = [f"{10 + 30 * i},{30 + 30 * i},{c},200" for i, c in enumerate("ABCDEFGH")]
    ...     _ = open(sched, "w").write("\\n".join(["start_s,end_s,cell,load_g", *rows, ""]))
    ...     run = fbgforge.synth_log("designs/tactile-array-60x80.toml", tmp, schedule=sched, noise_pm=0.0, drift_pm_per_s=0.0)
    ...     m = fbgforge.calibrate_array("designs/tactile-array-60x80.toml", run.log, sched)
    >>> bool(abs(m.sensitivity_pm_per_g[0, 0] - run.matrix.sensitivity_pm_per_g[0, 0]) < 1e-3), m.usable, m.faults
    (True, True, [])
    """
    d = as_design(design)
    doc = _fbgforge.calibrate_array(
        d._d,
        _path(log, "log"),
        _path(schedule, "schedule"),
        format,
        date_order,
        window_nm,
        _path(out, "out"),
        None if resolution_pm is None else float(resolution_pm),
        None if model_tolerance is None else float(model_tolerance),
        bool(fit_sheet),
        bool(charts),
    )
    return ArrayCalibration(None, _doc=doc)
