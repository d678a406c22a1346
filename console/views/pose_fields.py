"""The selected object's typed pose: *Centre x / y / z [m]* and *Yaw [deg]* text fields, checked on the server.

They are text fields, not viser number inputs: a browser's number input sends nothing for what is not a number
(``abc``, ``nan``, ``inf``: the field shows empty) and rewrites ``1e308`` as ``1308``, so the server would keep
its last value, even one from a refused move, and move the object with a number the operator never saw. Here
every typed text reaches the check (:func:`typed_pose`, built on the Goal fields' parser
:func:`~console.views.picking.typed_number`) and a bad one is refused naming its field. After any refused move
the view puts the object's real pose back into the fields (:meth:`PoseFields.show`).
"""

from __future__ import annotations

import math
from typing import Any, Sequence

from planner.grid import Workspace

from console.session.session_types import SessionError
from console.views.picking import typed_number, typed_xyz

FAR_M = 1.0
"""[m] how far outside the workspace a centre may be typed (as ``Session.move_object`` allows)."""
MAX_YAW_DEG = 360.0
"""[deg] a typed yaw is within +-this."""
Vec3 = tuple[float, float, float]


def typed_pose(centre: Sequence[Any], yaw: Any, workspace: Workspace) -> tuple[Vec3, float]:
    """The pose typed in the fields: ``(centre, yaw)``, centre = box centre in the world frame [m], yaw [rad] about +z.

    Args:
        centre: The three typed values x, y, z (text or numbers) [m].
        yaw: The typed heading [deg].
        workspace: Each centre coordinate must lie within its bounds widened by :data:`FAR_M`.

    Raises:
        SessionError: Naming the first bad field: ``centre.x: must be a number [m], got 'abc'``,
            ``centre.y: must be a finite number [m], got 'nan'``, ``centre.x: 1e+308 m is far outside the
            workspace (-1.00 to 6.00 m)``, ``yaw: must be within -360..360 deg, got '1e308'``.
    """
    xyz = typed_xyz(centre, "centre")
    for axis, name in enumerate("xyz"):
        lo, hi = float(workspace.min[axis]) - FAR_M, float(workspace.max[axis]) + FAR_M
        if not lo <= xyz[axis] <= hi:
            raise SessionError(f"centre.{name}: {xyz[axis]:g} m is far outside the workspace ({lo:.2f} to {hi:.2f} m)")
    deg = typed_number(yaw, "yaw", "deg")
    if not -MAX_YAW_DEG <= deg <= MAX_YAW_DEG:
        raise SessionError(f"yaw: must be within {-MAX_YAW_DEG:g}..{MAX_YAW_DEG:g} deg, got {yaw!r}")
    return (xyz[0], xyz[1], xyz[2]), math.radians(deg)


class PoseFields:
    """The four text fields in the current GUI container (viser ``gui``), labelled so screen readers find them.

    Attributes:
        centre: The Centre x / y / z [m] text handles (world frame).
        yaw: The Yaw [deg] text handle (about +z).
    """

    def __init__(self, gui: Any) -> None:
        self.centre = tuple(gui.add_text(f"Centre {n} [m]", "0.000", hint=f"Box centre in the world frame: {n} [m]")
                            for n in "xyz")
        self.yaw = gui.add_text("Yaw [deg]", "0.0", hint="Heading about +z in the world frame [deg]")

    def show(self, position: Sequence[float], yaw: float) -> None:
        """Put a pose into the fields: ``position`` (world [m], 3 decimals) and ``yaw`` [rad] (shown in degrees, 1 decimal)."""
        texts = [f"{float(v):.3f}" for v in position] + [f"{math.degrees(yaw):.1f}"]
        for handle, text in zip((*self.centre, self.yaw), texts):
            if str(handle.value) != text:
                handle.value = text

    def typed(self) -> tuple[tuple[str, str, str], str]:
        """The fields as typed (text): ``((x, y, z), yaw)``."""
        return tuple(str(h.value) for h in self.centre), str(self.yaw.value)  # type: ignore[return-value]

    def read(self, workspace: Workspace) -> tuple[Vec3, float]:
        """The typed pose checked (:func:`typed_pose`): centre (world [m]) and yaw [rad]; :class:`SessionError` if bad."""
        centre, yaw = self.typed()
        return typed_pose(centre, yaw, workspace)
