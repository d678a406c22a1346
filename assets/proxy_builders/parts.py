"""Mesh parts for the proxy models: :class:`Parts` (coloured primitives in one mesh), colours, normalising.

A builder adds boxes, rods, cylinders, spheres, ... in metres in the object frame (x forward =
length, y left = width, z up); :func:`normalize` then scales each axis so the bounding box is
exactly ``[-0.5, 0.5]^3``. Colours are RGB 0..255; a part's colour is a shade of the class colour
or a neutral accent (``DARK``, ``METAL`` ...) with a little of it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import trimesh

RGB = tuple[int, int, int]
Vec = Sequence[float]

# Neutral accent colours, blended with a little of the class colour (see Parts.color).
DARK: RGB = (38, 38, 42)
METAL: RGB = (170, 174, 180)
GLASS: RGB = (45, 70, 95)
WHITE: RGB = (242, 242, 238)
SKIN: RGB = (226, 182, 140)
WOOD: RGB = (125, 84, 50)
TERRACOTTA: RGB = (176, 94, 60)
RED_LIGHT: RGB = (200, 30, 30)
LAMP: RGB = (255, 240, 190)


class Parts:
    """Accumulates coloured primitive parts (metres, object frame) into one mesh."""

    def __init__(self, color: RGB) -> None:
        self.base = np.asarray(color, dtype=float)
        self._parts: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []

    def color(self, shade: float = 0.0, accent: RGB | None = None) -> np.ndarray:
        """RGBA of a part: the class colour (or an accent with 15 % of it), then shaded.

        ``shade`` > 0 blends towards white, < 0 towards black, by that fraction.
        """
        c = self.base if accent is None else 0.85 * np.asarray(accent, float) + 0.15 * self.base
        c = c + (255.0 - c) * shade if shade >= 0 else c * (1.0 + shade)
        return np.append(np.clip(np.round(c), 0, 255), 255).astype(np.uint8)

    def add(self, mesh: trimesh.Trimesh, shade: float = 0.0, accent: RGB | None = None) -> None:
        """Add a mesh as one part with a single colour."""
        rgba = self.color(shade, accent)
        self._parts.append(
            (
                np.asarray(mesh.vertices, float),
                np.asarray(mesh.faces),
                np.tile(rgba, (len(mesh.vertices), 1)),
            )
        )

    def add_colored(self, mesh: trimesh.Trimesh, rgba: np.ndarray) -> None:
        """Add a mesh with explicit per-vertex RGBA colours."""
        self._parts.append((np.asarray(mesh.vertices, float), np.asarray(mesh.faces), rgba))

    def block(self, lo: Vec, hi: Vec, shade: float = 0.0, accent: RGB | None = None) -> None:
        """Axis-aligned box from its min corner ``lo`` to its max corner ``hi``."""
        lo_, hi_ = np.asarray(lo, float), np.asarray(hi, float)
        self.box((lo_ + hi_) / 2, hi_ - lo_, shade, accent)

    def box(
        self,
        center: Vec,
        extents: Vec,
        shade: float = 0.0,
        accent: RGB | None = None,
        rotate: tuple[str, float] | None = None,
    ) -> None:
        """Box of ``extents`` at ``center``, optionally rotated by ``(axis, angle [rad])`` first."""
        m = trimesh.creation.box(extents=extents)
        if rotate is not None:
            m.apply_transform(rotation(*rotate))
        m.apply_translation(center)
        self.add(m, shade, accent)

    def rod(
        self,
        a: Vec,
        b: Vec,
        radius: float,
        shade: float = 0.0,
        accent: RGB | None = None,
        sections: int = 6,
    ) -> None:
        """Cylinder of ``radius`` from point ``a`` to point ``b``."""
        self.add(
            trimesh.creation.cylinder(radius, segment=[a, b], sections=sections), shade, accent
        )

    def cylinder(
        self,
        center: Vec,
        radius: float,
        height: float,
        axis: str = "z",
        shade: float = 0.0,
        accent: RGB | None = None,
        sections: int = 16,
        top_scale: float = 1.0,
        scale: Vec = (1.0, 1.0),
    ) -> None:
        """Cylinder (frustum if ``top_scale`` != 1, elliptic via ``scale``) along ``axis``."""
        m = trimesh.creation.cylinder(radius, height, sections=sections)
        v = m.vertices.copy()
        top = v[:, 2] > 0
        v[top, :2] *= top_scale
        v[:, 0] *= scale[0]
        v[:, 1] *= scale[1]
        m = trimesh.Trimesh(v, m.faces, process=False)
        m.apply_transform(axis_from_z(axis))
        m.apply_translation(center)
        self.add(m, shade, accent)

    def ellipsoid(
        self,
        center: Vec,
        radii: Vec,
        shade: float = 0.0,
        accent: RGB | None = None,
        subdivisions: int = 1,
    ) -> None:
        """Ellipsoid with semi-axes ``radii`` (an icosphere scaled per axis)."""
        m = trimesh.creation.icosphere(subdivisions=subdivisions)
        m = trimesh.Trimesh(m.vertices * np.asarray(radii, float) + center, m.faces, process=False)
        self.add(m, shade, accent)

    def torus(
        self,
        center: Vec,
        major: float,
        minor: float,
        axis: str = "z",
        shade: float = 0.0,
        accent: RGB | None = None,
        sections: tuple[int, int] = (16, 6),
        scale: Vec = (1.0, 1.0, 1.0),
    ) -> None:
        """Ring of radius ``major`` and tube radius ``minor`` around ``axis``."""
        m = trimesh.creation.torus(
            major, minor, major_sections=sections[0], minor_sections=sections[1]
        )
        m = trimesh.Trimesh(m.vertices * np.asarray(scale, float), m.faces, process=False)
        m.apply_transform(axis_from_z(axis))
        m.apply_translation(center)
        self.add(m, shade, accent)

    def hull(self, points: Iterable[Vec], shade: float = 0.0, accent: RGB | None = None) -> None:
        """Convex hull of ``points`` (tapered cabins, wedges)."""
        self.add(trimesh.convex.convex_hull(np.asarray(list(points), float)), shade, accent)

    def mesh(self) -> trimesh.Trimesh:
        """All parts as one mesh (vertices not merged, so parts keep their colours)."""
        if not self._parts:
            raise ValueError("no parts were added")
        vertices, faces, colors, offset = [], [], [], 0
        for v, f, c in self._parts:
            vertices.append(v)
            faces.append(f + offset)
            colors.append(c)
            offset += len(v)
        mesh = trimesh.Trimesh(np.vstack(vertices), np.vstack(faces), process=False)
        mesh.visual = trimesh.visual.ColorVisuals(mesh, vertex_colors=np.vstack(colors))
        return mesh


def rotation(axis: str, angle: float) -> np.ndarray:
    direction = {"x": [1, 0, 0], "y": [0, 1, 0], "z": [0, 0, 1]}[axis]
    return trimesh.transformations.rotation_matrix(angle, direction)


def axis_from_z(axis: str) -> np.ndarray:
    """Rotation taking the +z axis to ``axis``."""
    if axis == "z":
        return np.eye(4)
    if axis == "x":
        return rotation("y", math.pi / 2)
    if axis == "y":
        return rotation("x", -math.pi / 2)
    raise ValueError(f"axis must be x, y or z, got {axis!r}")


def normalize(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """Translate and scale each axis so the bounding box is exactly ``[-0.5, 0.5]^3``."""
    lo, hi = mesh.bounds
    extent = hi - lo
    if np.any(extent <= 0):
        raise ValueError(f"mesh is flat along an axis, extents {extent}")
    v = (mesh.vertices - (lo + hi) / 2) / extent
    v = np.clip(v, -0.5, 0.5)  # remove last-ulp overshoot so bounds are exact
    out = trimesh.Trimesh(v, mesh.faces, process=False)
    out.visual = trimesh.visual.ColorVisuals(out, vertex_colors=mesh.visual.vertex_colors)
    return out
