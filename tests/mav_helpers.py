"""Shared set-up of the MAVLink fault tests: a link on a free UDP port and an emulator with faults."""

from __future__ import annotations

import contextlib
import time
from dataclasses import replace
from typing import Any, Callable, Iterator

from console.link.manager import MissionManager
from console.link.mavlink import GroundMotion, MavlinkConfig, MavlinkLink
from console.link.ned import NedFrame
from mav_emulator import ArduCopterEmulator

ORIGIN = (2.5, 0.7, 0.0)  # world position of the vehicle's NED origin (where it starts)
CFG = MavlinkConfig(ned=NedFrame(origin=ORIGIN), ack_timeout=0.25, retries=4, heartbeat_timeout=1.0,
                    pose_timeout=0.5, setpoint_rate=10.0, fly_speed=4.0, climb_rate=3.0, descent_rate=3.0,
                    timeout_slack=5.0, ground=GroundMotion(speed=2.0), settle_timeout=4.0, ready_timeout=10.0,
                    command_max_age=2.0, nack_window=0.4)


@contextlib.contextmanager
def vehicle(config: MavlinkConfig = CFG, faults: dict[str, Any] | None = None, wait_ok: bool = True,
            tlog: Any = None, **emu: Any) -> Iterator[tuple[MavlinkLink, ArduCopterEmulator]]:
    """A connected link and a running emulator; ``faults`` are emulator attributes set before start."""
    link = MavlinkLink("udpin:127.0.0.1:0", config, tlog=tlog)  # port 0: a free port, tests run in parallel
    link.open()
    sim = ArduCopterEmulator(link.local_port, **emu)
    for k, v in (faults or {}).items():
        setattr(sim, k, v)
    sim.start()
    try:
        link.connect(timeout=20.0)
        if wait_ok:
            assert eventually(lambda: link.latest_state() is not None and link.latest_state().health == "ok", 30.0), \
                link.latest_state()
        yield link, sim
    finally:
        for m in [m for m in _managers if m.link is link]:
            m.close()
            _managers.remove(m)
        link.close()
        sim.stop()


_managers: list[MissionManager] = []


def mission_manager(link: MavlinkLink, **kw: Any) -> MissionManager:
    """A MissionManager closed (mission aborted, worker joined) when its :func:`vehicle` ends."""
    m = MissionManager(link, **kw)
    _managers.append(m)
    return m


def eventually(check: Callable[[], Any], timeout: float = 30.0, poll: float = 0.02) -> bool:
    """Poll ``check`` until truthy or ``timeout`` [s]; returns the last result's truth.

    The time-out is generous (a loaded 2-core CI machine): it costs nothing when the state arrives."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if check():
            return True
        time.sleep(poll)
    return bool(check())


def events(manager: MissionManager) -> list[str]:
    return [e.message for e in manager.events]


def config(**changes: Any) -> MavlinkConfig:
    return replace(CFG, **changes)
