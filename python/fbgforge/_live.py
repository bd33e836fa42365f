"""Live readings from Python: :func:`live` runs the library's live use case on its own
thread and hands its readings over as an iterator (:class:`LiveStream`)."""

import os

from . import _fbgforge
from ._api import _path
from ._design import design_file
from ._results import LiveFrame
from .errors import InstrumentLostError

__all__ = ["live", "LiveStream"]


class LiveStream:
    """A live stream being read: iterate for :class:`LiveFrame` readings.

    Bad frames, connection events, tare changes and the summary are kept on the
    stream: ``info`` (the start: design, outputs, method, tare settings), ``bad``
    (``(kind, message)`` per bad frame), ``events`` (``(event, message)``: connected,
    disconnected, reconnected, clock), ``tares`` (a dict per change of the tare:
    ``state`` waiting / resting / refused, ``origin``, ``moving`` gratings,
    ``baseline_nm``, ``message``), ``summary`` once the stream has ended. Call
    :meth:`tare` to tare again while it runs; use it as a context manager, or call
    :meth:`close`, to stop early.

    The iteration stops when the stream ends: a file read to its end, a finite stream
    that says it ended, a limit. When the source is lost (reconnecting given up, the
    log deleted) it ends with :class:`InstrumentLostError` (a ``ConnectionError``)
    carrying the summary, unless ``raise_on_lost=False`` was given to :func:`live`.
    """

    def __init__(self, inner, raise_on_lost):
        self._inner = inner
        self._raise = raise_on_lost
        self.info = None
        self.bad = []
        self.events = []
        self.tares = []
        self.summary = None
        self._outputs = None

    def __iter__(self):
        return self

    def _await_start(self):
        while self.info is None:
            kind, payload = next(self._inner)
            if kind == "frame":  # pragma: no cover - the start always comes first
                raise RuntimeError("internal: a reading before the start")
            self._take(kind, payload)

    def _take(self, kind, payload):
        if kind == "start":
            self.info = payload
            self._outputs = list(payload.get("outputs", []))
        elif kind == "bad":
            self.bad.append(tuple(payload))
        elif kind == "event":
            self.events.append(tuple(payload))
        elif kind == "tare":
            self.tares.append(payload)
        elif kind == "summary":
            self.summary = payload
            if payload.get("source_lost") and self._raise:
                raise InstrumentLostError(payload["ended"], payload)

    def __next__(self):
        while True:
            kind, payload = next(self._inner)
            if kind == "frame":
                return LiveFrame(payload, self._outputs)
            self._take(kind, payload)

    def tare(self):
        """Tare again: the frames are not read until the sensor has been at rest for
        a tare window (``tares`` records the change, origin ``"python"``)."""
        self._inner.tare()

    def close(self):
        """Stop reading (the summary is still given by the next iteration)."""
        self._inner.stop()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False


def live(
    design,
    source,
    *,
    tare_frames=50,
    tare_s=1.0,
    tare_wait_s=30.0,
    window_nm=None,
    method=None,
    resolution_pm=0.5,
    budget_us=100.0,
    core=None,
    case=None,
    insert=None,
    fidelity="auto",
    k=None,
    calibration=None,
    format=None,
    date_order=None,
    from_start=False,
    idle_exit_s=None,
    give_up_s=30.0,
    frames=None,
    duration_s=None,
    queue=8192,
    realtime=False,
    raise_on_lost=True,
):
    """Read a running interrogator stream frame by frame: an iterator of readings.

    Parameters
    ----------
    design : Design or path
        An array (cell loads) or a module (force per strain grating).
    source : str or path
        A log file being written (ENLIGHT, I-MON, CSV), ``"-"`` for standard input,
        or ``"hyperion://HOST[:PORT]"`` / ``"tcp://HOST:PORT"``.
    tare_frames : int, default 50
        Frames the tare window holds at least (0: no tare, shifts from the design's
        nominal wavelengths). The tare is taken only from a window in which every
        grating's spread and trend are within ``resolution_pm``.
    tare_s : float, default 1.0
        Frame time the tare window spans at least, s.
    tare_wait_s : float, default 30
        After the first full window, how long to wait for one at rest before
        refusing to read (naming the moving gratings) until :meth:`LiveStream.tare`.
    window_nm, method, resolution_pm, budget_us : optional
        As for :func:`reconstruct` and ``fbgforge live``.
    core, case, insert, fidelity : optional
        Module: the configuration whose K turns shifts into forces.
    k : dict, optional
        Module: calibrated K per grating, pm/N (``{"lambda_21": -170.5}``).
    calibration : path, optional
        Module: calibrated K from a ``verify --json`` report.
    format, date_order, from_start, idle_exit_s : optional
        Log file: format, date order, replay the rows already written, stop after
        the file has not grown for this long (s).
    give_up_s : float, default 30
        Hyperion: stop after failing to (re)connect for this long, s.
    frames, duration_s : optional
        Stop after this many readings, or this long (s).
    queue : int, default 8192
        Frames the queue holds: an instrument's frames that find it full are
        dropped (and counted); a file or standard input waits (none is lost).
    realtime : bool, default False
        Read a file or standard input at the pace it comes, dropping (and
        counting) frames that find the queue full.
    raise_on_lost : bool, default True
        End with :class:`InstrumentLostError` when the source is lost.

    Returns
    -------
    LiveStream
        Iterate for :class:`LiveFrame` readings.

    Examples
    --------
    >>> import fbgforge, tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     s = fbgforge.synth_log("designs/clip-on-34mm.toml", tmp, format="csv", rate_hz=10)
    ...     rows = fbgforge.read_log(s.log).rows
    ...     stream = fbgforge.live("designs/clip-on-34mm.toml", s.log, from_start=True,
    ...                            idle_exit_s=0.3, tare_frames=10, tare_s=0.5)
    ...     forces = [frame.forces_n for frame in stream]
    >>> len(forces) + stream.summary["tare_frames"] == rows, stream.summary["source_lost"]
    (True, False)
    >>> stream.tares[-1]["state"], stream.summary["dropped"]["total"]
    ('resting', 0)
    """
    src = os.fspath(source) if isinstance(source, os.PathLike) else str(source)
    with design_file(design) as dpath:
        inner = _fbgforge.live_stream(
            dpath,
            src,
            int(tare_frames),
            float(tare_s),
            float(tare_wait_s),
            window_nm,
            method,
            float(resolution_pm),
            float(budget_us),
            core,
            case,
            insert,
            fidelity,
            {str(g): float(v) for g, v in (k or {}).items()},
            _path(calibration, "calibration"),
            format,
            date_order,
            bool(from_start),
            idle_exit_s,
            float(give_up_s),
            frames,
            duration_s,
            int(queue),
            bool(realtime),
        )
        stream = LiveStream(inner, raise_on_lost)
        # A temporary copy of the design must outlive the run's start: the run's
        # thread loads it before it sends the start.
        stream._await_start()
    return stream
