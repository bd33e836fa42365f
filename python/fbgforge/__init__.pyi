"""Type stubs of the fbgforge Python package (see docs/python.md). A test checks that
every public function here has the runtime's parameters, kinds and defaults."""

import os
from pathlib import Path
from typing import Any, Dict, Iterator, List, Literal, Mapping, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

from . import errors as errors
from .errors import DesignError as DesignError
from .errors import FbgforgeError as FbgforgeError
from .errors import FileError as FileError
from .errors import InputError as InputError
from .errors import InstrumentLostError as InstrumentLostError
from .errors import MissingFileError as MissingFileError

__version__: str

PathLike = Union[str, "os.PathLike[str]"]
DesignLike = Union["Design", PathLike]
Case = Literal["I", "II", "i", "ii", "1", "2"]
Fidelity = Literal["auto", "closed-form", "fem"]
LogFormat = Literal["enlight-peaks", "enlight-sensors", "imon", "csv"]
DateOrder = Literal["dmy", "mdy"]
Names = Union[str, Sequence[str]]
FloatArray = npt.NDArray[np.float64]

class Design:
    @classmethod
    def from_toml(cls, text: str) -> "Design": ...
    @classmethod
    def from_dict(cls, spec: Mapping[str, Any]) -> "Design": ...
    @property
    def name(self) -> str: ...
    @property
    def kind(self) -> Literal["module", "array", "module+array"]: ...
    @property
    def gratings(self) -> List[str]: ...
    @property
    def cells(self) -> List[str]: ...
    @property
    def path(self) -> Optional[Path]: ...
    def to_dict(self) -> Dict[str, Any]: ...
    def to_toml(self) -> str: ...
    def replace(self, changes: Optional[Mapping[str, Any]] = None, /, **fields: Any) -> "Design": ...
    def __eq__(self, other: object) -> bool: ...
    def __hash__(self) -> int: ...

def load_design(path: PathLike) -> Design: ...
def shipped_design(name: str) -> Design: ...
def shipped_designs() -> List[str]: ...

class Result:
    def to_dict(self) -> Dict[str, Any]: ...

class Prediction(Result):
    paper_statements: Optional[Dict[str, Any]]
    rows: List[Dict[str, Any]]
    force_n: float
    gratings: List[str]
    cases: List[str]
    inserts: List[Optional[str]]
    cores: List[str]
    models: List[str]
    sensitivity_pm_per_n: FloatArray
    shift_pm: FloatArray
    strain: FloatArray
    band_low_pm_per_n: FloatArray
    band_high_pm_per_n: FloatArray
    def to_pandas(self) -> Any: ...

class BuildResult(Result):
    dir: Path
    files: List[Path]
    manifest: Dict[str, Any]
    parts: List[str]
    def to_pandas(self) -> Any: ...

class PeakLog(Result):
    source: str
    format: str
    clock: str
    channels: int
    column_names: List[str]
    rows: int
    time_s: FloatArray
    row_start: npt.NDArray[np.int64]
    line_of_row: npt.NDArray[Any]
    peaks: Dict[str, npt.NDArray[Any]]
    warnings: Dict[str, Dict[str, Any]]
    def to_pandas(self) -> Any: ...

class VerifyReport(Result):
    verdict: str
    case: Optional[str]
    measurement: Dict[str, Any]
    gratings: List[str]
    measured_sensitivity_pm_per_n: FloatArray
    predicted_sensitivity_pm_per_n: FloatArray
    statuses: List[str]
    sensitivity_pm_per_n: FloatArray
    r_squared: FloatArray
    max_lag_s: FloatArray
    quality_q_pm_per_n_s: FloatArray
    def __getattr__(self, name: str) -> FloatArray: ...
    def to_pandas(self) -> Any: ...

class SensingMatrix(Result):
    def __init__(
        self,
        sensitivity_pm_per_g: npt.ArrayLike,
        gratings: Optional[Sequence[str]] = None,
        cells: Optional[Sequence[str]] = None,
        ulimit_g: float = 250.0,
    ) -> None: ...
    gratings: List[str]
    cells: List[str]
    sensitivity_pm_per_g: FloatArray
    shape: Tuple[int, int]
    ulimit_g: float
    warnings: Dict[str, Dict[str, Any]]
    def to_pandas(self) -> Any: ...

class ArrayCalibration(SensingMatrix):
    usable: bool
    complete: bool
    sd_pm_per_g: FloatArray
    faults: List[Dict[str, Any]]
    metrology: List[Dict[str, Any]]
    additivity: List[Dict[str, Any]]
    comparison: Dict[str, Any]
    verdicts: Dict[str, str]
    sheet_fit: Optional[Dict[str, Any]]
    files: Dict[str, Any]
    charts: List[Path]
    def table2(self) -> Any: ...

class Reconstruction(Result):
    loads_g: FloatArray
    cells: List[str]
    gratings: List[str]
    time_s: Optional[FloatArray]
    per_frame: Dict[str, Any]
    converged: npt.NDArray[np.bool_]
    residual_pm: FloatArray
    flags: List[List[str]]
    certified: npt.NDArray[np.bool_]
    suspect_gratings: List[Dict[str, Any]]
    setup: Dict[str, Any]
    method: str
    reason: str
    def __getattr__(self, name: str) -> Any: ...
    def to_pandas(self) -> Any: ...

class Sweep(Result):
    param: str
    label: str
    force_n: float
    series: List[str]
    values: FloatArray
    shift_pm: FloatArray
    sensitivity_pm_per_n: FloatArray
    band_low_pm_per_n: FloatArray
    band_high_pm_per_n: FloatArray
    def to_pandas(self) -> Any: ...

class Optimization(Result):
    design: Design
    outcome: Dict[str, Any]
    design_path: Path
    report_dir: Path
    objective_unit: Optional[str]
    objective: float
    def to_pandas(self) -> Any: ...

class Placement(Optimization):
    start_objective: float
    best_objective: float
    gratings: List[str]
    start_y_mm: FloatArray
    y_mm: FloatArray

class SynthLog(Result):
    log: Path
    force: Optional[Path]
    truth: Optional[Path]
    matrix_truth: Optional[Path]
    truth_values: Optional[Dict[str, Any]]
    matrix: Optional[SensingMatrix]

class LiveFrame(Result):
    outputs: List[str]
    serial: Optional[int]
    time_s: float
    loads_g: Optional[FloatArray]
    forces_n: Optional[FloatArray]
    converged: Optional[bool]
    residual_pm: Optional[float]
    delta_t_k: Optional[float]
    latency_us: float
    age_us: float
    below_tare: bool
    peaks_nm: FloatArray
    shifts_pm: FloatArray
    values: FloatArray
    def __getattr__(self, name: str) -> Any: ...

class LiveStream(Iterator[LiveFrame]):
    info: Optional[Dict[str, Any]]
    bad: List[Tuple[str, str]]
    events: List[Tuple[str, str]]
    tares: List[Dict[str, Any]]
    summary: Optional[Dict[str, Any]]
    def __iter__(self) -> "LiveStream": ...
    def __next__(self) -> LiveFrame: ...
    def tare(self) -> None: ...
    def close(self) -> None: ...
    def __enter__(self) -> "LiveStream": ...
    def __exit__(self, *exc: Any) -> bool: ...

def predict(
    design: DesignLike,
    force_n: float = 10.0,
    delta_t_k: float = 0.0,
    case: Optional[Case] = None,
    fidelity: Fidelity = "auto",
    band: bool = True,
    mesh_level: Optional[int] = None,
    spectrum: bool = True,
) -> Prediction: ...
def build(
    design: DesignLike,
    out_dir: PathLike,
    tolerance_mm: Optional[float] = None,
    parts: Optional[Names] = None,
) -> BuildResult: ...
def read_spectra(
    path: PathLike,
    format: Optional[Literal["enlight-spectrum", "imon-pixels", "osa-csv"]] = None,
    imon_calibration: Optional[Sequence[float]] = None,
) -> Dict[str, Any]: ...
def find_peaks(
    wavelengths_nm: npt.ArrayLike,
    power: npt.ArrayLike,
    estimator: Literal["gaussian", "parabola", "centroid"] = "gaussian",
    unit: Literal["linear", "mW", "counts", "dBm", "dB"] = "linear",
) -> List[Dict[str, Any]]: ...
def grating_spectrum(
    bragg_wavelength_nm: float,
    length_mm: float,
    wavelengths_nm: npt.ArrayLike,
    index_modulation: float = 2e-4,
    strain: float = 0.0,
    strain_end: Optional[float] = None,
    apodisation: Literal["uniform", "raised_cosine"] = "uniform",
) -> FloatArray: ...
def read_log(
    path: PathLike,
    format: Optional[LogFormat] = None,
    date_order: Optional[DateOrder] = None,
) -> PeakLog: ...
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
) -> VerifyReport: ...
def sensing_matrix(design: DesignLike) -> SensingMatrix: ...
def methods() -> List[str]: ...
def reconstruct(
    model: Union[DesignLike, SensingMatrix, npt.ArrayLike],
    shifts: Any,
    *,
    gratings: Optional[Union[Literal["matrix"], Sequence[str]]] = None,
    method: Optional[str] = None,
    ulimit_g: Optional[float] = None,
    min_load_g: Optional[float] = None,
    penalty: Optional[float] = None,
    max_loads: Optional[int] = None,
    resolution_pm: float = 0.5,
    budget_us: float = 100.0,
    normalise: bool = True,
    common_mode: bool = False,
    matrix_sd_pct: Optional[float] = None,
    keep_all_gratings: bool = False,
    significance: Optional[float] = None,
) -> Reconstruction: ...
class Reconstructor:
    cells: List[str]
    gratings: List[str]
    kept: List[str]
    def __init__(
        self,
        model: Union[DesignLike, SensingMatrix, npt.ArrayLike],
        *,
        method: Optional[str] = None,
        ulimit_g: Optional[float] = None,
        min_load_g: Optional[float] = None,
        penalty: Optional[float] = None,
        max_loads: Optional[int] = None,
        resolution_pm: float = 0.5,
        budget_us: float = 100.0,
        normalise: bool = True,
        common_mode: bool = False,
        matrix_sd_pct: Optional[float] = None,
        keep: Optional[Sequence[str]] = None,
        significance: Optional[float] = None,
    ) -> None: ...
    @property
    def setup(self) -> Dict[str, Any]: ...
    @property
    def method(self) -> str: ...
    def __call__(self, shifts: npt.ArrayLike) -> Tuple[npt.NDArray[np.float64], List[str]]: ...
    def frame(self, shifts: npt.ArrayLike) -> Dict[str, Any]: ...
    def frames(self, shifts: npt.ArrayLike) -> Tuple[npt.NDArray[np.float64], Dict[str, Any]]: ...

def sweep(
    design: DesignLike,
    param: str,
    values: Optional[npt.ArrayLike] = None,
    *,
    start: Optional[float] = None,
    stop: Optional[float] = None,
    steps: int = 41,
    spacing: Literal["linear", "log"] = "linear",
    force_n: float = 50.0,
    case: Optional[Case] = None,
    fidelity: Fidelity = "auto",
    band: bool = True,
) -> Sweep: ...
def optimize(
    design: DesignLike,
    *,
    objective: Literal["q", "sensitivity"] = "q",
    vary: Names = ("outer_diameter_mm", "cap_wall_mm", "core_wall_mm", "dome_height_ratio"),
    bounds: Optional[Union[str, Mapping[str, Tuple[float, float]]]] = None,
    max_force_n: float = 20.0,
    max_strain_microstrain: float = 3000.0,
    min_clearance_mm: Optional[float] = None,
    cores: Optional[Names] = None,
    inserts: Optional[Names] = None,
    materials: Optional[PathLike] = None,
    measured: Optional[PathLike] = None,
    solver: str = "both",
    starts: int = 2,
    max_iters: int = 200,
    swarm_iters: int = 80,
    seed: int = 2024,
    landscape: Optional[Names] = None,
    out: Optional[PathLike] = None,
    report_dir: Optional[PathLike] = None,
) -> Optimization: ...
def place(
    design: DesignLike,
    *,
    objective: Literal["protocol", "coherence"] = "protocol",
    method: str = "wsupport",
    vary_fibers: bool = False,
    solver: str = "both",
    max_iters: int = 90,
    agreement_samples: int = 40,
    out: Optional[PathLike] = None,
    report_dir: Optional[PathLike] = None,
) -> Placement: ...
def synth_log(
    design: DesignLike,
    out_dir: PathLike,
    *,
    format: LogFormat = "enlight-peaks",
    core: Optional[str] = None,
    k_pm_per_n: float = 12.0,
    rate_hz: float = 20.0,
    force_rate_hz: float = 100.0,
    pulses_n: Sequence[float] = (10, 20, 30, 40, 50, 25),
    pulse_s: float = 4.0,
    shape: Literal["haversine", "trapezoid", "staircase", "sine"] = "haversine",
    ramp_s: float = 1.0,
    steps: int = 10,
    cycles: int = 8,
    delay_s: float = 0.0,
    rest_s: float = 6.0,
    tau_s: float = 0.4,
    instant_fraction: float = 0.3,
    force_start_s: float = -1.7,
    noise_pm: float = 0.3,
    force_noise_n: float = 0.01,
    drift_pm_per_s: float = 0.05,
    temperature_ramp_k_per_s: float = 0.0,
    dropout: float = 0.0,
    seed: int = 1,
    decimal_comma: bool = False,
    bom: bool = False,
    metadata_lines: int = 45,
    twelve_hour: bool = False,
    schedule: Optional[PathLike] = None,
    from_model: bool = False,
    case: Optional[str] = None,
    insert: Optional[str] = None,
) -> SynthLog: ...
def calibrate_array(
    design: DesignLike,
    log: PathLike,
    schedule: PathLike,
    *,
    format: Optional[LogFormat] = None,
    date_order: Optional[DateOrder] = None,
    window_nm: Optional[float] = None,
    out: Optional[PathLike] = None,
    resolution_pm: Optional[float] = None,
    model_tolerance: Optional[float] = None,
    fit_sheet: bool = False,
    charts: bool = True,
) -> ArrayCalibration: ...
def live(
    design: DesignLike,
    source: PathLike,
    *,
    tare_frames: int = 50,
    tare_s: float = 1.0,
    tare_wait_s: float = 30.0,
    window_nm: Optional[float] = None,
    method: Optional[str] = None,
    resolution_pm: float = 0.5,
    budget_us: float = 100.0,
    core: Optional[str] = None,
    case: Optional[Case] = None,
    insert: Optional[str] = None,
    fidelity: Fidelity = "auto",
    k: Optional[Mapping[str, float]] = None,
    calibration: Optional[PathLike] = None,
    format: Optional[LogFormat] = None,
    date_order: Optional[DateOrder] = None,
    from_start: bool = False,
    idle_exit_s: Optional[float] = None,
    give_up_s: float = 30.0,
    frames: Optional[int] = None,
    duration_s: Optional[float] = None,
    queue: int = 8192,
    realtime: bool = False,
    raise_on_lost: bool = True,
) -> LiveStream: ...
