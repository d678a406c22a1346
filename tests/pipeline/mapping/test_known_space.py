"""Known space: log-odds states, one capture's ray update, unlabelled cells, explained share, round trips."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pipeline.camera.geometry import CameraMount, Intrinsics, Pose, camera_pose_in_world
from pipeline.mapping.known_space import (
    LOG_HIT, LOG_MAX, LOG_MIN, LOG_MISS, KnownSpace, KnownSpaceError, KnownState, unlabelled_cells,
)
from pipeline.mapping.known_space_update import (
    DepthNoise, box_depth, capture_update, explained_share,
)
from pipeline.scene import SceneObject

INTR = Intrinsics(525.0, 525.0, 319.5, 239.5, 640, 480)
MOUNT = CameraMount(position=(0.15, 0.0, 0.35))
ROBOT = Pose.from_xyz_yaw(2.5, 0.7, 0.0, math.pi / 2)  # facing +y
CAM = camera_pose_in_world(ROBOT, MOUNT)


def _box(oid, x, y, size=(1.0, 1.0, 1.0), z0=0.0, yaw=0.0):
    return SceneObject(oid, "cardboard_box", (x, y, z0 + size[1] / 2), size, yaw)


def _space(res=0.25):
    return KnownSpace.empty((0.0, 0.0, 0.0), (5.0, 8.0, 3.0), res)


def test_states_from_hits_and_misses_each_cell_once() -> None:
    ks = _space()
    assert ks.is_blank() and ks.counts()["unknown"] == 20 * 32 * 12
    free = np.zeros(ks.shape, bool)
    occ = np.zeros(ks.shape, bool)
    free[1, 1, 0] = free[2, 2, 2] = True
    occ[2, 2, 2] = occ[3, 3, 3] = True  # in both: the hit wins
    ks2 = ks.updated(free, occ)
    st = ks2.state()
    assert st[1, 1, 0] == KnownState.FREE and st[2, 2, 2] == KnownState.OCCUPIED and st[0, 0, 0] == KnownState.UNKNOWN
    assert ks2.log_odds[1, 1, 0] == LOG_MISS and ks2.log_odds[2, 2, 2] == LOG_HIT
    assert ks.is_blank()  # immutable: the old one is unchanged
    many = ks2
    for _ in range(20):
        many = many.updated(free, occ)
    assert many.log_odds[1, 1, 0] == LOG_MIN and many.log_odds[3, 3, 3] == LOG_MAX  # clamped
    # a clamped occupied cell turns free after a few misses (the map can change its mind)
    miss_only = many
    n = 0
    while miss_only.state()[3, 3, 3] != KnownState.FREE:
        fr = np.zeros(ks.shape, bool)
        fr[3, 3, 3] = True
        miss_only = miss_only.updated(fr, np.zeros(ks.shape, bool))
        n += 1
        assert n < 20
    assert n == math.floor(LOG_MAX / -LOG_MISS) + 1


def test_round_trip_merge_and_bad_data() -> None:
    ks = _space()
    free = np.zeros(ks.shape, bool)
    free[:5, :5, 0] = True
    occ = np.zeros(ks.shape, bool)
    occ[10, 10, 1] = True
    ks = ks.updated(free, occ)
    d = ks.to_dict()
    assert len(d["data"]) < 400  # compact
    back = KnownSpace.from_dict(d)
    assert back.same_grid(ks) and np.array_equal(back.log_odds, ks.log_odds)
    merged = ks.merged(back)
    assert merged.log_odds[0, 0, 0] == 2 * LOG_MISS and merged.log_odds[10, 10, 1] == min(LOG_MAX, 2 * LOG_HIT)
    with pytest.raises(KnownSpaceError, match="different grids"):
        ks.merged(_space(0.125))
    for field, value, match in (("format", "x", "known_space.format"), ("shape", [20, 32], "known_space.shape"),
                                ("data", "!!", "known_space.data"), ("resolution", float("nan"), "resolution"),
                                ("origin", [0, 0, float("inf")], "known_space.origin")):
        with pytest.raises(KnownSpaceError, match=match):
            KnownSpace.from_dict({**d, field: value})
    with pytest.raises(KnownSpaceError, match="bounds_max.y"):
        KnownSpace.empty((0, 0, 0), (5, 0, 3), 0.25)


def test_a_capture_sees_free_space_up_to_a_wall_and_marks_its_surface() -> None:
    # a synthetic depth map: a vertical wall 3 m in front of the camera (world y = 0.85 + 3.0)
    depth = np.full((480, 640), 3.0, np.float32)
    up = capture_update(_space(), depth, INTR, CAM)
    st = up.space.state()
    ws_cell = up.space.cell_of
    assert up.rays > 1000 and up.hits > 0
    assert st[ws_cell((2.5, 2.0, 0.35))] == KnownState.FREE  # between the camera and the wall
    assert st[ws_cell((2.5, 3.9, 0.35))] == KnownState.OCCUPIED  # the wall's surface, y = 3.85
    assert st[ws_cell((2.5, 5.0, 0.35))] == KnownState.UNKNOWN  # behind it: unchanged
    assert st[ws_cell((2.5, 0.2, 2.5))] == KnownState.UNKNOWN  # behind the camera


def test_the_floor_is_no_obstacle_and_the_band_follows_the_noise() -> None:
    # only floor: every ray looking down ends on it; the floor is not an obstacle
    R = CAM.rotation.as_matrix()
    t = np.asarray(CAM.translation)
    u, v = np.meshgrid(np.arange(640.0), np.arange(480.0))
    dirs = np.stack([(u - INTR.cx) / INTR.fx, (v - INTR.cy) / INTR.fy, np.ones_like(u)], -1) @ R.T
    with np.errstate(divide="ignore"):
        z = np.where(dirs[..., 2] < 0, -t[2] / dirs[..., 2], 0.0)
    up = capture_update(_space(), z.astype(np.float32), INTR, CAM)
    assert up.occupied_cells == 0 and up.floor_hits > 100
    assert up.space.state()[up.space.cell_of((2.5, 2.0, 0.05))] == KnownState.FREE  # seen-free floor
    # a noisy wall: free stops sigma before the surface, the occupied band is 2 sigma thick
    depth = np.full((480, 640), 3.0, np.float32)
    exact = capture_update(_space(0.125), depth, INTR, CAM).space.state()
    noisy = capture_update(_space(0.125), depth, INTR, CAM, noise=DepthNoise(relative=0.1)).space.state()
    col = (20, slice(None), 3)
    assert int((noisy[col] == KnownState.OCCUPIED).sum()) > int((exact[col] == KnownState.OCCUPIED).sum()) + 2
    assert int((noisy[col] == KnownState.FREE).sum()) < int((exact[col] == KnownState.FREE).sum())
    with pytest.raises(KnownSpaceError, match="depth: must be 480 x 640"):
        capture_update(_space(), depth[:10], INTR, CAM)
    with pytest.raises(KnownSpaceError, match="noise.relative"):
        DepthNoise(relative=float("nan"))


def test_unlabelled_cells_and_explained_share() -> None:
    box = _box("b", 2.5, 3.5)
    hidden = _box("h", 1.2, 3.0, size=(0.6, 0.8, 0.6))
    depth = box_depth([box, hidden], INTR, CAM, pixel_step=1)
    ks = capture_update(_space(), depth, INTR, CAM).space
    occ = int((ks.state() == KnownState.OCCUPIED).sum())
    unl = unlabelled_cells(ks, [box])
    assert 0 < int(unl.sum()) < occ
    centres = ks.centers(np.argwhere(unl))
    assert np.all(np.abs(centres[:, 0] - 1.2) < 0.7)  # the unmapped box's cells
    assert int(unlabelled_cells(ks, [box, hidden]).sum()) == 0
    both = explained_share(depth, INTR, CAM, [box, hidden], (0, 0, 0), (5, 8, 3))
    one = explained_share(depth, INTR, CAM, [box], (0, 0, 0), (5, 8, 3))
    assert both.share == 1.0 and both.near_pixels > 100
    assert 0.0 < one.share < 1.0 and one.near_pixels == both.near_pixels
    assert explained_share(depth, INTR, CAM, [], (0, 0, 0), (5, 8, 3)).low


def test_box_depth_bounds_rays_without_a_depth_model() -> None:
    box = _box("b", 2.5, 3.35)  # its near face at y = 2.85: 2 m in front of the camera (y = 0.85)
    d = box_depth([box], INTR, CAM, pixel_step=1)
    assert d[240, 320] == pytest.approx(2.0, abs=1e-3)
    assert d[479, 320] == pytest.approx(0.35 * 525 / 239.5, rel=0.01)  # the floor at the bottom row
    assert d[0, 320] > 8.0  # above the box and the horizon: nothing within range


def test_the_robot_body_is_free_by_definition() -> None:
    occ = np.zeros(_space().shape, bool)
    occ[10, 2, 0] = True
    ks = _space().updated(np.zeros_like(occ), occ)
    body = ks.with_free_body((2.6, 0.6, 0.0), 0.35, 0.45)
    st = body.state()
    assert st[10, 2, 0] == KnownState.FREE and st[10, 2, 1] == KnownState.FREE and st[10, 2, 2] == KnownState.UNKNOWN
    assert st[10, 5, 0] == KnownState.UNKNOWN
