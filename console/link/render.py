"""Headless renderer of a scene: RGB, depth along the optical axis and instance masks.

Ray casting with trimesh and Intel Embree (the ``embreex`` wheel: no OpenGL, no display, pip only).
Each object is drawn with its catalog proxy model (``assets/proxy_models/<class>.glb``, object
frame x = length, y = width, z = up, bounds ``[-0.5, 0.5]^3``) scaled to its ``(l, w, h)``, turned
by its yaw about +z and moved to its box centre; a box in the catalog colour stands in when the
model file is missing. A room shell (tiled floor, walls, ceiling) closes the world so every ray
hits something.

Frames: scene objects and the room are in the world frame (z up) [m]; ``camera_pose`` is
``world <- camera`` with the camera in the OpenCV optical frame (x right, y down, z forward).
Pixel ``(u, v)`` looks along ``((u - cx) / fx, (v - cy) / fy, 1)``; lens distortion is ignored.
"""

from __future__ import annotations

import functools
import hashlib
import logging
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

import numpy as np

from pipeline.camera.geometry import Intrinsics, Pose
from pipeline.scene import Scene, SceneObject

log = logging.getLogger(__name__)

Vec3 = tuple[float, float, float]
RGB = tuple[int, int, int]

FLOOR_TILE = 0.5
"""Floor tile size [m] of the room's checkered floor."""


class RenderError(RuntimeError):
    """The renderer cannot run (missing ray-casting backend, bad input)."""


@dataclass(frozen=True)
class RenderResult:
    """One rendered view.

    Attributes:
        rgb: H x W x 3 uint8 image.
        depth: H x W float32 depth along the optical axis [m] (``inf`` where nothing was hit).
        instances: H x W int32: index into ``object_ids`` of the object seen at each pixel,
            ``-1`` for the room (floor, walls, ceiling) and misses.
        object_ids: Scene object ids, in index order.
        labels: Their labels, in index order.
    """

    rgb: np.ndarray
    depth: np.ndarray
    instances: np.ndarray
    object_ids: tuple[str, ...]
    labels: tuple[str, ...]


def _label_color(label: str) -> RGB:
    """A stable colour for a label without a catalog entry."""
    h = hashlib.sha1(label.encode()).digest()
    return (80 + h[0] % 150, 80 + h[1] % 150, 80 + h[2] % 150)


@functools.lru_cache(maxsize=64)
def _proxy_model(label: str) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """``(vertices, faces, face_colors 0..1)`` of a class's proxy model in the unit cube, or None."""
    try:
        from pipeline.catalog import default_catalog
    except ImportError:  # pragma: no cover - catalog module missing
        return None
    try:
        entry = default_catalog().lookup(label)
    except Exception as exc:  # a broken catalog file must not stop the simulator
        log.warning("catalog unavailable for rendering (%s); drawing boxes", exc)
        return None
    if entry is None or not Path(entry.model_path).is_file():
        return None
    return _load_unit_mesh(str(entry.model_path))


@functools.lru_cache(maxsize=64)
def _load_unit_mesh(path: str) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    import trimesh

    try:
        # glTF materials would hide the per-vertex colours (COLOR_0) the proxies carry
        mesh = trimesh.load(path, force="mesh", process=False, skip_materials=True)
    except Exception as exc:
        log.warning("cannot load proxy model %s: %s; drawing a box", path, exc)
        return None
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        return None
    from pipeline.catalog import object_from_gltf

    v = object_from_gltf(mesh.vertices)  # the file is y-up (glTF); the renderer works in the object frame
    lo, hi = v.min(axis=0), v.max(axis=0)
    span = np.where(hi - lo > 1e-9, hi - lo, 1.0)
    v = (v - (lo + hi) / 2) / span  # exactly the unit cube, whatever the file's rounding
    try:
        visual = mesh.visual if mesh.visual.kind != "texture" else mesh.visual.to_color()
        fc = np.asarray(visual.face_colors, dtype=np.float64)[:, :3] / 255.0
    except Exception:
        fc = np.full((len(mesh.faces), 3), 0.6)
    return v, np.asarray(mesh.faces, dtype=np.int64), fc


def _box_unit_mesh() -> tuple[np.ndarray, np.ndarray]:
    import trimesh

    box = trimesh.creation.box((1.0, 1.0, 1.0))
    return np.asarray(box.vertices), np.asarray(box.faces, dtype=np.int64)


def object_mesh(obj: SceneObject) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """World-frame ``(vertices, faces, face_colors 0..1)`` of one object (proxy model or box)."""
    if obj.frame != "world":
        raise RenderError(f"object {obj.id!r} is in the {obj.frame} frame; the renderer needs world")
    model = _proxy_model(obj.label)
    if model is None:
        v, f = _box_unit_mesh()
        color = _catalog_color(obj.label)
        fc = np.tile(np.asarray(color, dtype=np.float64) / 255.0, (len(f), 1))
    else:
        v, f, fc = model
    w, h, l = obj.size
    c, s = math.cos(obj.yaw), math.sin(obj.yaw)
    rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    world = (v * np.array([l, w, h])) @ rot.T + np.asarray(obj.position)
    return world, f, fc


def _catalog_color(label: str) -> RGB:
    try:
        from pipeline.catalog import default_catalog

        entry = default_catalog().lookup(label)
        if entry is not None:
            return entry.color
    except Exception:
        pass
    return _label_color(label)


def room_mesh(room_min: Sequence[float], room_max: Sequence[float]) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Inward-facing room shell: ``(vertices, faces, face_colors, surface)``.

    ``surface`` per face: 0 floor, 1 walls, 2 ceiling (the floor gets tiles at shading time).
    """
    x0, y0, z0 = (float(v) for v in room_min)
    x1, y1, z1 = (float(v) for v in room_max)
    quads = [  # corners counter-clockwise seen from inside the room
        ((x0, y0, z0), (x1, y0, z0), (x1, y1, z0), (x0, y1, z0), 0),  # floor, normal +z
        ((x0, y0, z1), (x0, y1, z1), (x1, y1, z1), (x1, y0, z1), 2),  # ceiling, normal -z
        ((x0, y0, z0), (x0, y1, z0), (x0, y1, z1), (x0, y0, z1), 1),  # x0 wall, normal +x
        ((x1, y0, z0), (x1, y0, z1), (x1, y1, z1), (x1, y1, z0), 1),  # x1 wall, normal -x
        ((x0, y0, z0), (x0, y0, z1), (x1, y0, z1), (x1, y0, z0), 1),  # y0 wall, normal +y
        ((x0, y1, z0), (x1, y1, z0), (x1, y1, z1), (x0, y1, z1), 1),  # y1 wall, normal -y
    ]
    colors = {0: (0.62, 0.60, 0.56), 1: (0.80, 0.79, 0.75), 2: (0.92, 0.92, 0.92)}
    verts, faces, fcol, surf = [], [], [], []
    for a, b, c, d, kind in quads:
        n = len(verts)
        verts += [a, b, c, d]
        faces += [(n, n + 1, n + 2), (n, n + 2, n + 3)]
        fcol += [colors[kind]] * 2
        surf += [kind] * 2
    return (np.asarray(verts, dtype=np.float64), np.asarray(faces, dtype=np.int64),
            np.asarray(fcol, dtype=np.float64), np.asarray(surf, dtype=np.int64))


class SceneRenderer:
    """Renders one static scene from any camera pose.

    Args:
        scene: Objects in the world frame.
        room: ``(min, max)`` corners of the room shell [m] (world frame), or ``None`` for objects
            only (misses get ``inf`` depth and black pixels).
        light: Direction the key light shines *from* (world frame), normalised internally.

    Raises:
        RenderError: The ``embreex`` ray-casting backend is not installed, or nothing to draw.
    """

    def __init__(self, scene: Scene, room: tuple[Sequence[float], Sequence[float]] | None = None,
                 light: Sequence[float] = (0.35, -0.5, 1.0)) -> None:
        try:
            from embreex import rtcore_scene
            from embreex.mesh_construction import TriangleMesh
        except ImportError as exc:  # pragma: no cover - depends on the environment
            raise RenderError(
                f"the simulator's renderer needs Embree ray casting: pip install embreex ({exc})"
            ) from None
        verts, faces, fcol, inst, surf = [], [], [], [], []
        n = 0
        objs = scene.objects
        for i, obj in enumerate(objs):
            v, f, c = object_mesh(obj)
            verts.append(v)
            faces.append(f + n)
            fcol.append(c)
            inst.append(np.full(len(f), i, dtype=np.int32))
            surf.append(np.full(len(f), -1, dtype=np.int8))
            n += len(v)
        if room is not None:
            v, f, c, s = room_mesh(*room)
            verts.append(v)
            faces.append(f + n)
            fcol.append(c)
            inst.append(np.full(len(f), -1, dtype=np.int32))
            surf.append(s.astype(np.int8))
        if not verts:
            raise RenderError("nothing to render: the scene is empty and there is no room")
        vertices = np.concatenate(verts)
        tris = np.concatenate(faces)
        corners = vertices[tris]
        normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
        length = np.linalg.norm(normals, axis=1, keepdims=True)
        self._normals = (normals / np.where(length > 0, length, 1.0)).astype(np.float32)
        self._colors = np.concatenate(fcol).astype(np.float32)
        self._instance = np.concatenate(inst)
        self._surface = np.concatenate(surf)
        self._scene = rtcore_scene.EmbreeScene()
        TriangleMesh(self._scene, vertices.astype(np.float32), tris.astype(np.int32))
        lv = np.asarray(light, dtype=np.float64)
        lv = lv / np.linalg.norm(lv)
        self._key_front = np.clip(self._normals @ lv, 0.0, None).astype(np.float32)
        self._key_back = np.clip(-(self._normals @ lv), 0.0, None).astype(np.float32)
        self.object_ids = tuple(o.id for o in objs)
        self.labels = tuple(o.label for o in objs)
        self.triangles = len(tris)
        self._rays: tuple[Intrinsics, np.ndarray, np.ndarray] | None = None

    def _camera_rays(self, intr: Intrinsics) -> tuple[np.ndarray, np.ndarray]:
        """Camera-frame ray per pixel with optical-axis component 1, and 1 / its length
        (both float32, cached per intrinsics)."""
        if self._rays is None or self._rays[0] != intr:
            u, v = np.meshgrid(np.arange(intr.width, dtype=np.float64),
                               np.arange(intr.height, dtype=np.float64))
            d = np.stack([(u - intr.cx) / intr.fx, (v - intr.cy) / intr.fy, np.ones_like(u)], axis=-1).reshape(-1, 3)
            self._rays = (intr, d.astype(np.float32), (1.0 / np.linalg.norm(d, axis=1)).astype(np.float32))
        return self._rays[1], self._rays[2]

    def render(self, camera_pose: Pose, intrinsics: Intrinsics) -> RenderResult:
        """Render the view of a camera at ``camera_pose`` (``world <- camera``)."""
        W, H = intrinsics.width, intrinsics.height
        rays, inv_len = self._camera_rays(intrinsics)
        R = camera_pose.rotation.as_matrix().astype(np.float32)
        # with the optical-axis component 1, Embree's hit distance is the depth along that axis
        d = rays @ R.T
        o = np.asarray(camera_pose.translation, dtype=np.float32)
        out = self._scene.run(np.broadcast_to(o, d.shape).copy(), d, output=1)
        tri, t = out["primID"], out["tfar"]
        hit = tri >= 0
        everywhere = bool(hit.all())  # the usual case inside a closed room: no masking needed
        sel = slice(None) if everywhere else hit
        ti = tri[sel]
        depth = t.astype(np.float32, copy=True)
        instances = np.full(len(d), -1, dtype=np.int32)
        rgb = np.zeros((len(d), 3), dtype=np.float32)
        if not everywhere:
            depth[~hit] = np.inf
        if len(ti):
            instances[sel] = self._instance[ti]
            rgb[sel] = self._shade(ti, d[sel], inv_len[sel], t[sel], o)
        img = (np.clip(rgb, 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8).reshape(H, W, 3)
        return RenderResult(img, depth.reshape(H, W), instances.reshape(H, W), self.object_ids, self.labels)

    def _shade(self, tri: np.ndarray, d: np.ndarray, inv_len: np.ndarray, t: np.ndarray,
               origin: np.ndarray) -> np.ndarray:
        """Lambert shading: key light + camera headlight + ambient; tiles on the floor."""
        facing = np.einsum("ij,ij->i", d, self._normals[tri]) * inv_len  # cos(ray, normal)
        # two-sided faces: a face seen from behind is lit as if its normal were flipped
        key = np.where(facing > 0, self._key_back[tri], self._key_front[tri])
        shade = 0.30 + 0.45 * key + 0.30 * np.abs(facing)
        color = self._colors[tri] * shade[:, None]
        floor = np.flatnonzero(self._surface[tri] == 0)
        if len(floor):
            p = origin + d[floor] * t[floor, None]
            checker = (np.floor(p[:, 0] / FLOOR_TILE) + np.floor(p[:, 1] / FLOOR_TILE)) % 2
            color[floor] *= np.where(checker > 0, np.float32(1.0), np.float32(0.82))[:, None]
        return color


__all__ = ["SceneRenderer", "RenderResult", "RenderError", "object_mesh", "room_mesh", "FLOOR_TILE"]
