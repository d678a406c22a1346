"""Build the low-poly proxy model (``.glb``) of every catalog class.

Run ``python -m assets.make_proxy_models`` to regenerate ``assets/proxy_models/`` from
``assets/catalog.toml`` (``--out DIR`` writes elsewhere, ``--only NAME`` builds some classes only).
The output is deterministic: the same catalog gives the same vertices.

Each model is built from a few primitives (boxes, rods, cylinders, spheres, tori) at the class's
typical size in metres, coloured per part with shades of the class colour (plus a few neutral
accents such as black tyres), then normalised:

- OBJECT frame: x = length axis (the catalog ``l``, the object's heading; its front faces +x),
  y = width (catalog ``w``, y to the object's left), z = up (catalog ``h``). This is z-up, NOT the
  y-up convention of glTF: the vertices are stored as they are, with no axis swap.
- The axis-aligned bounding box is exactly ``[-0.5, 0.5]^3``: a viewer scales the mesh by
  ``(l, w, h)`` and rotates it by the object's yaw about z to place it.

Colours are per-vertex (``COLOR_0``) with one matte material and no normals, so glTF viewers
(three.js / viser) shade the faces flat. ``box.glb`` is the neutral fallback for unknown labels.
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path

import numpy as np
import trimesh

from assets import CATALOG_PATH, FALLBACK_MODEL, PROXY_DIR

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10 only
    import tomli as tomllib

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

FALLBACK_COLOR: RGB = (158, 158, 158)
DEFAULT_NOMINAL_SIZE = (0.5, 0.5, 0.5)
"""``(w, h, l)`` [m] to build a class of unknown size that has no entry in NOMINAL_SIZES."""


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
            m.apply_transform(_rotation(*rotate))
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
        m.apply_transform(_axis_from_z(axis))
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
        m.apply_transform(_axis_from_z(axis))
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


def _rotation(axis: str, angle: float) -> np.ndarray:
    direction = {"x": [1, 0, 0], "y": [0, 1, 0], "z": [0, 0, 1]}[axis]
    return trimesh.transformations.rotation_matrix(angle, direction)


def _axis_from_z(axis: str) -> np.ndarray:
    """Rotation taking the +z axis to ``axis``."""
    if axis == "z":
        return np.eye(4)
    if axis == "x":
        return _rotation("y", math.pi / 2)
    if axis == "y":
        return _rotation("x", -math.pi / 2)
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


# --- Builders: (parts, w, h, l) [m]; x in [-l/2, l/2] (front +x), y in [-w/2, w/2], z in [0, h].

Builder = Callable[[Parts, float, float, float], None]
BUILDERS: dict[str, Builder] = {}
NOMINAL_SIZES: dict[str, tuple[float, float, float]] = {
    "rock": (1.0, 0.6, 1.2),
    "debris_pile": (1.6, 0.7, 2.0),
    "unknown_object": (0.6, 0.5, 0.8),
}


def builder(*names: str) -> Callable[[Builder], Builder]:
    def register(fn: Builder) -> Builder:
        for n in names:
            BUILDERS[n] = fn
        return fn

    return register


@builder("box")
def _box(p: Parts, w: float, h: float, l: float) -> None:
    p.block((-l / 2, -w / 2, 0), (l / 2, w / 2, h), 0.15)
    e = 0.03 * min(w, h, l)
    for y in (-w / 2, w / 2):
        for z in (0, h):
            p.block((-l / 2, y - e, z - e), (l / 2, y + e, z + e), -0.45)
    for x in (-l / 2, l / 2):
        for z in (0, h):
            p.block((x - e, -w / 2, z - e), (x + e, w / 2, z + e), -0.45)
        for y in (-w / 2, w / 2):
            p.block((x - e, y - e, 0), (x + e, y + e, h), -0.45)


@builder("desk")
def _desk(p: Parts, w: float, h: float, l: float) -> None:
    t = 0.03
    p.block((-l / 2, -w / 2, h - t), (l / 2, w / 2, h), 0.1)  # top
    # left side panel, right drawer pedestal, modesty panel at the back (-x)
    p.block((-l / 2 + 0.03, w / 2 - 0.05, 0), (l / 2 - 0.03, w / 2 - 0.02, h - t), -0.15)
    ped = 0.42
    p.block((-l / 2 + 0.03, -w / 2 + 0.02, 0), (l / 2 - 0.05, -w / 2 + 0.02 + ped, h - t), -0.1)
    p.block((-l / 2 + 0.03, -w / 2 + 0.1, 0.3), (-l / 2 + 0.05, w / 2 - 0.05, h - t), -0.25)
    for i in range(3):  # drawer fronts and handles on the pedestal, facing +x
        z0 = 0.04 + i * (h - t - 0.06) / 3
        z1 = z0 + (h - t - 0.06) / 3 - 0.02
        p.block((l / 2 - 0.05, -w / 2 + 0.04, z0), (l / 2 - 0.03, -w / 2 + ped, z1), 0.15)
        p.block(
            (l / 2 - 0.03, -w / 2 + 0.15, z1 - 0.06),
            (l / 2 - 0.01, -w / 2 + ped - 0.11, z1 - 0.04),
            accent=METAL,
        )


@builder("office_chair")
def _office_chair(p: Parts, w: float, h: float, l: float) -> None:
    r = min(w, l) / 2 - 0.03
    for k in range(5):  # star base with casters
        a = 2 * math.pi * k / 5
        end = (r * math.cos(a), r * math.sin(a))
        p.rod((0, 0, 0.09), (end[0], end[1], 0.06), 0.022, -0.5, accent=DARK)
        p.ellipsoid((end[0], end[1], 0.03), (0.03, 0.03, 0.03), accent=DARK, subdivisions=0)
    p.cylinder((0, 0, 0.27), 0.03, 0.36, shade=0.0, accent=METAL, sections=8)  # gas column
    p.block((-l / 2 + 0.08, -0.25, 0.45), (l / 2 - 0.04, 0.25, 0.53), 0.0)  # seat
    p.block(
        (-l / 2 + 0.06, -0.04, 0.45), (-l / 2 + 0.1, 0.04, 0.62), -0.4, accent=DARK
    )  # back support
    p.box((-l / 2 + 0.06, 0, 0.83), (0.07, 0.46, 0.44), -0.1, rotate=("y", -0.12))  # backrest
    for s in (-1, 1):  # armrests
        y = s * 0.27
        p.rod((-0.05, y, 0.52), (-0.05, y, 0.68), 0.015, accent=DARK)
        p.block((-0.17, y - 0.035, 0.68), (0.12, y + 0.035, 0.71), -0.4, accent=DARK)


@builder("chair")
def _chair(p: Parts, w: float, h: float, l: float) -> None:
    seat = 0.45
    e = 0.04
    for x in (-l / 2, l / 2 - e):
        for y in (-w / 2, w / 2 - e):
            top = h if x < 0 else seat
            p.block((x, y, 0), (x + e, y + e, top), -0.25)
    p.block((-l / 2, -w / 2, seat), (l / 2, w / 2, seat + 0.04), 0.1)
    p.block((-l / 2, -w / 2 + e, h - 0.2), (-l / 2 + e, w / 2 - e, h - 0.03), 0.05)
    p.block((-l / 2, -w / 2 + e, seat + 0.15), (-l / 2 + e, w / 2 - e, seat + 0.2), 0.05)


@builder("stool")
def _stool(p: Parts, w: float, h: float, l: float) -> None:
    r = min(w, l) / 2
    p.cylinder((0, 0, h - 0.03), r * 0.8, 0.06, shade=0.1, sections=16)
    for k in range(4):
        a = math.pi / 4 + k * math.pi / 2
        foot = (r - 0.018) * math.sqrt(2)
        p.rod(
            (0.55 * r * math.cos(a), 0.55 * r * math.sin(a), h - 0.06),
            (foot * math.cos(a), foot * math.sin(a), 0),
            0.018,
            -0.2,
        )
    p.torus((0, 0, 0.25 * h), 0.82 * r, 0.012, shade=0.0, accent=METAL, sections=(16, 4))


@builder("sofa")
def _sofa(p: Parts, w: float, h: float, l: float) -> None:
    arm = 0.2
    p.block((-l / 2, -w / 2, 0.08), (l / 2, w / 2, 0.42), -0.1)  # base
    p.block((-l / 2, -w / 2, 0.08), (-l / 2 + 0.22, w / 2, h), -0.05)  # back
    for s in (-1, 1):
        y0 = s * w / 2
        p.block((-l / 2, min(y0, y0 - s * arm), 0.08), (l / 2, max(y0, y0 - s * arm), 0.65), -0.15)
    n = 3
    inner = w - 2 * arm
    for i in range(n):  # seat and back cushions
        y0 = -inner / 2 + i * inner / n + 0.01
        y1 = y0 + inner / n - 0.02
        p.block((-l / 2 + 0.22, y0, 0.42), (l / 2 - 0.02, y1, 0.52), 0.15)
        p.box(
            (-l / 2 + 0.3, (y0 + y1) / 2, 0.67),
            (0.14, inner / n - 0.02, 0.3),
            0.2,
            rotate=("y", -0.15),
        )
    for x in (-l / 2 + 0.05, l / 2 - 0.05):
        for y in (-w / 2 + 0.05, w / 2 - 0.05):
            p.block((x - 0.03, y - 0.03, 0), (x + 0.03, y + 0.03, 0.08), accent=DARK)


@builder("bench")
def _bench(p: Parts, w: float, h: float, l: float) -> None:
    seat = 0.44
    for i in range(4):  # seat slats along y
        x0 = -l / 2 + 0.1 + i * 0.12
        p.block((x0, -w / 2, seat - 0.03), (x0 + 0.1, w / 2, seat), 0.05 * (i % 2))
    for i in range(3):  # back slats, leaning back
        z = seat + 0.12 + i * 0.11
        x = -l / 2 + 0.06 - 0.07 * (z - seat) / (h - seat)
        p.box((x + 0.03, 0, z), (0.03, w, 0.08), 0.05 * (i % 2), rotate=("y", -0.2))
    for s in (-1, 1):  # cast side frames with arm rests
        y = s * (w / 2 - 0.12)
        p.block((l / 2 - 0.12, y - 0.03, 0), (l / 2 - 0.06, y + 0.03, seat), accent=DARK)
        p.rod((-l / 2 + 0.08, y, 0), (-l / 2 + 0.02, y, h), 0.025, accent=DARK)
        p.block(
            (-l / 2 + 0.04, y - 0.03, seat - 0.06),
            (l / 2 - 0.06, y + 0.03, seat - 0.03),
            accent=DARK,
        )
        p.block(
            (-l / 2 + 0.1, y - 0.03, seat + 0.2), (l / 2 - 0.02, y + 0.03, seat + 0.24), accent=DARK
        )
        p.rod((l / 2 - 0.09, y, seat), (l / 2 - 0.09, y, seat + 0.22), 0.02, accent=DARK)


@builder("bed")
def _bed(p: Parts, w: float, h: float, l: float) -> None:
    p.block((-l / 2 + 0.06, -w / 2, 0.12), (l / 2, w / 2, 0.32), -0.35, accent=WOOD)  # frame
    for x in (-l / 2 + 0.1, l / 2 - 0.05):
        for y in (-w / 2 + 0.05, w / 2 - 0.05):
            p.block((x - 0.04, y - 0.04, 0), (x + 0.04, y + 0.04, 0.12), -0.45, accent=WOOD)
    p.block(
        (-l / 2 + 0.08, -w / 2 + 0.03, 0.32), (l / 2 - 0.03, w / 2 - 0.03, 0.5), shade=0.75
    )  # mattress
    p.block((-l / 2, -w / 2, 0), (-l / 2 + 0.06, w / 2, h), -0.3, accent=WOOD)  # headboard at -x
    for s in (-1, 1):  # pillows
        p.ellipsoid((-l / 2 + 0.3, s * w / 4, 0.55), (0.16, w / 4 - 0.06, 0.06), shade=0.85)
    p.block((-l / 2 + 0.6, -w / 2 + 0.01, 0.5), (l / 2 - 0.01, w / 2 - 0.01, 0.57), 0.0)  # blanket
    p.block((l / 2 - 0.03, -w / 2 + 0.01, 0.25), (l / 2 - 0.01, w / 2 - 0.01, 0.57), -0.05)


def _drawer_front(p: Parts, l: float, y0: float, y1: float, z0: float, z1: float) -> None:
    p.block((l / 2 - 0.005, y0, z0), (l / 2 + 0.01, y1, z1), 0.15)
    p.ellipsoid(
        (l / 2 + 0.02, (y0 + y1) / 2, (z0 + z1) / 2),
        (0.015, 0.015, 0.015),
        accent=METAL,
        subdivisions=0,
    )


@builder("nightstand")
def _nightstand(p: Parts, w: float, h: float, l: float) -> None:
    lb = l - 0.03
    p.block((-l / 2, -w / 2, 0.06), (l / 2 - 0.03, w / 2, h - 0.02), -0.1)
    for x in (-l / 2 + 0.03, l / 2 - 0.06):
        for y in (-w / 2 + 0.03, w / 2 - 0.03):
            p.block((x - 0.02, y - 0.02, 0), (x + 0.02, y + 0.02, 0.06), -0.4)
    _drawer_front(p, lb, -w / 2 + 0.03, w / 2 - 0.03, h - 0.18, h - 0.04)
    p.block(
        (l / 2 - 0.03, -w / 2 + 0.03, 0.1), (l / 2 - 0.027, w / 2 - 0.03, h - 0.22), -0.55
    )  # open niche
    p.block((-l / 2, -w / 2, h - 0.02), (l / 2 - 0.01, w / 2, h), 0.1)


@builder("dresser")
def _dresser(p: Parts, w: float, h: float, l: float) -> None:
    lb = l - 0.03
    p.block((-l / 2, -w / 2, 0.06), (l / 2 - 0.03, w / 2, h - 0.03), -0.1)
    p.block((-l / 2 + 0.02, -w / 2 + 0.03, 0), (l / 2 - 0.05, w / 2 - 0.03, 0.06), -0.45)  # plinth
    p.block((-l / 2, -w / 2 - 0.01, h - 0.03), (l / 2, w / 2 + 0.01, h), 0.05)  # top
    rows = 3
    zh = (h - 0.13) / rows
    for i in range(rows):
        z0 = 0.08 + i * zh
        if i == rows - 1:
            for y0, y1 in ((-w / 2 + 0.03, -0.01), (0.01, w / 2 - 0.03)):
                _drawer_front(p, lb, y0, y1, z0, z0 + zh - 0.02)
        else:
            _drawer_front(p, lb, -w / 2 + 0.03, w / 2 - 0.03, z0, z0 + zh - 0.02)


def _cupboard(p: Parts, w: float, h: float, l: float, doors: int, drawer: bool) -> None:
    lb = l - 0.02
    p.block((-l / 2, -w / 2, 0.06), (lb / 2, w / 2, h), 0.0)
    p.block((-l / 2 + 0.02, -w / 2 + 0.02, 0), (lb / 2 - 0.03, w / 2 - 0.02, 0.06), -0.5)
    top = h - 0.03
    if drawer:
        _drawer_front(p, lb + 0.005, -w / 2 + 0.02, w / 2 - 0.02, h - 0.2, h - 0.04)
        top = h - 0.22
    dw = (w - 0.04) / doors
    if doors > 1:  # dark gap between the doors
        p.block((lb / 2, -0.006, 0.08), (lb / 2 + 0.004, 0.006, top), -0.6, accent=DARK)
    for i in range(doors):
        y0 = -w / 2 + 0.02 + i * dw + 0.005
        y1 = y0 + dw - 0.01
        p.block((lb / 2, y0, 0.08), (lb / 2 + 0.01, y1, top), 0.12)
        yh = y1 - 0.05 if i == 0 and doors > 1 else y0 + 0.05
        zc = 0.08 + 0.55 * (top - 0.08)
        p.block(
            (lb / 2 + 0.01, yh - 0.012, zc - 0.12),
            (lb / 2 + 0.025, yh + 0.012, zc + 0.12),
            -0.3,
            accent=METAL,
        )


@builder("office_cabinet")
def _office_cabinet(p: Parts, w: float, h: float, l: float) -> None:
    _cupboard(p, w, h, l, doors=2, drawer=False)


@builder("cabinet")
def _cabinet(p: Parts, w: float, h: float, l: float) -> None:
    _cupboard(p, w, h, l, doors=1, drawer=True)


@builder("refrigerator")
def _refrigerator(p: Parts, w: float, h: float, l: float) -> None:
    lb = l - 0.04
    p.block((-l / 2, -w / 2, 0.04), (lb / 2 - 0.04, w / 2, h), 0.0)
    p.block((-l / 2 + 0.03, -w / 2 + 0.03, 0), (lb / 2 - 0.06, w / 2 - 0.03, 0.04), accent=DARK)
    split = 0.62 * h
    p.block((lb / 2 - 0.04, -w / 2, 0.04), (lb / 2, w / 2, split - 0.01), 0.2)  # fridge door
    p.block((lb / 2 - 0.04, -w / 2, split + 0.01), (lb / 2, w / 2, h), 0.2)  # freezer door
    y = w / 2 - 0.07
    p.block((lb / 2, y - 0.015, split - 0.5), (l / 2, y + 0.015, split - 0.06), accent=METAL)
    p.block((lb / 2, y - 0.015, split + 0.06), (l / 2, y + 0.015, split + 0.35), accent=METAL)


@builder("shelf")
def _shelf(p: Parts, w: float, h: float, l: float) -> None:
    t = 0.02
    for s in (-1, 1):
        p.block(
            (-l / 2, s * w / 2 - (t if s > 0 else 0), 0),
            (l / 2, s * w / 2 + (0 if s > 0 else t), h),
            -0.1,
        )
    p.block((-l / 2, -w / 2, 0), (-l / 2 + 0.01, w / 2, h), -0.35)  # back
    n = 5
    for i in range(n + 1):
        z = min(0.05 + i * (h - 0.05) / n, h - t)
        p.block((-l / 2, -w / 2 + t, z), (l / 2, w / 2 - t, z + t), 0.05)
    rng = np.random.default_rng(7)
    for i in range(n):  # books on each shelf, deterministic pattern
        z0 = 0.05 + i * (h - 0.05) / n + t
        y = -w / 2 + t + 0.01
        while y < w / 2 - t - 0.06 and (i % 2 == 0 or y < 0.1):
            bw = float(rng.uniform(0.025, 0.05))
            bh = float(rng.uniform(0.18, 0.28))
            depth = float(rng.uniform(0.16, 0.24))
            p.block(
                (-l / 2 + 0.02, y, z0),
                (-l / 2 + 0.02 + depth, y + bw, z0 + bh),
                float(rng.uniform(-0.5, 0.6)),
            )
            y += bw + 0.002


@builder("door")
def _door(p: Parts, w: float, h: float, l: float) -> None:
    f = 0.06
    p.block((-l / 2, -w / 2, 0), (l / 2, -w / 2 + f, h), -0.3)  # frame: jambs and head
    p.block((-l / 2, w / 2 - f, 0), (l / 2, w / 2, h), -0.3)
    p.block((-l / 2, -w / 2, h - f), (l / 2, w / 2, h), -0.3)
    t = 0.4 * l
    p.block((-t / 2, -w / 2 + f, 0.01), (t / 2, w / 2 - f, h - f), 0.05)  # leaf
    for z0, z1 in ((0.12, 0.85), (1.05, h - 0.17)):  # raised panels on both faces
        for s in (-1, 1):
            x0, x1 = sorted((s * t / 2, s * (t / 2 + 0.12 * l)))
            p.block((x0, -w / 2 + f + 0.1, z0), (x1, w / 2 - f - 0.1, z1), 0.2)
    for s in (-1, 1):  # lever handles
        x0, x1 = sorted((s * t / 2, s * l / 2))
        p.block((x0, w / 2 - f - 0.16, 0.98), (x1, w / 2 - f - 0.06, 1.02), accent=METAL)


@builder("toilet")
def _toilet(p: Parts, w: float, h: float, l: float) -> None:
    bowl_x = l / 2 - 0.22
    p.cylinder(
        (bowl_x - 0.03, 0, 0.12), 0.1, 0.24, sections=12, scale=(1.3, 1.0), shade=-0.05
    )  # pedestal
    p.cylinder(
        (bowl_x, 0, 0.3), 0.15, 0.14, sections=16, top_scale=1.25, scale=(1.2, 1.0), shade=0.0
    )  # bowl
    p.torus(
        (bowl_x, 0, 0.38), 0.15, 0.025, sections=(16, 4), scale=(1.25, 1.05, 1.0), shade=-0.1
    )  # seat
    p.cylinder(
        (bowl_x, 0, 0.3725), 0.16, 0.005, sections=16, scale=(1.15, 0.9), accent=GLASS, shade=0.3
    )  # water
    p.block((-l / 2 + 0.05, -0.14, 0.2), (-l / 2 + 0.2, 0.14, 0.4), -0.05)  # back of bowl
    p.block((-l / 2, -w / 2, 0.4), (-l / 2 + 0.2, w / 2, h - 0.02), 0.1)  # tank
    p.block((-l / 2 - 0.005, -w / 2 - 0.005, h - 0.02), (-l / 2 + 0.205, w / 2 + 0.005, h), -0.1)
    p.cylinder((-l / 2 + 0.1, 0, h + 0.005), 0.025, 0.01, sections=8, accent=METAL)


@builder("sink")
def _sink(p: Parts, w: float, h: float, l: float) -> None:
    p.cylinder((-0.05, 0, 0.36), 0.09, 0.72, sections=12, top_scale=1.3, shade=-0.05)  # pedestal
    p.block((-l / 2, -w / 2, h - 0.17), (l / 2, w / 2, h - 0.04), 0.1)  # basin body
    p.block(
        (-l / 2 + 0.12, -w / 2 + 0.06, h - 0.04),
        (l / 2 - 0.04, w / 2 - 0.06, h - 0.035),
        accent=GLASS,
        shade=0.1,
    )
    p.block((-l / 2, -w / 2, h - 0.04), (-l / 2 + 0.12, w / 2, h - 0.03), 0.2)  # rim
    p.block((l / 2 - 0.04, -w / 2, h - 0.04), (l / 2, w / 2, h - 0.03), 0.2)
    for s in (-1, 1):
        p.block(
            (-l / 2 + 0.12, s * w / 2 - (0.06 if s > 0 else 0), h - 0.04),
            (l / 2 - 0.04, s * w / 2 + (0 if s > 0 else 0.06), h - 0.03),
            0.2,
        )
    p.rod((-l / 2 + 0.06, 0, h - 0.03), (-l / 2 + 0.06, 0, h), 0.015, accent=METAL)
    p.rod((-l / 2 + 0.06, 0, h - 0.01), (-l / 2 + 0.16, 0, h - 0.01), 0.01, accent=METAL)


@builder("bathtub")
def _bathtub(p: Parts, w: float, h: float, l: float) -> None:
    t = 0.08
    p.block((-l / 2, -w / 2, 0), (l / 2, w / 2, 0.12), -0.1)  # floor / base
    p.block(
        (-l / 2 + t, -w / 2 + t, 0.12), (l / 2 - t, w / 2 - t, 0.3), accent=GLASS, shade=0.45
    )  # water
    p.block((-l / 2, -w / 2, 0.12), (-l / 2 + t, w / 2, h), 0.1)
    p.block((l / 2 - t, -w / 2, 0.12), (l / 2, w / 2, h), 0.1)
    p.block((-l / 2 + t, -w / 2, 0.12), (l / 2 - t, -w / 2 + t, h), 0.0)
    p.block((-l / 2 + t, w / 2 - t, 0.12), (l / 2 - t, w / 2, h), 0.0)
    p.rod((-l / 2 + t, 0, h - 0.07), (-l / 2 + t + 0.1, 0, h - 0.07), 0.015, accent=METAL)  # spout
    for s in (-1, 1):
        p.cylinder(
            (-l / 2 + t / 2, s * 0.08, h + 0.01), 0.02, 0.02, sections=8, accent=METAL
        )  # taps


@builder("suitcase")
def _suitcase(p: Parts, w: float, h: float, l: float) -> None:
    wheel = 0.025
    top = h - 0.13
    p.block((-l / 2 + 0.005, -w / 2, 2 * wheel), (l / 2 - 0.005, w / 2, top), 0.0)
    p.block(
        (-0.006, -w / 2 - 0.002, 2 * wheel), (0.006, w / 2 + 0.002, top), -0.5, accent=DARK
    )  # zip line
    for k in (-1, 0, 1):  # ribs on the front shell
        p.block(
            (l / 2 - 0.005, k * w / 4 - 0.02, 2 * wheel + 0.05),
            (l / 2, k * w / 4 + 0.02, top - 0.05),
            0.2,
        )
    for x in (-l / 2 + 0.04, l / 2 - 0.04):
        for y in (-w / 2 + 0.04, w / 2 - 0.04):
            p.cylinder((x, y, wheel), wheel, 0.02, axis="y", accent=DARK, sections=8)
    for s in (-1, 1):  # telescopic handle at the back, carry handle on top
        p.rod(
            (-l / 2 + 0.04, s * 0.1, top), (-l / 2 + 0.04, s * 0.1, h - 0.015), 0.01, accent=METAL
        )
    p.rod((-l / 2 + 0.04, -0.12, h - 0.015), (-l / 2 + 0.04, 0.12, h - 0.015), 0.015, accent=DARK)
    p.block((0.0, -0.07, top), (0.04, 0.07, top + 0.025), -0.5, accent=DARK)


@builder("compressor")
def _compressor(p: Parts, w: float, h: float, l: float) -> None:
    r = 0.13
    p.cylinder((0.02, 0, r + 0.03), r, l - 0.1, axis="x", sections=14, shade=0.0)  # tank
    for x in (-l / 2 + 0.09, l / 2 - 0.06):
        p.torus((x + 0.02, 0, r + 0.03), r, 0.012, axis="x", sections=(14, 4), shade=-0.3)
    p.block((-0.12, -0.1, 2 * r), (0.12, 0.1, 2 * r + 0.12), accent=DARK, shade=0.1)  # motor / pump
    p.cylinder((-0.02, 0, 2 * r + 0.16), 0.06, 0.08, sections=10, accent=METAL)  # cylinder head
    p.cylinder(
        (0.14, 0.05, 2 * r + 0.05), 0.035, 0.02, axis="x", accent=WHITE, sections=10
    )  # gauge
    for s in (-1, 1):  # handle frame
        y = s * (w / 2 - 0.03)
        p.rod((l / 2 - 0.014, y, 0.0), (0.08, y, h - 0.02), 0.014, accent=DARK)
        p.rod((-l / 2 + 0.08, y, 0.08), (-0.02, y, h - 0.02), 0.014, accent=DARK)
        p.cylinder(
            (-l / 2 + 0.07, s * (w / 2 - 0.025), 0.07),
            0.07,
            0.05,
            axis="y",
            accent=DARK,
            sections=12,
        )
    p.rod((0.08, -(w / 2 - 0.03), h - 0.02), (0.08, w / 2 - 0.03, h - 0.02), 0.02, accent=DARK)
    p.rod((-0.02, -(w / 2 - 0.03), h - 0.02), (-0.02, w / 2 - 0.03, h - 0.02), 0.014, accent=DARK)


@builder("cardboard_box")
def _cardboard_box(p: Parts, w: float, h: float, l: float) -> None:
    p.block((-l / 2, -w / 2, 0), (l / 2, w / 2, h - 0.002), 0.0)
    p.block((-l / 2 - 0.002, -0.03, 0.0), (l / 2 + 0.002, 0.03, h), 0.35)  # tape over the seam
    p.block((-l / 2 - 0.002, -w / 2, h - 0.004), (l / 2 + 0.002, -w / 2 + 0.004, h - 0.002), -0.3)
    p.block(
        (l / 2 - 0.001, -w / 2 + 0.05, h - 0.12), (l / 2 + 0.002, -w / 2 + 0.17, h - 0.06), -0.45
    )  # label


@builder("sports_mat")
def _sports_mat(p: Parts, w: float, h: float, l: float) -> None:
    n = 4  # folding panels along x, separated by grooves
    for i in range(n):
        x0 = -l / 2 + i * l / n
        p.block(
            (x0 + (0.004 if i else 0), -w / 2, 0),
            (x0 + l / n - (0.004 if i < n - 1 else 0), w / 2, h),
            0.08 * (i % 2),
        )
    for i in range(1, n):
        x = -l / 2 + i * l / n
        p.block((x - 0.004, -w / 2, 0), (x + 0.004, w / 2, h * 0.6), -0.5)


@builder("robot_dog")
def _robot_dog(p: Parts, w: float, h: float, l: float) -> None:
    bz = h - 0.075  # body centre height
    bl = l - 0.12
    p.block(
        (-l / 2 + 0.02, -0.095, bz - 0.06),
        (-l / 2 + 0.02 + bl, 0.095, bz + 0.06),
        accent=DARK,
        shade=0.15,
    )
    p.block((-l / 2 + 0.1, -0.08, bz + 0.06), (l / 2 - 0.2, 0.08, h), 0.0)  # yellow top cover
    head_x = -l / 2 + 0.02 + bl
    p.block((head_x - 0.01, -0.07, bz - 0.05), (l / 2, 0.07, bz + 0.05), -0.1, accent=DARK)  # head
    for y in (-0.035, 0.035):  # stereo camera "eyes"
        p.cylinder((l / 2, y, bz + 0.01), 0.018, 0.01, axis="x", accent=GLASS, sections=8)
    hip_dx = bl / 2 - 0.08
    for sx in (-1, 1):
        for sy in (-1, 1):
            hip = np.array([-l / 2 + 0.02 + bl / 2 + sx * hip_dx, sy * (w / 2 - 0.025), bz])
            knee = hip + [-0.07, 0, -0.15]
            foot = np.array([hip[0] + 0.01, hip[1], 0.02])
            p.cylinder(hip, 0.045, 0.05, axis="y", accent=DARK, sections=10)  # hip motor
            p.rod(hip, knee, 0.028, shade=-0.2)  # thigh
            p.rod(knee, foot, 0.016, accent=DARK)  # calf
            p.ellipsoid(foot, (0.02, 0.02, 0.02), accent=DARK, subdivisions=0)


@builder("table")
def _table(p: Parts, w: float, h: float, l: float) -> None:
    p.block((-l / 2, -w / 2, h - 0.04), (l / 2, w / 2, h), 0.1)
    p.block(
        (-l / 2 + 0.06, -w / 2 + 0.06, h - 0.12), (l / 2 - 0.06, w / 2 - 0.06, h - 0.04), -0.2
    )  # apron
    for x in (-l / 2 + 0.06, l / 2 - 0.12):
        for y in (-w / 2 + 0.06, w / 2 - 0.12):
            p.block((x, y, 0), (x + 0.06, y + 0.06, h - 0.04), -0.15)


@builder("monitor")
def _monitor(p: Parts, w: float, h: float, l: float) -> None:
    p.block((-l / 2, -0.12, 0), (l / 2, 0.12, 0.015), -0.2)  # base plate
    p.block((-0.05, -0.03, 0.015), (-0.02, 0.03, 0.2), -0.1)  # neck
    zb = h - 0.36
    p.block((-0.02, -w / 2, zb), (0.03, w / 2, h), -0.2)  # bezel
    p.block(
        (0.03, -w / 2 + 0.015, zb + 0.015),
        (0.034, w / 2 - 0.015, h - 0.015),
        accent=GLASS,
        shade=0.1,
    )


@builder("laptop")
def _laptop(p: Parts, w: float, h: float, l: float) -> None:
    d = l - 0.07  # base depth
    p.block((l / 2 - d, -w / 2, 0), (l / 2, w / 2, 0.018), 0.1)
    p.block(
        (l / 2 - d + 0.02, -w / 2 + 0.02, 0.018),
        (l / 2 - 0.08, w / 2 - 0.02, 0.02),
        -0.5,
        accent=DARK,
    )  # keys
    p.block((l / 2 - 0.06, -0.05, 0.018), (l / 2 - 0.015, 0.05, 0.0195), -0.2)  # touchpad
    a = 0.29  # screen leans back 17 degrees
    hinge = np.array([l / 2 - d, 0, 0.018])
    sh = (h - 0.018) / math.cos(a)
    c = hinge + [-math.sin(a) * sh / 2, 0, math.cos(a) * sh / 2]
    p.box(c, (0.012, w, sh), 0.05, rotate=("y", -a))
    n = np.array([math.cos(a), 0, math.sin(a)])
    p.box(c + 0.007 * n, (0.003, w - 0.03, sh - 0.03), accent=GLASS, shade=0.1, rotate=("y", -a))


@builder("backpack")
def _backpack(p: Parts, w: float, h: float, l: float) -> None:
    p.block((-l / 2 + 0.03, -w / 2, 0), (l / 2 - 0.06, w / 2, h - 0.08), 0.0)  # main compartment
    p.ellipsoid((-0.015, 0, h - 0.08), (l / 2 - 0.045, w / 2, 0.07), 0.05)  # rounded top
    p.block((l / 2 - 0.06, -w / 2 + 0.04, 0.02), (l / 2, w / 2 - 0.04, 0.2), -0.15)  # front pocket
    p.block((l / 2 - 0.003, -0.08, 0.17), (l / 2 + 0.001, 0.08, 0.18), -0.6, accent=DARK)  # zip
    for s in (-1, 1):  # shoulder straps at the back (-x)
        y = s * 0.07
        p.rod((-l / 2 + 0.045, y, h - 0.1), (-l / 2 + 0.018, y, 0.3), 0.018, -0.35)
        p.rod((-l / 2 + 0.018, y, 0.3), (-l / 2 + 0.045, y + s * 0.04, 0.06), 0.015, -0.35)
    p.torus((-0.02, 0, h - 0.045), 0.03, 0.008, axis="y", sections=(8, 4), shade=-0.35)


@builder("bottle")
def _bottle(p: Parts, w: float, h: float, l: float) -> None:
    r = min(w, l) / 2
    p.cylinder((0, 0, 0.3 * h), r, 0.6 * h, sections=12, shade=0.1)
    p.cylinder((0, 0, 0.35 * h), r + 0.001, 0.2 * h, sections=12, accent=WHITE)  # label
    p.cylinder((0, 0, 0.68 * h), r, 0.16 * h, sections=12, top_scale=0.38, shade=0.1)  # shoulder
    p.cylinder((0, 0, 0.84 * h), 0.38 * r, 0.16 * h, sections=10, shade=0.1)  # neck
    p.cylinder((0, 0, 0.95 * h), 0.45 * r, 0.1 * h, sections=10, accent=WHITE, shade=-0.2)  # cap


@builder("cup")
def _cup(p: Parts, w: float, h: float, l: float) -> None:
    r = l / 2
    p.cylinder((0, -(w - l) / 2, h / 2), r, h, sections=14, shade=0.0)
    p.cylinder(
        (0, -(w - l) / 2, h - 0.002), r - 0.005, 0.005, sections=14, accent=WOOD, shade=-0.5
    )  # coffee
    p.torus(
        (0, w / 2 - 0.022, h / 2),
        0.026,
        0.006,
        axis="x",
        sections=(10, 4),
        shade=-0.1,
        scale=(1.0, 0.85, 1.0),
    )


@builder("trash_bin")
def _trash_bin(p: Parts, w: float, h: float, l: float) -> None:
    r = min(w, l) / 2
    p.cylinder(
        (0, 0, (h - 0.06) / 2),
        0.85 * r,
        h - 0.06,
        sections=16,
        top_scale=1 / 0.85 * 0.97,
        shade=0.0,
    )
    p.cylinder((0, 0, h - 0.04), r, 0.04, sections=16, shade=0.2)  # lid
    p.ellipsoid((0, 0, h - 0.02), (0.95 * r, 0.95 * r, 0.02), 0.15)
    p.block((-0.03, -0.06, h - 0.004), (0.03, 0.06, h), -0.4)  # lid grip
    p.block((0.85 * r - 0.01, -0.05, 0.0), (r + 0.005, 0.05, 0.03), -0.5, accent=DARK)  # pedal


@builder("plant")
def _plant(p: Parts, w: float, h: float, l: float) -> None:
    pot_h = 0.3 * h
    r = 0.3 * min(w, l)
    p.cylinder(
        (0, 0, pot_h / 2), 0.75 * r, pot_h, sections=12, top_scale=1 / 0.75, accent=TERRACOTTA
    )
    p.torus((0, 0, pot_h), r, 0.015, sections=(12, 4), accent=TERRACOTTA, shade=-0.1)
    p.cylinder((0, 0, pot_h - 0.01), 0.95 * r, 0.02, sections=12, accent=WOOD, shade=-0.4)  # soil
    p.rod((0, 0, pot_h), (0, 0, 0.6 * h), 0.015, accent=WOOD)
    rf = min(w, l) / 2
    balls = [
        ((0, 0, h - 0.6 * rf), 0.6),
        ((0.5 * rf, 0.1 * rf, h - 1.2 * rf), 0.5),
        ((-0.5 * rf, 0.5 * rf, h - 1.1 * rf), 0.5),
        ((-0.1 * rf, -0.55 * rf, h - 1.25 * rf), 0.45),
    ]
    for i, (c, s) in enumerate(balls):
        p.ellipsoid(c, (s * rf, s * rf, s * rf), shade=(-0.15, 0.0, 0.12, -0.05)[i])


@builder("ladder")
def _ladder(p: Parts, w: float, h: float, l: float) -> None:
    top = h - 0.05
    ft, bt = np.array([0.06, 0, top]), np.array([-0.06, 0, top])
    rungs = 5
    for s in (-1, 1):
        y0, y1 = s * w / 2, s * (w / 2 - 0.04)
        fb, bb = np.array([l / 2 - 0.02, y0, 0]), np.array([-l / 2 + 0.02, y0, 0])
        p.box(
            (0.5 * (fb[0] + ft[0]), 0.5 * (y0 + y1), top / 2),
            (0.025, 0.04, math.hypot(fb[0] - ft[0], top)),
            0.0,
            rotate=("y", -math.atan2(fb[0] - ft[0], top)),
        )
        p.box(
            (0.5 * (bb[0] + bt[0]), 0.5 * (y0 + y1), top / 2),
            (0.02, 0.035, math.hypot(bb[0] - bt[0], top)),
            -0.15,
            rotate=("y", math.atan2(bt[0] - bb[0], top)),
        )
        p.block(
            (fb[0] - 0.04, (y0 + y1) / 2 - 0.02, 0),
            (fb[0] + 0.02, (y0 + y1) / 2 + 0.02, 0.04),
            accent=DARK,
        )
        p.block(
            (bb[0] - 0.02, (y0 + y1) / 2 - 0.018, 0),
            (bb[0] + 0.04, (y0 + y1) / 2 + 0.018, 0.04),
            accent=DARK,
        )
    for i in range(rungs):  # steps on the front legs
        z = (i + 1) * top / (rungs + 1)
        x = (l / 2 - 0.02) + (0.06 - (l / 2 - 0.02)) * z / top
        p.block((x - 0.05, -w / 2 + 0.03, z - 0.012), (x + 0.03, w / 2 - 0.03, z + 0.012), 0.2)
    p.block((-0.12, -w / 2 + 0.03, top), (0.12, w / 2 - 0.03, h), accent=DARK, shade=0.1)  # top cap
    for s in (-1, 1):  # spreader bars
        y = s * (w / 2 - 0.05)
        p.rod((0.4 * (l / 2), y, 0.55 * top), (-0.4 * (l / 2), y, 0.55 * top), 0.008, accent=METAL)


@builder("pallet")
def _pallet(p: Parts, w: float, h: float, l: float) -> None:
    b = 0.022
    ys = (-w / 2 + 0.05, 0.0, w / 2 - 0.05)
    xs = (-l / 2 + 0.0725, 0.0, l / 2 - 0.0725)
    for y in ys:  # bottom boards along x
        p.block((-l / 2, y - 0.05, 0), (l / 2, y + 0.05, b), -0.15)
    for x in xs:  # blocks
        for y in ys:
            p.block((x - 0.0725, y - 0.05, b), (x + 0.0725, y + 0.05, h - 2 * b), -0.3)
    for x in xs:  # stringer boards along y
        p.block((x - 0.0725, -w / 2, h - 2 * b), (x + 0.0725, w / 2, h - b), -0.05)
    for i in range(5):  # top deck boards along x
        y = -w / 2 + 0.05 + i * (w - 0.1) / 4
        p.block((-l / 2, y - 0.05, h - b), (l / 2, y + 0.05, h), 0.1 * (i % 2))


@builder("barrel")
def _barrel(p: Parts, w: float, h: float, l: float) -> None:
    r = min(w, l) / 2 - 0.01
    p.cylinder((0, 0, h / 2), r, h, sections=18, shade=0.0)
    for z in (0.01, h / 3, 2 * h / 3, h - 0.01):  # rolling hoops and chimes
        p.torus((0, 0, z), r, 0.01, sections=(18, 4), shade=-0.3)
    p.cylinder((0, 0, h + 0.001), r - 0.02, 0.002, sections=18, shade=0.25)
    p.cylinder((r * 0.55, 0, h + 0.006), 0.03, 0.012, sections=8, accent=METAL)  # bung


@builder("traffic_cone")
def _traffic_cone(p: Parts, w: float, h: float, l: float) -> None:
    base = 0.035
    p.block((-l / 2, -w / 2, 0), (l / 2, w / 2, base), -0.55, accent=DARK)
    rb, rt = 0.13, 0.025
    p.cylinder((0, 0, base + (h - base) / 2), rb, h - base, sections=16, top_scale=rt / rb)
    for f0, f1 in ((0.35, 0.5), (0.62, 0.72)):  # reflective bands
        z0, z1 = base + f0 * (h - base), base + f1 * (h - base)
        r0 = rb + (rt - rb) * f0 + 0.003
        r1 = rb + (rt - rb) * f1 + 0.003
        p.cylinder((0, 0, (z0 + z1) / 2), r0, z1 - z0, sections=16, top_scale=r1 / r0, accent=WHITE)


@builder("fire_hydrant")
def _fire_hydrant(p: Parts, w: float, h: float, l: float) -> None:
    r = 0.1
    p.cylinder((0, 0, 0.03), 0.16, 0.06, sections=12, shade=-0.2)  # flange
    p.cylinder((0, 0, 0.06 + (h - 0.2) / 2), r, h - 0.2, sections=12, shade=0.0)  # barrel
    p.torus((0, 0, h - 0.16), r + 0.01, 0.02, sections=(12, 4), shade=-0.2)
    p.ellipsoid((0, 0, h - 0.14), (r + 0.015, r + 0.015, 0.1), 0.05)  # bonnet
    p.cylinder((0, 0, h - 0.02), 0.03, 0.04, sections=5, accent=METAL)  # operating nut
    for s in (-1, 1):  # side hose outlets with caps
        p.cylinder((0, s * (r + 0.04), h - 0.3), 0.04, 0.08, axis="y", sections=10, shade=-0.05)
        p.cylinder(
            (0, s * (w / 2 - 0.015), h - 0.3), 0.05, 0.03, axis="y", sections=6, accent=METAL
        )
    p.cylinder(
        (r + 0.02, 0, h - 0.38), 0.06, 0.06, axis="x", sections=10, shade=-0.05
    )  # pumper outlet
    p.cylinder((l / 2 - 0.015, 0, h - 0.38), 0.065, 0.03, axis="x", sections=6, accent=METAL)
    p.block(
        (-l / 2, -0.02, h - 0.4), (-l / 2 + 0.01, 0.02, h - 0.36), -0.3
    )  # keeps l symmetric-ish


@builder("person")
def _person(p: Parts, w: float, h: float, l: float) -> None:
    s = h / 1.7
    hip, shoulder = 0.9 * s, 1.42 * s
    for sy in (-1, 1):  # walking towards +x: left leg and right arm forward
        y = sy * 0.1 * s
        ankle = sy * 0.1 * s
        p.rod((0.0, y, hip), (ankle, y, 0.08 * s), 0.065 * s, -0.55, sections=8)  # legs
        p.block(
            (ankle - 0.07 * s, y - 0.05 * s, 0),
            (ankle + 0.2 * s, y + 0.05 * s, 0.08 * s),
            accent=DARK,
        )  # shoes
        shoulder_pt = (0.0, sy * 0.2 * s, shoulder - 0.03 * s)
        elbow = (-sy * 0.05 * s, sy * 0.25 * s, 1.12 * s)
        hand = (-sy * 0.12 * s, sy * 0.27 * s, 0.88 * s)
        p.rod(shoulder_pt, elbow, 0.045 * s, 0.0, sections=8)  # upper arm
        p.rod(elbow, hand, 0.04 * s, 0.1, sections=8)  # forearm
        p.ellipsoid(hand, (0.045 * s, 0.04 * s, 0.05 * s), accent=SKIN, subdivisions=0)
    p.block(
        (-0.11 * s, -0.17 * s, hip - 0.05 * s), (0.11 * s, 0.17 * s, hip + 0.08 * s), -0.55
    )  # pelvis
    p.cylinder(
        (0, 0, (hip + shoulder) / 2 + 0.02 * s),
        0.12 * s,
        shoulder - hip,
        sections=10,
        scale=(1.0, 1.65),
        top_scale=1.1,
        shade=0.0,
    )  # torso
    p.cylinder((0, 0, shoulder + 0.06 * s), 0.045 * s, 0.08 * s, sections=8, accent=SKIN)  # neck
    p.ellipsoid((0.01 * s, 0, h - 0.125 * s), (0.095 * s, 0.08 * s, 0.115 * s), accent=SKIN)  # head
    p.ellipsoid(
        (-0.02 * s, 0, h - 0.085 * s), (0.095 * s, 0.088 * s, 0.085 * s), -0.5, accent=WOOD
    )  # hair
    p.ellipsoid(
        (0.105 * s, 0, h - 0.13 * s), (0.02 * s, 0.015 * s, 0.025 * s), accent=SKIN, subdivisions=0
    )  # nose


def _wheel(p: Parts, x: float, y: float, r: float, width: float, rim: float = 0.55) -> None:
    """Tyre (axis along y) with a lighter hub cap."""
    p.cylinder((x, y, r), r, width, axis="y", accent=DARK, sections=16)
    side = 1 if y > 0 else -1
    p.cylinder(
        (x, y + side * (width / 2 + 0.005), r), rim * r, 0.01, axis="y", accent=METAL, sections=12
    )


@builder("car")
def _car(p: Parts, w: float, h: float, l: float) -> None:
    wr = 0.31
    body_lo, body_hi = 0.2, 0.9
    p.hull(
        [
            (x, y, z)
            for x in (-l / 2, l / 2)
            for y in (-w / 2 + 0.02, w / 2 - 0.02)
            for z in (body_lo, body_hi - 0.12)
        ]
        + [
            (x, y, body_hi)
            for x in (-l / 2 + 0.08, l / 2 - 0.15)
            for y in (-w / 2 + 0.06, w / 2 - 0.06)
        ],
        0.0,
    )
    cab = [
        (x, y, body_hi) for x in (-l / 2 + 0.35, l / 2 - 1.05) for y in (-w / 2 + 0.1, w / 2 - 0.1)
    ]
    cab += [
        (x, y, h - 0.02) for x in (-l / 2 + 0.75, l / 2 - 1.75) for y in (-w / 2 + 0.2, w / 2 - 0.2)
    ]
    p.hull(cab, accent=GLASS, shade=0.05)
    p.block((-l / 2 + 0.75, -w / 2 + 0.2, h - 0.03), (l / 2 - 1.75, w / 2 - 0.2, h), -0.05)  # roof
    for x in (-l / 2 + 0.75, l / 2 - 0.8):
        for y in (-w / 2 + 0.11, w / 2 - 0.11):
            _wheel(p, x, y, wr, 0.2)
    for y in (-w / 2 + 0.2, w / 2 - 0.2):
        p.block(
            (l / 2 - 0.01, y - 0.14, 0.6), (l / 2 + 0.01, y + 0.14, 0.7), accent=LAMP
        )  # headlights
        p.block((-l / 2 - 0.01, y - 0.14, 0.62), (-l / 2 + 0.01, y + 0.14, 0.72), accent=RED_LIGHT)
    p.block(
        (-l / 2 - 0.02, -w / 2 + 0.05, 0.25), (l / 2 + 0.02, w / 2 - 0.05, 0.35), -0.5, accent=DARK
    )  # bumpers


@builder("van")
def _van(p: Parts, w: float, h: float, l: float) -> None:
    wr = 0.34
    hood = l / 2 - 0.75
    p.block((-l / 2, -w / 2, 0.3), (hood, w / 2, h - 0.02), 0.0)  # box body
    p.hull(
        [
            (x, y, z)
            for x in (hood, l / 2)
            for y in (-w / 2 + 0.02, w / 2 - 0.02)
            for z in (0.3, 0.95)
        ],
        0.0,
    )
    p.hull(
        [(hood, y, z) for y in (-w / 2 + 0.03, w / 2 - 0.03) for z in (0.95, h - 0.12)]
        + [(hood + 0.55, y, 0.95) for y in (-w / 2 + 0.06, w / 2 - 0.06)],
        accent=GLASS,
        shade=0.05,
    )
    p.block((-l / 2 + 0.05, -w / 2 + 0.03, h - 0.02), (hood - 0.1, w / 2 - 0.03, h), -0.1)  # roof
    for s in (-1, 1):
        p.block(
            (hood - 1.0, s * w / 2 - 0.005, 1.2),
            (hood - 0.05, s * w / 2 + 0.005, h - 0.35),
            accent=GLASS,
        )
        p.block(
            (-l / 2 + 1.5, s * w / 2 - 0.006, 0.4),
            (-l / 2 + 1.52, s * w / 2 + 0.006, h - 0.2),
            -0.3,
        )  # door line
    for x in (-l / 2 + 0.85, l / 2 - 0.85):
        for y in (-w / 2 + 0.12, w / 2 - 0.12):
            _wheel(p, x, y, wr, 0.22)
    for y in (-w / 2 + 0.2, w / 2 - 0.2):
        p.block((l / 2 - 0.01, y - 0.12, 0.75), (l / 2 + 0.01, y + 0.12, 0.85), accent=LAMP)
        p.block((-l / 2 - 0.01, y - 0.06, 0.6), (-l / 2 + 0.01, y + 0.06, 1.0), accent=RED_LIGHT)
    p.block(
        (-l / 2 - 0.03, -w / 2 + 0.05, 0.3), (l / 2 + 0.03, w / 2 - 0.05, 0.42), -0.5, accent=DARK
    )


@builder("truck")
def _truck(p: Parts, w: float, h: float, l: float) -> None:
    wr = 0.5
    cab_l = 2.2
    xc = l / 2 - cab_l
    p.block(
        (-l / 2 + 0.2, -w / 2 + 0.35, 0.55), (l / 2 - 0.2, w / 2 - 0.35, 0.9), -0.6, accent=DARK
    )  # chassis
    p.block((xc, -w / 2 + 0.05, 0.9), (l / 2, w / 2 - 0.05, 2.9), 0.15)  # cab
    p.block(
        (l / 2 - 0.01, -w / 2 + 0.15, 1.9), (l / 2 + 0.01, w / 2 - 0.15, 2.7), accent=GLASS
    )  # windscreen
    for s in (-1, 1):
        p.block(
            (xc + 0.9, s * (w / 2 - 0.05) - 0.01, 1.9),
            (l / 2 - 0.15, s * (w / 2 - 0.05) + 0.01, 2.6),
            accent=GLASS,
        )
    p.block((-l / 2, -w / 2, 0.9), (xc - 0.25, w / 2, h), 0.25, accent=WHITE)  # cargo box
    p.block(
        (-l / 2 - 0.01, -0.01, 1.0), (-l / 2 + 0.01, 0.01, h - 0.1), -0.4, accent=DARK
    )  # rear door split
    for y in (-w / 2 + 0.25, w / 2 - 0.25):
        p.block((l / 2 - 0.01, y - 0.15, 1.0), (l / 2 + 0.02, y + 0.15, 1.15), accent=LAMP)
    p.block(
        (l / 2 - 0.05, -w / 2 + 0.1, 0.4), (l / 2 + 0.02, w / 2 - 0.1, 0.7), -0.5, accent=DARK
    )  # bumper
    for x in (l / 2 - 1.3, -l / 2 + 2.6, -l / 2 + 1.5):
        for y in (-w / 2 + 0.2, w / 2 - 0.2):
            _wheel(p, x, y, wr, 0.4)


@builder("bus")
def _bus(p: Parts, w: float, h: float, l: float) -> None:
    wr = 0.5
    p.block((-l / 2, -w / 2, 0.35), (l / 2, w / 2, h - 0.15), 0.0)
    p.block(
        (-l / 2 + 0.2, -w / 2 + 0.1, h - 0.15), (l / 2 - 0.2, w / 2 - 0.1, h - 0.05), 0.3
    )  # roof
    p.block((-l / 2 + 2.0, -0.5, h - 0.05), (-l / 2 + 3.5, 0.5, h), -0.3)  # roof unit
    for s in (-1, 1):  # window bands
        p.block(
            (-l / 2 + 0.4, s * w / 2 - 0.01, 1.5),
            (l / 2 - 0.3, s * w / 2 + 0.01, h - 0.5),
            accent=GLASS,
        )
    p.block(
        (l / 2 - 0.01, -w / 2 + 0.1, 1.0), (l / 2 + 0.01, w / 2 - 0.1, h - 0.4), accent=GLASS
    )  # windscreen
    for x in (l / 2 - 2.0, -l / 2 + 6.0):  # doors on the right (-y) side
        p.block(
            (x - 0.55, -w / 2 - 0.02, 0.4),
            (x + 0.55, -w / 2 + 0.01, h - 0.5),
            accent=GLASS,
            shade=-0.3,
        )
    for y in (-w / 2 + 0.3, w / 2 - 0.3):
        p.block((l / 2 - 0.01, y - 0.15, 0.6), (l / 2 + 0.02, y + 0.15, 0.75), accent=LAMP)
        p.block((-l / 2 - 0.02, y - 0.1, 0.6), (-l / 2 + 0.01, y + 0.1, 1.0), accent=RED_LIGHT)
    for x in (l / 2 - 2.8, -l / 2 + 3.0):
        for y in (-w / 2 + 0.2, w / 2 - 0.2):
            _wheel(p, x, y, wr, 0.35)


def _spoked_wheel(p: Parts, x: float, z: float, r: float, tyre: float) -> None:
    """Bicycle-style wheel in the x-z plane: tyre ring, hub and a few spokes."""
    p.torus((x, 0, z), r - tyre, tyre, axis="y", accent=DARK, sections=(18, 5))
    p.cylinder((x, 0, z), 0.03, 0.08, axis="y", accent=METAL, sections=8)
    for k in range(4):
        a = k * math.pi / 4
        d = (r - tyre) * np.array([math.cos(a), 0, math.sin(a)])
        p.rod(np.array([x, 0, z]) - d, np.array([x, 0, z]) + d, 0.004, accent=METAL, sections=4)


@builder("bicycle")
def _bicycle(p: Parts, w: float, h: float, l: float) -> None:
    r = 0.34
    rear, front = np.array([-l / 2 + r, 0, r]), np.array([l / 2 - r, 0, r])
    bb = np.array([-0.1, 0, 0.3])  # bottom bracket
    seat_top = np.array([-0.26, 0, 0.85])
    head_top, head_bot = np.array([0.42, 0, 0.86]), np.array([0.47, 0, 0.7])
    for x in (rear[0], front[0]):
        _spoked_wheel(p, x, r, r, 0.025)
    tube = 0.018
    for a, b in (
        (rear, bb),
        (rear, seat_top),
        (bb, seat_top),
        (seat_top, head_top),
        (bb, head_bot),
        (head_bot, head_top),
    ):
        p.rod(a, b, tube, 0.0, sections=6)
    p.rod(head_bot, front, 0.014, -0.2, sections=6)  # fork
    p.rod(head_top, head_top + [-0.02, 0, 0.17], 0.014, -0.2, sections=6)  # stem
    p.rod(
        head_top + [-0.02, -w / 2, 0.17],
        head_top + [-0.02, w / 2, 0.17],
        0.014,
        accent=DARK,
        sections=6,
    )
    p.rod(seat_top, seat_top + [-0.02, 0, 0.15], 0.012, accent=METAL, sections=6)
    p.box(seat_top + [0.0, 0, 0.17], (0.26, 0.12, 0.05), accent=DARK)  # saddle
    p.cylinder(bb, 0.08, 0.02, axis="y", accent=METAL, sections=12)  # chainring
    for s in (-1, 1):
        p.box(bb + [0.1 * s, 0.1 * s, -0.1 * s], (0.1, 0.08, 0.02), accent=DARK)  # pedals


@builder("motorcycle")
def _motorcycle(p: Parts, w: float, h: float, l: float) -> None:
    r = 0.32
    rear, front = np.array([-l / 2 + r + 0.05, 0, r]), np.array([l / 2 - r - 0.05, 0, r])
    for c in (rear, front):
        p.torus(c, r - 0.06, 0.06, axis="y", accent=DARK, sections=(18, 6))
        p.cylinder(c, r - 0.12, 0.04, axis="y", accent=METAL, sections=12)
    p.block((-0.25, -0.15, 0.25), (0.25, 0.15, 0.6), accent=METAL, shade=-0.2)  # engine
    p.ellipsoid((0.2, 0, 0.85), (0.3, 0.17, 0.13), 0.05)  # tank
    p.block((-0.62, -0.14, 0.72), (-0.02, 0.14, 0.82), -0.6, accent=DARK)  # seat
    p.block((-0.75, -0.12, 0.66), (-0.4, 0.12, 0.74), 0.0)  # tail
    p.rod(rear, (-0.1, 0, 0.5), 0.03, accent=METAL)  # swing arm
    head = np.array([0.62, 0, 0.85])
    for s in (-1, 1):
        p.rod(front + [0, s * 0.08, 0], head + [0, s * 0.08, 0], 0.028, accent=METAL)  # fork
        p.rod(
            head + [-0.05, 0, 0.12], head + [-0.08, s * (w / 2 - 0.02), 0.16], 0.016, accent=DARK
        )  # handlebar
        p.box(
            head + [-0.1, s * (w / 2 - 0.05), h - 0.885], (0.02, 0.1, 0.07), accent=GLASS
        )  # mirrors
        p.rod(
            head + [-0.08, s * (w / 2 - 0.07), 0.16],
            head + [-0.1, s * (w / 2 - 0.05), h - 0.885],
            0.006,
            accent=DARK,
        )
    p.rod(head, head + [-0.05, 0, 0.12], 0.03, accent=DARK)
    p.ellipsoid(head + [0.1, 0, 0.0], (0.07, 0.09, 0.09), accent=LAMP)  # headlight
    p.rod((-0.2, -0.17, 0.32), (-0.8, -0.2, 0.42), 0.045, accent=METAL)  # exhaust
    p.hull(
        [head + [-0.05, sy * 0.12, dz] for sy in (-1, 1) for dz in (-0.05, 0.2)]
        + [(0.3, sy * 0.16, 0.35) for sy in (-1, 1)]
        + [(0.45, sy * 0.12, 0.75) for sy in (-1, 1)],
        0.1,
    )  # fairing
    for c, a0, a1 in (
        (front, 0.2, 1.9),
        (rear, 1.4, 2.9),
    ):  # fenders: arcs of short boxes over the wheels
        for k in range(5):
            a = a0 + (a1 - a0) * (k + 0.5) / 5
            seg = (r + 0.04) * 2 * math.sin((a1 - a0) / 10) + 0.01
            p.box(
                c + (r + 0.04) * np.array([math.cos(a), 0, math.sin(a)]),
                (seg, 0.14, 0.015),
                0.0,
                rotate=("y", math.pi / 2 - a),
            )


@builder("tree")
def _tree(p: Parts, w: float, h: float, l: float) -> None:
    p.cylinder(
        (0, 0, 0.3 * h),
        0.07 * min(w, l),
        0.6 * h,
        sections=10,
        top_scale=0.6,
        accent=WOOD,
        shade=-0.2,
    )
    rw, rl = w / 2, l / 2
    crowns = [
        ((0, 0, 0.72 * h), (0.75, 0.75, 0.28), 0.0),
        ((0.4 * rl, 0.25 * rw, 0.62 * h), (0.6, 0.55, 0.22), -0.15),
        ((-0.4 * rl, 0.4 * rw, 0.66 * h), (0.6, 0.6, 0.22), 0.1),
        ((0.0, -0.4 * rw, 0.62 * h), (0.6, 0.6, 0.22), -0.05),
        ((0.05 * rl, 0.0, 0.86 * h), (0.5, 0.5, 0.14), 0.15),
    ]
    for c, (a, b, cz), shade in crowns:
        p.ellipsoid(c, (a * rl, b * rw, cz * h), shade)


def _lumpy(
    center: Vec, radii: Vec, rng: np.random.Generator, roughness: float, subdivisions: int = 2
) -> trimesh.Trimesh:
    """Irregular blob: an icosphere with deterministic radial noise, flat at z = 0."""
    m = trimesh.creation.icosphere(subdivisions=subdivisions)
    v = m.vertices * (1.0 + roughness * rng.uniform(-1, 1, size=(len(m.vertices), 1)))
    v = v * np.asarray(radii, float) + np.asarray(center, float)
    v[:, 2] = np.maximum(v[:, 2], 0.0)
    return trimesh.Trimesh(v, m.faces, process=False)


@builder("rock")
def _rock(p: Parts, w: float, h: float, l: float) -> None:
    rng = np.random.default_rng(1)
    m = _lumpy((0, 0, 0.3 * h), (l / 2, w / 2, 0.7 * h), rng, 0.18)
    shades = rng.uniform(-0.2, 0.15, size=len(m.vertices))
    p.add_colored(m, np.stack([p.color(float(s)) for s in shades]))


@builder("debris_pile")
def _debris_pile(p: Parts, w: float, h: float, l: float) -> None:
    rng = np.random.default_rng(2)
    p.add(_lumpy((0, 0, -0.25 * h), (0.45 * l, 0.45 * w, 0.9 * h), rng, 0.12, subdivisions=1), -0.1)
    for i in range(9):  # planks, bricks and slabs scattered on the mound
        x, y = rng.uniform(-0.3, 0.3) * l, rng.uniform(-0.3, 0.3) * w
        z = 0.65 * h * (1 - (x / (0.45 * l)) ** 2 - (y / (0.45 * w)) ** 2) ** 0.5
        size = (rng.uniform(0.3, 0.9), rng.uniform(0.08, 0.25), rng.uniform(0.04, 0.12))
        yaw = rng.uniform(0, math.pi)
        m = trimesh.creation.box(extents=size)
        m.apply_transform(_rotation("y", rng.uniform(-0.5, 0.5)))
        m.apply_transform(_rotation("z", yaw))
        m.apply_translation((x, y, z))
        accent = (WOOD, None, METAL)[i % 3]
        p.add(m, float(rng.uniform(-0.3, 0.3)), accent)


@builder("unknown_object")
def _unknown_object(p: Parts, w: float, h: float, l: float) -> None:
    rng = np.random.default_rng(3)  # a tarp-covered lump with a hazard band
    pts = rng.uniform(-0.5, 0.5, size=(24, 3)) * [l, w, h] + [0, 0, h / 2]
    pts = np.vstack([pts, [[sx * l / 2, sy * w / 2, 0] for sx in (-1, 1) for sy in (-1, 1)]])
    p.hull(np.clip(pts, [-l / 2, -w / 2, 0], [l / 2, w / 2, h]), 0.0)
    for i in range(6):
        x = -l / 2 + (i + 0.5) * l / 6
        p.block(
            (x - 0.035, -w / 2 - 0.01, 0),
            (x + 0.035, w / 2 + 0.01, 0.06),
            accent=(DARK, LAMP)[i % 2],
        )


# --- Catalog reading and output ---------------------------------------------------------------


def read_catalog(path: Path = CATALOG_PATH) -> list[dict]:
    """The raw ``[[object]]`` tables (name, size, model, color) of a catalog file.

    Reads the TOML directly (not :mod:`pipeline.catalog`, which requires the models to exist).
    """
    with open(path, "rb") as f:
        data = tomllib.load(f)
    return list(data.get("object", []))


def _parse_color(text: str) -> RGB:
    t = text.lstrip("#")
    if len(t) == 3:
        t = "".join(c * 2 for c in t)
    return (int(t[0:2], 16), int(t[2:4], 16), int(t[4:6], 16))


def build_model(kind: str, size: Sequence[float] | None, color: RGB) -> trimesh.Trimesh:
    """Build and normalise one proxy mesh.

    Args:
        kind: Builder name (the model file stem, e.g. ``office_chair``); unknown kinds get a box.
        size: Typical ``(w, h, l)`` [m] the parts are laid out at; ``None`` for the nominal size.
        color: Class colour ``(r, g, b)``.

    Returns:
        The mesh in the object frame (x forward, y left, z up), bounds exactly ``[-0.5, 0.5]^3``.
    """
    w, h, l = size if size is not None else NOMINAL_SIZES.get(kind, DEFAULT_NOMINAL_SIZE)
    parts = Parts(color)
    BUILDERS.get(kind, _box)(parts, float(w), float(h), float(l))
    return normalize(parts.mesh())


def _matte_material(tree: dict) -> None:
    """glTF post-processing: one non-metallic material that multiplies the vertex colours."""
    tree["materials"] = [
        {
            "pbrMetallicRoughness": {
                "baseColorFactor": [1, 1, 1, 1],
                "metallicFactor": 0.0,
                "roughnessFactor": 0.85,
            }
        }
    ]
    for mesh in tree.get("meshes", []):
        for prim in mesh["primitives"]:
            prim["material"] = 0


def export_glb(mesh: trimesh.Trimesh, path: Path, name: str) -> None:
    """Write ``mesh`` as a GLB with vertex colours, a matte material and no normals."""
    scene = trimesh.Scene()
    scene.add_geometry(mesh, geom_name=name, node_name=name)
    data = trimesh.exchange.gltf.export_glb(
        scene, include_normals=False, tree_postprocessor=_matte_material
    )
    path.write_bytes(data)


def write_models(
    out_dir: Path = PROXY_DIR, catalog: Path = CATALOG_PATH, only: Iterable[str] | None = None
) -> dict[str, Path]:
    """Build the model of every catalog entry plus the fallback box into ``out_dir``.

    Returns:
        ``{model file name: written path}``.
    """
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    wanted = set(only) if only is not None else None
    jobs: list[tuple[str, Sequence[float] | None, RGB, str]] = []
    for entry in read_catalog(Path(catalog)):
        size = entry.get("size")
        jobs.append(
            (
                entry["model"],
                None if size == "unknown" else size,
                _parse_color(entry["color"]),
                entry["name"],
            )
        )
    jobs.append((FALLBACK_MODEL, (1.0, 1.0, 1.0), FALLBACK_COLOR, "box"))
    written: dict[str, Path] = {}
    for model, size, color, name in jobs:
        if wanted is not None and name not in wanted and model not in wanted:
            continue
        kind = Path(model).stem
        mesh = build_model(kind, size, color)
        path = out_dir / model
        export_glb(mesh, path, name)
        written[model] = path
    return written


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--out",
        type=Path,
        default=PROXY_DIR,
        help="output directory (default: assets/proxy_models)",
    )
    parser.add_argument("--catalog", type=Path, default=CATALOG_PATH, help="catalog TOML file")
    parser.add_argument("--only", nargs="+", metavar="NAME", help="build only these classes")
    args = parser.parse_args(argv)
    try:
        written = write_models(args.out, args.catalog, args.only)
    except (OSError, KeyError, ValueError, tomllib.TOMLDecodeError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    for model, path in written.items():
        mesh = trimesh.load(path, force="mesh", process=False)
        print(f"{model:24s} {len(mesh.faces):5d} faces {path.stat().st_size / 1024:6.1f} KB")
    return 0


if __name__ == "__main__":
    sys.exit(main())
