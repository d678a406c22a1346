"""Proxy builders of vehicles: car, van, truck, bus (wheels with rims), bicycle, motorcycle.

Each builder lays out its parts at ``(w, h, l)`` [m] in the object frame: x in [-l/2, l/2] (front
+x), y in [-w/2, w/2], z in [0, h]; :func:`~assets.make_proxy_models.build_model` normalises.
"""

from __future__ import annotations

import math

import numpy as np

from .parts import DARK, GLASS, LAMP, METAL, Parts, RED_LIGHT, WHITE
from .registry import builder


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
