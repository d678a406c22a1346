"""The proxy models are y-up as glTF 2.0 says (up +Y, front +Z, left +X): upright in trimesh's glTF convention
(trimesh loads glTF vertices as stored), and placed the same by the console's viser view as in the object frame."""

from __future__ import annotations

import math

import numpy as np
import pytest
import trimesh
from scipy.spatial.transform import Rotation

from pipeline.catalog import default_catalog, load_proxy_mesh
from pipeline.rotation import yaw_gltf_quat_wxyz

CATALOG = default_catalog()


def _raw(name: str) -> np.ndarray:
    """The vertices as stored in the GLB (no axis conversion), bounds [-0.5, 0.5]^3."""
    mesh = trimesh.load(CATALOG.get(name).model_path, force="mesh", process=False)
    return np.asarray(mesh.vertices, dtype=np.float64)


def test_a_person_stands_up_along_plus_y() -> None:
    v = _raw("person")
    assert v[:, 1].min() == pytest.approx(-0.5, abs=1e-6)  # feet
    head = v[v[:, 1] > 0.4]
    assert len(head) and np.ptp(head[:, 0]) < 0.5  # the head is narrow across the body (X = left)


@pytest.mark.parametrize("name", ["chair", "office_chair", "sofa", "toilet"])
def test_seats_face_plus_z_with_the_back_up_behind(name: str) -> None:
    v = _raw(name)
    top = v[v[:, 1] > 0.35]
    assert len(top) and top[:, 2].mean() < -0.1  # glTF front is +Z: the backrest is at -Z, up is +Y


def test_load_proxy_mesh_gives_the_object_frame() -> None:
    raw, obj = _raw("person"), load_proxy_mesh(CATALOG.get("person").model_path).vertices
    np.testing.assert_allclose(obj, raw[:, [2, 0, 1]], atol=1e-9)  # object (x, y, z) = glTF (Z, X, Y)


@pytest.mark.parametrize("yaw", [0.0, 0.7, -2.5])
def test_the_viser_pose_places_the_glb_like_the_object_frame(yaw: float) -> None:
    """viser: rotate the stored vertices by yaw_gltf_quat_wxyz after scaling them by [w, h, l] along the file's
    axes; the same points as the object-frame mesh scaled by (l, w, h) and turned by the yaw."""
    w, h, l = 0.5, 0.9, 1.6
    raw = _raw("office_chair")
    qw, qx, qy, qz = yaw_gltf_quat_wxyz(yaw)
    placed = Rotation.from_quat((qx, qy, qz, qw)).apply(raw * (w, h, l))
    obj = load_proxy_mesh(CATALOG.get("office_chair").model_path).vertices
    expected = Rotation.from_euler("z", yaw).apply(obj * (l, w, h))
    np.testing.assert_allclose(placed, expected, atol=1e-9)
    assert math.isclose(placed[:, 2].max() - placed[:, 2].min(), h, rel_tol=1e-9)  # upright: h along world z
