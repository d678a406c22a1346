"""Proxy builders of outdoor and work-site things: a ladder, a pallet, a barrel, a traffic cone,
a fire hydrant, a person, a tree, a rock, a debris pile and the unknown-object lump.

Each builder lays out its parts at ``(w, h, l)`` [m] in the object frame: x in [-l/2, l/2] (front
+x), y in [-w/2, w/2], z in [0, h]; :func:`~assets.make_proxy_models.build_model` normalises.
The random shapes (rock, debris) use fixed seeds: the same size gives the same mesh.
"""

from __future__ import annotations

import math

import numpy as np
import trimesh

from .parts import DARK, LAMP, METAL, Parts, SKIN, Vec, WHITE, WOOD, rotation
from .registry import builder


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
        m.apply_transform(rotation("y", rng.uniform(-0.5, 0.5)))
        m.apply_transform(rotation("z", yaw))
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
