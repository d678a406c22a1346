"""The route panel's buttons follow the latest route even when a mission-state event and a new goal cross
(console/views/paths_view.py; no browser: the server-side GUI handles).

The interleaving is forced, not timed: the RUN handler's route read is held (an event) until a new goal's
route redraw has been given its chance to run. Before the fix the RUN handler read the route outside the
panel's lock and then wrote the stale "no candidate" state over the newer redraw: Register stayed disabled.
"""

from __future__ import annotations

import threading
from pathlib import Path

import pytest
import viser

from console.app import wait_until
from console.session.session import RUN, Session
from console.views.paths_view import PathsView


@pytest.fixture()
def server() -> viser.ViserServer:
    srv = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    yield srv
    srv.stop()


def test_a_stale_route_read_does_not_disable_register(server: viser.ViserServer, tmp_path: Path,
                                                       monkeypatch: pytest.MonkeyPatch) -> None:
    session = Session(tmp_path / "session", start=(2.5, 0.7, 0.0), autosave=False)
    view = PathsView(server, session)
    register = view._edit["Register"]
    assert register.disabled  # no candidate yet

    real = session.route_snapshot
    held, release = threading.Event(), threading.Event()
    run_thread: list[threading.Thread] = []

    def slow_snapshot() -> object:  # the RUN handler's read: taken now, returned after the goal's redraw tried
        snap = real()
        if threading.current_thread() in run_thread:
            held.set()
            assert release.wait(30), "the test's release never came"
        return snap

    monkeypatch.setattr(session, "route_snapshot", slow_snapshot)
    t = threading.Thread(target=view._on_event, args=(RUN, None), daemon=True)
    run_thread.append(t)
    t.start()
    assert held.wait(30), "the RUN handler never read the route"

    goal = threading.Thread(target=lambda: session.add_goal((2.5, 2.0, 0.0)), daemon=True)
    goal.start()
    assert wait_until(lambda: real().candidate is not None, 30), "the goal was not planned"
    goal.join(2.0)  # before the fix its redraw finishes here; after it, the redraw waits for the RUN handler's lock
    release.set()
    t.join(30)
    goal.join(30)
    assert not t.is_alive() and not goal.is_alive()
    assert session.route_snapshot().candidate is not None
    assert not register.disabled, "a route read before the new goal disabled Register after the goal enabled it"
