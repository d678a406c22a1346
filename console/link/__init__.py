"""Robot links: the simulated robot and MAVLink vehicles behind one interface.

``open_link(spec)`` builds (and connects) a link from a command-line spec:

- ``sim``: the built-in simulated robot in the paper's room (:class:`~console.link.sim.SimRobot`);
- ``mavlink:<pymavlink connection>``: an ArduPilot vehicle, e.g. ``mavlink:udpin:127.0.0.1:14550``
  (ArduPilot SITL ``--out=udp:127.0.0.1:14550``), ``mavlink:tcp:127.0.0.1:5760`` or
  ``mavlink:/dev/ttyACM0,57600`` (:class:`~console.link.mavlink.MavlinkLink`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from console.link.base import (CaptureResult, CommandRejected, GroundTruth, LinkError, LinkTimeout, Mode, RobotLink,
                   RobotState, RunStatus, SegmentRun, VisibleObject)

LINK_SPECS = ("sim", "mavlink:udpin:HOST:PORT", "mavlink:udpout:HOST:PORT", "mavlink:tcp:HOST:PORT",
              "mavlink:/dev/ttyACM0,BAUD")
"""The forms :func:`open_link` accepts, for help texts."""


def open_link(spec: str, *, connect: bool = True, timeout: float = 10.0,
              captures: str | Path | None = None, **kw: Any) -> RobotLink:
    """Build the link named by ``spec`` and (by default) connect it.

    Args:
        spec: ``sim`` or ``mavlink:<connection>`` (see the module docstring).
        connect: Connect before returning (waits up to ``timeout`` [s] for a MAVLink vehicle).
        captures: Folder of photos served as the robot's camera (``--captures DIR``).
        **kw: Passed to :class:`~console.link.sim.SimRobot` (``world``, ``start``, ``config``,
            ``intrinsics``, ``mount``) or :class:`~console.link.mavlink.MavlinkLink` (``config``,
            ``camera``, ``mount``).

    Raises:
        LinkError: Unknown spec, bad connection string, or no vehicle within ``timeout``.
    """
    text = (spec or "").strip()
    link: RobotLink
    if text == "sim" or text.startswith("sim:"):
        from console.link.sim import SimRobot

        if text not in ("sim", "sim:"):
            raise LinkError(f"robot {spec!r}: the simulator takes no address, use 'sim'")
        try:
            link = SimRobot(captures=captures, **kw)
        except TypeError as exc:
            raise LinkError(f"robot 'sim': {exc}") from None
    elif text.startswith("mavlink:"):
        from console.link.mavlink import MavlinkLink

        try:
            link = MavlinkLink(text[len("mavlink:"):], captures=captures, **kw)
        except TypeError as exc:
            raise LinkError(f"robot {spec!r}: {exc}") from None
    else:
        raise LinkError(f"unknown robot {spec!r}: expected one of {', '.join(LINK_SPECS)}")
    if connect:
        link.connect(timeout)
    return link


__all__ = ["open_link", "LINK_SPECS", "RobotLink", "RobotState", "Mode", "CaptureResult", "GroundTruth",
           "VisibleObject", "SegmentRun", "RunStatus", "LinkError", "LinkTimeout", "CommandRejected"]
