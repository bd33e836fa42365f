"""Type stubs of the fbgforge Python package (see docs/python.md)."""

import os
from typing import Any, Dict, List, Literal, Optional, Sequence, Tuple, Union, overload

import numpy as np
import numpy.typing as npt

__version__: str

PathLike = Union[str, "os.PathLike[str]"]
DesignLike = Union["Design", PathLike]
Case = Literal["I", "II", "i", "ii", "1", "2"]
Fidelity = Literal["auto", "closed-form", "fem"]
LogFormat = Literal["enlight-peaks", "enlight-sensors", "imon", "csv"]
DateOrder = Literal["dmy", "mdy"]

class FbgforgeError(ValueError):
    """An fbgforge error: the message names the file, line or field and what was
    expected, as the command line prints it."""

class Design:
    """A loaded, checked design spec (``load_design``)."""

    @property
    def name(self) -> str: ...
    @property
    def path(self) -> str: ...
    @property
    def kind(self) -> Literal["module", "array", "module+array"]: ...
    @property
    def gratings(self) -> List[str]: ...
    def to_dict(self) -> Dict[str, Any]: ...

def load_design(path: PathLike) -> Design:
    """Load and check a design spec (TOML); FbgforgeError names the field or line."""

def predict(
    design: DesignLike,
    force_n: float = 10.0,
    delta_t_k: float = 0.0,
    case: Optional[Case] = None,
    fidelity: Fidelity = "auto",
) -> Dict[str, Any]:
    """Each strain grating's K (pm/N) and shifts at ``force_n``: the dict
    ``fbgforge predict --json`` prints (keys design, force_n, delta_t_k, fidelity,
    predictions)."""

def build(
    design: DesignLike,
    out_dir: PathLike,
    tolerance_mm: Optional[float] = None,
    parts: Optional[Sequence[str]] = None,
) -> Dict[str, Any]:
    """Build the printable parts (STL, STEP, manifest.json) into ``out_dir``; returns
    ``{"dir", "files", "manifest"}``."""

def read_log(
    path: PathLike,
    format: Optional[LogFormat] = None,
    date_order: Optional[DateOrder] = None,
) -> Dict[str, Any]:
    """Read an interrogator log. Keys: source, format, clock, channels, column_names,
    rows, time_s (rows,), row_start (rows + 1,), line_of_row, warnings, and peaks: a
    dict of equal-length columns row, time_s, channel, wavelength_nm
    (``pandas.DataFrame(log["peaks"])``)."""

def verify(
    design: DesignLike,
    log: PathLike,
    force: PathLike,
    *,
    case: Optional[Case] = None,
    insert: Optional[str] = None,
    core: Optional[str] = None,
    k_tolerance: float = 0.08,
    window_nm: Optional[float] = None,
    clock_offset_s: Optional[float] = None,
    force_start: Optional[str] = None,
    max_offset_s: float = 60.0,
    resolution_pm: Optional[float] = None,
    format: Optional[LogFormat] = None,
    date_order: Optional[DateOrder] = None,
    force_time_column: Optional[str] = None,
    force_force_column: Optional[str] = None,
    force_scale_to_n: Optional[float] = None,
    force_date_order: Optional[DateOrder] = None,
    report_dir: Optional[PathLike] = None,
) -> Dict[str, Any]:
    """Verify a printed part: the report ``fbgforge verify --json`` prints
    (design, measurement, verdict)."""

def sensing_matrix(design: DesignLike) -> Dict[str, Any]:
    """The model sensing matrix of an array design: gratings, cells,
    sensitivity_pm_per_g (gratings × cells ndarray), ulimit_g."""

def methods() -> List[str]:
    """Names of the reconstruction methods."""

@overload
def reconstruct(
    a: npt.ArrayLike,
    y: npt.ArrayLike,
    method: Optional[str] = None,
    *,
    ulimit_g: float = 250.0,
    min_load_g: Optional[float] = None,
    penalty: Optional[float] = None,
    max_loads: Optional[int] = None,
    resolution_pm: float = 0.5,
    normalise: bool = True,
    return_info: Literal[False] = False,
) -> npt.NDArray[np.float64]: ...
@overload
def reconstruct(
    a: npt.ArrayLike,
    y: npt.ArrayLike,
    method: Optional[str] = None,
    *,
    ulimit_g: float = 250.0,
    min_load_g: Optional[float] = None,
    penalty: Optional[float] = None,
    max_loads: Optional[int] = None,
    resolution_pm: float = 0.5,
    normalise: bool = True,
    return_info: Literal[True],
) -> Tuple[npt.NDArray[np.float64], Dict[str, Any]]:
    """Cell loads (g) from shifts (pm), y = A x: ``a`` gratings × cells (pm/g), ``y``
    one frame or frames × gratings. Frames run in parallel with the GIL released."""
