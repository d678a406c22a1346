"""The shape the console's background jobs share: one worker thread at a time, and Pause / Resume / Stop.

- :class:`BackgroundRun`: one worker thread at a time (``running``, ``wait``); a run that said it
  ended (its last job update) reads ``running == False`` at once, though its thread may still be
  finishing, so panels redrawn on that last update see it ended. Capture & map
  (:mod:`console.session.mapping_job`) is one.
- :class:`JobThread`: a :class:`BackgroundRun` the operator can pause, resume and stop (Look around /
  Look at, Go look, Find). The worker checks the events at its own points (between turns,
  captures, moves); :meth:`JobThread._wait_resumed` blocks it while paused. Each job keeps its own
  ``pause`` / ``resume`` / ``stop`` (what they do to the robot and the words of their refusals differ)
  and calls the ``_request_*`` helpers here for the events.

Attribute names (``_lock``, ``_thread``, ``_ended``, ``_pause``, ``_stop``) are the ones the jobs'
mixins (:mod:`console.session.search_moves`, :mod:`console.session.search_finish`) read.
"""

from __future__ import annotations

import threading
from typing import Any, Callable

from console.session.session import JobStatus, Session, SessionError

POLL = 0.05
"""Longest a paused worker sleeps between looks at its events [s] (Resume / Stop wake it at once)."""


class BackgroundRun:
    """One worker thread at a time.

    Args:
        lock: Guards the thread and the job's own start-time state (a re-entrant one when the job's
            start reports progress whose listeners read the job); a plain :class:`threading.Lock` by default.
    """

    def __init__(self, lock: Any = None) -> None:
        self._lock = lock if lock is not None else threading.Lock()
        self._thread: threading.Thread | None = None
        self._ended = False  # the run said it ended (its thread may still be finishing)

    @property
    def running(self) -> bool:
        """A run is under way and has not said it ended."""
        with self._lock:
            # ended once it said so: its last event must already read 'not running' (the panels redraw on it)
            return self._thread is not None and self._thread.is_alive() and not self._ended

    def wait(self, timeout: float | None = None) -> bool:
        """Wait for the run's thread to end, at most ``timeout`` [s]; ``True`` when none is running."""
        with self._lock:
            t = self._thread
        if t is not None:
            t.join(timeout)
            return not t.is_alive()
        return True

    def _alive(self) -> bool:
        """The worker thread is alive (call with ``self._lock`` held)."""
        return self._thread is not None and self._thread.is_alive()

    def _launch(self, target: Callable[..., None], name: str, args: tuple[Any, ...] = (),
                announce: Callable[[], None] | None = None) -> None:
        """Start ``target(*args)`` in a new daemon thread ``name``; call with ``self._lock`` held, after
        the job's own resets. ``announce`` (the 'starting' progress) runs before the thread starts, so
        no tab sees the worker's first line before it."""
        self._ended = False
        self._thread = threading.Thread(target=target, args=args, name=name, daemon=True)
        if announce is not None:
            announce()
        self._thread.start()


class JobThread(BackgroundRun):
    """A :class:`BackgroundRun` with Pause / Resume / Stop, reporting to the session's job line.

    Args:
        session: Where the job's progress goes (:meth:`_set_job`).
        lock: As :class:`BackgroundRun`.
    """

    def __init__(self, session: Session, lock: Any = None) -> None:
        super().__init__(lock)
        self._session = session
        self._pause = threading.Event()
        self._stop = threading.Event()
        self._wake = threading.Event()  # set by Resume / Stop: a paused worker carries on at once

    @property
    def paused(self) -> bool:
        """A run is under way and paused."""
        return self.running and self._pause.is_set()

    def _launch(self, target: Callable[..., None], name: str, args: tuple[Any, ...] = (),
                announce: Callable[[], None] | None = None) -> None:
        """As :meth:`BackgroundRun._launch`; a new run starts neither paused nor stopped."""
        self._pause.clear()
        self._stop.clear()
        self._wake.clear()
        super()._launch(target, name, args, announce)

    def _request_pause(self) -> None:
        self._pause.set()

    def _request_resume(self) -> None:
        self._pause.clear()
        self._wake.set()

    def _request_stop(self) -> None:
        self._stop.set()
        self._wake.set()

    def _wait_resumed(self, on_pause: Callable[[], None] | None = None, poll: float = POLL) -> bool:
        """The worker's pause point: while paused (and not stopped) call ``on_pause`` once (to say so)
        and wait for Resume or Stop; ``False`` when stopped."""
        if self._pause.is_set() and not self._stop.is_set():
            if on_pause is not None:
                on_pause()
            while self._pause.is_set() and not self._stop.is_set():
                self._wake.wait(poll)
                self._wake.clear()
        return not self._stop.is_set()

    def _robot_ready(self, link: Any, mapping: Any, already: str, before: str) -> Any:
        """The robot's latest state, when a job that moves the robot may start now.

        Args:
            link: The robot link (``latest_state``), or ``None``.
            mapping: The capture & map job (``running``).
            already: The refusal when this job runs already.
            before: Ends the refusal when a mission is under way (``abort it before {before}``).

        Raises:
            SessionError: This job runs, a capture is being mapped, a mission is under way, or no state
                from the robot.
        """
        if self.running:
            raise SessionError(already)
        if mapping.running:
            raise SessionError("a capture is being mapped: wait for it")
        if self._session.run.active:
            raise SessionError(f"a mission is under way (running or paused): abort it before {before}")
        st = link.latest_state() if link is not None else None
        if st is None or not getattr(st, "link_ok", False):
            raise SessionError("no state from the robot: is the link connected?")
        return st

    def _set_job(self, status: JobStatus) -> None:
        """Put ``status`` on the session's job line; a status that is not running marks the run ended
        first, so :attr:`running` reads ``False`` for whoever redraws on it."""
        if not status.running:
            self._ended = True
        self._session.set_job(status)


__all__ = ["BackgroundRun", "JobThread", "POLL"]
