"""Shared fixtures of the session tests."""

from __future__ import annotations

import functools
from pathlib import Path

import pytest


@pytest.fixture()
def rig(tmp_path: Path, monkeypatch: pytest.MonkeyPatch):
    """The simulated robot in the paper's room at time x10 with a Go look job (``rig.go_look``), no battery
    drain in flight: at time x10 each hover capture's mapping (wall time, long on a loaded machine) is ten
    times longer in the air; the battery rules have their own tests."""
    import console.link.sim_config as sim_config
    from console.cli.search_cmd import HeadlessRig
    from console.link.world_file import paper_world
    from console.session.go_look import GoLookJob

    monkeypatch.setattr(sim_config, "SimConfig", functools.partial(sim_config.SimConfig, drain_fly=0.0))
    r = HeadlessRig(paper_world(), tmp_path / "session", time_scale=10.0)
    r.go_look = GoLookJob(r.session, r.robot, r.mapping, r.runner)
    yield r
    r.go_look.stop()
    r.go_look.wait(60)
    r.close()
