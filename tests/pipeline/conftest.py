"""Shared fixtures of the pipeline tests: one capture of the simulated robot in the paper's room (the line of
boxes) from a camera pose, and its ground-truth map.

``sim_shot(x, y, z, yaw_deg, mount=..., **robot_options)``: the robot placed at ``(x, y, z)`` [m] (world frame,
z up) facing ``yaw_deg`` [deg] counter-clockwise from +x (no pose: the simulator's start), its camera on
``mount`` (:class:`pipeline.camera.geometry.CameraMount`, default the simulator's), one photo taken
(:class:`console.link.captures.CaptureResult`). ``gt_map(shot, mount, **run_options)``: that photo through the
mapper with the render's ground truth as the models (:func:`console.session.mapping_job.ground_truth_bundle_for`),
mapped with ``mount`` (the camera pose the mapper is told, which a test may set wrong on purpose; default the
shot's own): the :class:`pipeline.mapper.MapResult`.
"""

from __future__ import annotations

import math
from typing import Any, Callable

import pytest


def take_sim_shot(x: float | None = None, y: float | None = None, z: float = 0.0, yaw_deg: float = 90.0,
                  mount: Any = None, **robot_options: Any) -> Any:
    """One capture of the simulated robot (see the module's text); ``x``/``y`` ``None``: its start pose."""
    from console.link.sim import SimRobot
    from pipeline.camera.geometry import Pose

    if x is not None and y is not None:
        robot_options["start"] = Pose.from_xyz_yaw(x, y, z, math.radians(yaw_deg))
    if mount is not None:
        robot_options["mount"] = mount
    robot = SimRobot(manual_clock=True, **robot_options)
    robot.connect()
    try:
        return robot.capture()
    finally:
        robot.close()


def map_ground_truth(shot: Any, mount: Any = None, catalog: Any = None, **run_options: Any) -> Any:
    """The ground-truth map of ``shot`` (see the module's text)."""
    from console.session.mapping_job import ground_truth_bundle_for
    from pipeline.catalog import default_catalog
    from pipeline.mapper import Mapper

    with Mapper(ground_truth_bundle_for(shot), catalog if catalog is not None else default_catalog()) as mapper:
        return mapper.run(shot.image, shot.intrinsics, shot.mount if mount is None else mount, shot.robot_pose,
                          **run_options)


@pytest.fixture(scope="session")
def sim_shot() -> Callable[..., Any]:
    """:func:`take_sim_shot`: a capture of the simulated robot at a camera pose."""
    return take_sim_shot


@pytest.fixture(scope="session")
def gt_map() -> Callable[..., Any]:
    """:func:`map_ground_truth`: a capture's ground-truth map."""
    return map_ground_truth
