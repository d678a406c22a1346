"""The panels' redraw worker: events from many threads, one redraw at a time, and the last redraw always
reads the latest state (an older redraw can no longer hide a button a newer state showed)."""

from __future__ import annotations

import threading
import time

from console.app import wait_until
from console.views.refresher import Refresher


def test_the_last_redraw_shows_the_latest_state_whatever_the_threads_do() -> None:
    state = {"n": 0}
    drawn: list[int] = []
    inside = threading.Semaphore(1)
    overlaps: list[int] = []

    def draw() -> None:
        if not inside.acquire(blocking=False):
            overlaps.append(1)
            return
        try:
            seen = state["n"]
            time.sleep(0.001)  # a slow redraw: the state moves on meanwhile
            drawn.append(seen)
        finally:
            inside.release()

    r = Refresher(draw, "test-refresh")
    try:
        def events(k: int) -> None:
            for _ in range(50):
                state["n"] += 1
                (r.poke if k % 2 else r.now)()

        threads = [threading.Thread(target=events, args=(k,)) for k in range(4)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        final = state["n"]
        assert wait_until(lambda: drawn and drawn[-1] == final, 30.0, 0.01), (drawn[-5:], final)
        assert not overlaps  # never two redraws at once
        assert len(drawn) < 200 + 1  # pokes in a burst coalesce (at most one redraw per call)
    finally:
        r.close()


def test_a_poke_during_a_redraw_causes_one_more() -> None:
    started, release = threading.Event(), threading.Event()
    calls: list[int] = []

    def draw() -> None:
        calls.append(1)
        if len(calls) == 1:
            started.set()
            release.wait(30.0)

    r = Refresher(draw, "test-refresh")
    try:
        r.poke()
        assert started.wait(30.0)
        r.poke()
        r.poke()  # two pokes while the first redraw runs: one more redraw
        release.set()
        assert wait_until(lambda: len(calls) == 2, 30.0, 0.01), calls
    finally:
        r.close()
