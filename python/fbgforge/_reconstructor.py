"""A reconstructor built once and called per frame or per batch (issue 35)."""

import numpy as np

from . import _fbgforge
from ._api import _model_matrix, _names
from .errors import InputError


class Reconstructor:
    """Cell loads from grating shifts with the matrix, method and settings fixed once.

    Building it converts the matrix (a design's model matrix is computed here, once),
    picks the method (named, or the default choice within ``budget_us`` per frame,
    made from the matrix alone, never from frames) and prepares it. Each call then
    costs what a frame costs inside a batch, plus the call itself. Frames are in the
    matrix's grating order (``gratings``); unlike :func:`reconstruct`, no stream
    diagnosis runs (there is no stream): name the gratings to use with ``keep``.

    Parameters
    ----------
    model : Design, path, SensingMatrix or array-like
        As :func:`reconstruct`.
    method : str, optional
        One of :func:`methods`; default the array's default choice.
    ulimit_g, min_load_g, penalty, max_loads, resolution_pm, budget_us, normalise
        As :func:`reconstruct`.
    common_mode : bool, default False
        Fit a common offset (every grating moving together: temperature) per frame.
    matrix_sd_pct : float, optional
        Per-entry uncertainty of the matrix, % of each entry (default: one
        calibration reading per column at 200 g).
    keep : list of str, optional
        Gratings to use (default all): leave out one found faulty.
    significance : float, optional
        Significance of the frame test behind the flags (default 0.05): a right
        answer is flagged with at most this probability, on any array.

    Examples
    --------
    >>> import numpy as np, fbgforge
    >>> m = fbgforge.sensing_matrix("designs/tactile-array-60x80.toml")
    >>> rec = fbgforge.Reconstructor(m, method="bnb")
    >>> x = np.zeros(8); x[1] = 100.0                       # 100 g on cell B
    >>> loads, flags = rec(m.sensitivity_pm_per_g @ x)
    >>> rec.cells[int(np.argmax(loads))], round(float(loads.max())), flags
    ('B', 100, [])
    >>> rec.frames(np.tile(m.sensitivity_pm_per_g @ x, (3, 1)))[0].shape
    (3, 8)
    """

    __slots__ = ("_r", "cells", "gratings", "kept")

    def __init__(
        self,
        model,
        *,
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
        keep=None,
        significance=None,
    ):
        m = _model_matrix(model)
        self.cells = list(m.cells)
        self.gratings = list(m.gratings)
        if keep is None:
            idx = None
            self.kept = list(self.gratings)
        else:
            names = _names(keep, "keep")
            unknown = [k for k in names if k not in self.gratings]
            if unknown:
                raise InputError(
                    f"keep names {', '.join(unknown)}, not gratings of the matrix ({', '.join(self.gratings)})"
                )
            idx = [self.gratings.index(k) for k in names]
            self.kept = names
        a = np.ascontiguousarray(m.sensitivity_pm_per_g, dtype=np.float64)
        self._r = _fbgforge.Reconstructor(
            a,
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
            idx,
            None if significance is None else float(significance),
        )

    @property
    def setup(self):
        """The method, why, its penalty, the choice's candidates, the gratings kept."""
        return self._r.setup()

    @property
    def method(self):
        """The method in use."""
        return self._r.setup()["method"]

    def __call__(self, shifts):
        """One frame (one shift per grating, pm, matrix order): (loads_g, flags)."""
        loads, flags, _residual, _certified = self._r.frame(np.ascontiguousarray(shifts, dtype=np.float64))
        return loads, flags

    def frame(self, shifts):
        """One frame: a dict of ``loads_g``, ``flags``, ``residual_pm``, ``certified``."""
        loads, flags, residual, certified = self._r.frame(np.ascontiguousarray(shifts, dtype=np.float64))
        return {"loads_g": loads, "flags": flags, "residual_pm": residual, "certified": certified}

    def frames(self, shifts):
        """Frames × gratings (pm, matrix order): (loads_g frames × cells, per-frame columns)."""
        y = np.ascontiguousarray(np.atleast_2d(np.asarray(shifts, dtype=np.float64)))
        return self._r.frames(y)
