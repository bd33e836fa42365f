"""fbgforge from Python: fiber Bragg grating tactile sensors, designed, built, modelled
and verified by the same library as the ``fbgforge`` command line.

Every function calls one library use case. Results are the JSON documents the command
line prints (as dicts) or numpy arrays; errors are :class:`FbgforgeError` (a
``ValueError``) with the command line's message. Heavy work releases the GIL.

>>> import fbgforge
>>> d = fbgforge.load_design("designs/clip-on-34mm.toml")
>>> rows = fbgforge.predict(d, force_n=1.0, case="II")["predictions"]
"""

from ._fbgforge import (
    Design,
    FbgforgeError,
    __version__,
    build,
    load_design,
    methods,
    predict,
    read_log,
    reconstruct,
    sensing_matrix,
    verify,
)

__all__ = [
    "Design",
    "FbgforgeError",
    "__version__",
    "build",
    "load_design",
    "methods",
    "predict",
    "read_log",
    "reconstruct",
    "sensing_matrix",
    "verify",
]
