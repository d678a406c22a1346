"""Loading the perception models in the background at console start, with progress in the page.

:class:`ModelPreload` runs the perceiver's ``preload(progress)`` (see
:class:`~console.session.mapping_job.MapperPerceiver`) in a thread as soon as the console starts, so the first
Capture & map costs no more than the next. Its progress goes to the session's job status (the
progress bar every tab shows) under :data:`PRELOAD_NAME`; a failure (e.g. missing weights) is shown
there and as an error notice, never raised: the console stays up, and Capture & map tries again.

A capture requested before the models are ready waits for them (:meth:`ModelPreload.wait_ready`);
while it waits, the mapping job shows the loading progress in its own status instead.
"""

from __future__ import annotations

import logging
import threading
import time
from typing import Any, Callable

from console.session.session import JobStatus, Session
from console.session.session_types import MappingError

log = logging.getLogger(__name__)

PRELOAD_NAME = "Loading models"

WaitProgress = Callable[[float, str], None]
"""``on_progress(fraction of the loading in [0, 1], what is being loaded)``."""


class ModelPreload:
    """Loads a perceiver's models once, in a background thread.

    States: ``idle`` (not started), ``loading``, ``ready``, ``failed`` (:attr:`error` says why).
    A perceiver without a ``preload`` method has nothing to load: it is ``ready`` once started.

    Args:
        session: Where the progress (job status) and a failure notice go.
        perceiver: The perception backend; its ``preload(progress)`` raises on failure.
    """

    def __init__(self, session: Session, perceiver: Any) -> None:
        self._session = session
        self._perceiver = perceiver
        self._cond = threading.Condition()
        self._state = "idle"
        self._fraction = 0.0
        self._message = "not started"
        self._error: str | None = None
        self._waiters = 0
        self._thread: threading.Thread | None = None
        self.seconds: float | None = None
        """Wall time of the loading [s], once it ended."""

    @property
    def state(self) -> str:
        with self._cond:
            return self._state

    @property
    def error(self) -> str | None:
        with self._cond:
            return self._error

    def start(self) -> None:
        """Start loading in the background (once; later calls do nothing)."""
        with self._cond:
            if self._state != "idle":
                return
            self._state, self._message = "loading", "starting"
            self._thread = threading.Thread(target=self._run, name="model-preload", daemon=True)
            self._thread.start()

    def wait_ready(self, on_progress: WaitProgress, timeout: float | None = None) -> bool:
        """Block while the models are not loaded yet (``idle`` or ``loading``), calling
        ``on_progress`` at once and at every change; ``True`` once ``ready`` or ``failed``
        (a failed loading is retried by the capture itself), ``False`` on ``timeout`` [s]."""
        end = None if timeout is None else time.monotonic() + timeout
        with self._cond:
            self._waiters += 1
            try:
                seen: tuple[float, str] | None = None
                while self._state in ("idle", "loading"):
                    now = (self._fraction, self._message)
                    if now != seen:
                        seen = now
                        self._cond.release()  # the callback may take the session's lock: not under ours
                        try:
                            on_progress(*now)
                        finally:
                            self._cond.acquire()
                        continue
                    left = None if end is None else end - time.monotonic()
                    if left is not None and left <= 0:
                        return False
                    self._cond.wait(left if left is not None else 1.0)
                return True
            finally:
                self._waiters -= 1

    def join(self, timeout: float | None = None) -> bool:
        """Wait for the loading thread; ``True`` if it is not running (any more)."""
        t = self._thread
        if t is not None:
            t.join(timeout)
            return not t.is_alive()
        return True

    # --- the loading thread ----------------------------------------------------------------------------
    def _progress(self, fraction: float, message: str) -> None:
        f = max(0.0, min(1.0, float(fraction)))
        with self._cond:
            self._fraction, self._message = f, str(message)
            quiet = self._waiters > 0  # a waiting capture shows the progress in its own status
            self._cond.notify_all()
        if not quiet:
            self._session.set_job(JobStatus(PRELOAD_NAME, True, f, str(message)), background=True)

    def _finish(self, state: str, error: str | None, seconds: float) -> None:
        with self._cond:
            self._state, self._error, self.seconds = state, error, seconds
            quiet = self._waiters > 0
            self._cond.notify_all()
        label = getattr(self._perceiver, "label", "perception")
        if state == "ready":
            log.info("perception models ready in %.1f s (%s)", seconds, label)
            if not quiet:
                self._session.set_job(JobStatus(PRELOAD_NAME, False, 1.0, f"models ready in {seconds:.1f} s"), background=True)
            return
        if not quiet:
            self._session.set_job(JobStatus(PRELOAD_NAME, False, 0.0, "failed", error), background=True)
        self._session.notify("Models not loaded", f"{error} Capture & map will try again.", "error")

    def _run(self) -> None:
        t0 = time.perf_counter()
        preload = getattr(self._perceiver, "preload", None)
        try:
            if preload is not None:
                preload(self._progress)
        except Exception as exc:  # MappingError carries an operator-facing message; anything else is a bug
            if not isinstance(exc, MappingError):
                log.exception("model preload crashed")
            text = str(exc) if isinstance(exc, MappingError) else f"internal error while loading the models: {exc!r}"
            self._finish("failed", text, time.perf_counter() - t0)
        else:
            self._finish("ready", None, time.perf_counter() - t0)
