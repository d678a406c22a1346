"""A surface a few centimetres above the floor (a 5 cm sports mat) is an obstacle in the known space when
the depth is exact (the simulator's render), so an unmapped mat closes the floor round it for walking and
landing; with a depth model's noise the floor band stays 10 cm (only the detector can map such a mat).

Before, every surface up to 10 cm was floor: the search landed on the paper room's unmapped mat ("landing
stopped: contact with an unmapped obstacle ahead at (0.38, 7.62, 0.05)").
"""

from __future__ import annotations

import math

import numpy as np

from pipeline.camera.geometry import CameraMount, Intrinsics, Pose, camera_pose_in_world
from pipeline.mapping.known_space import KnownSpace, KnownState, unlabelled_cells
from pipeline.mapping.known_space_update import (
    FLOOR_BAND, FLOOR_BAND_EXACT, DepthNoise, box_depth, capture_update,
)
from pipeline.scene import SceneObject

INTR = Intrinsics(525.0, 525.0, 319.5, 239.5, 640, 480)
CAM = camera_pose_in_world(Pose.from_xyz_yaw(0.8, 5.0, 0.0, math.pi / 2), CameraMount(position=(0.15, 0.0, 0.35)))
MAT = SceneObject("sports_mat-1", "sports_mat", (0.8, 7.3, 0.025), (1.0, 0.05, 1.0), 0.0)  # the paper room's


def _space() -> KnownSpace:
    return KnownSpace.empty((0.0, 0.0, 0.0), (5.0, 8.0, 3.0), 0.25)


def _mat_cells(space: KnownSpace) -> np.ndarray:
    """The floor cells (k = 0) the mat's footprint overlaps."""
    centres = space.centers(np.argwhere(np.ones(space.shape, dtype=bool)))
    half = 0.5 + space.resolution / 2
    on = (np.abs(centres[:, 0] - 0.8) < half) & (np.abs(centres[:, 1] - 7.3) < half) & (centres[:, 2] < 0.25)
    return on.reshape(space.shape)


def test_an_exact_depth_sees_a_5_cm_mat_as_an_obstacle_and_the_bare_floor_as_floor() -> None:
    assert FLOOR_BAND_EXACT < MAT.size[1] < FLOOR_BAND
    up = capture_update(_space(), box_depth([MAT], INTR, CAM), INTR, CAM)  # exact depth: noise 0
    st = up.space.state()
    mat = _mat_cells(up.space)
    assert np.count_nonzero(st[mat] == KnownState.OCCUPIED) >= 6, st[mat]  # the mat's seen part
    occupied = st == KnownState.OCCUPIED
    assert not np.any(occupied & ~mat)  # nothing else: the bare floor round it is floor
    assert st[up.space.cell_of((0.8, 6.0, 0.05))] == KnownState.FREE
    unl = unlabelled_cells(up.space, [])
    assert np.array_equal(unl, occupied)  # not mapped: unlabelled obstacle cells the planner closes
    assert not unlabelled_cells(up.space, [MAT]).any()  # mapped: explained by the mat


def test_a_noisy_depth_keeps_the_10_cm_floor_band() -> None:
    up = capture_update(_space(), box_depth([MAT], INTR, CAM), INTR, CAM, noise=DepthNoise(relative=0.05))
    assert up.occupied_cells == 0  # the mat is floor to a depth model: only the detector can map it
    up = capture_update(_space(), box_depth([MAT], INTR, CAM), INTR, CAM, floor_band=FLOOR_BAND)
    assert up.occupied_cells == 0  # the band can still be set


def test_the_simulators_render_marks_the_paper_rooms_mat_and_nothing_else_on_the_floor() -> None:
    from console.link.sim import SimRobot

    robot = SimRobot(start=Pose.from_xyz_yaw(0.8, 5.0, 0.0, math.pi / 2), manual_clock=True)
    robot.connect()
    try:
        shot = robot.capture()
    finally:
        robot.close()
    assert shot.ground_truth is not None and shot.ground_truth.depth is not None
    depth = np.nan_to_num(np.asarray(shot.ground_truth.depth, dtype=np.float64), nan=0.0, posinf=0.0)
    up = capture_update(_space(), depth, shot.intrinsics, shot.camera_pose)
    st = up.space.state()
    mat = _mat_cells(up.space)
    assert np.count_nonzero(st[mat] == KnownState.OCCUPIED) >= 4
    truth = [o for o in shot.ground_truth.objects if o.label != "sports_mat"]
    stray = unlabelled_cells(up.space, truth) & ~mat
    floor = np.zeros(st.shape, dtype=bool)
    floor[:, :, 0] = True
    assert not np.any(stray & floor), up.space.centers(np.argwhere(stray & floor))  # the rendered floor is floor
