"""fbgforge from Python: fiber Bragg grating tactile sensors designed, built, modelled,
verified and read live by the same library as the ``fbgforge`` command line.

Every function calls one library use case and returns a small result object: numpy
arrays with the grating and cell names beside them, ``to_dict()`` for the document
the command line's ``--json`` prints, ``to_pandas()`` for a table. Shifts are matched
to gratings by name (see :func:`reconstruct`). Errors subclass the built-ins they
are kinds of (:mod:`fbgforge.errors`). Heavy work runs with the GIL released.

>>> import fbgforge
>>> d = fbgforge.shipped_design("clip-on-34mm")
>>> p = fbgforge.predict(d, force_n=1.0, case="II")
>>> p.gratings[0], round(float(p.sensitivity_pm_per_n[0]), 1)
('lambda_11', -165.5)
"""

from . import errors
from ._api import (
    build,
    calibrate_array,
    methods,
    optimize,
    place,
    predict,
    read_log,
    reconstruct,
    sensing_matrix,
    sweep,
    synth_log,
    verify,
)
from ._design import Design, load_design, shipped_design, shipped_designs
from ._fbgforge import __version__
from ._live import LiveStream, live
from ._reconstructor import Reconstructor
from ._results import (
    ArrayCalibration,
    BuildResult,
    LiveFrame,
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
from ._spectra import find_peaks, grating_spectrum, read_spectra
from .errors import (
    DesignError,
    FbgforgeError,
    FileError,
    InputError,
    InstrumentLostError,
    MissingFileError,
)

__all__ = [
    "__version__",
    # designs
    "Design",
    "load_design",
    "shipped_design",
    "shipped_designs",
    # use cases
    "predict",
    "sweep",
    "build",
    "read_log",
    "verify",
    "synth_log",
    "sensing_matrix",
    "calibrate_array",
    "methods",
    "reconstruct",
    "Reconstructor",
    "optimize",
    "place",
    "live",
    # spectra
    "read_spectra",
    "find_peaks",
    "grating_spectrum",
    # results
    "Prediction",
    "Sweep",
    "BuildResult",
    "PeakLog",
    "VerifyReport",
    "SynthLog",
    "SensingMatrix",
    "ArrayCalibration",
    "Reconstruction",
    "Optimization",
    "Placement",
    "LiveStream",
    "LiveFrame",
    # errors
    "errors",
    "FbgforgeError",
    "InputError",
    "DesignError",
    "FileError",
    "MissingFileError",
    "InstrumentLostError",
]
