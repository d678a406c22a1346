"""Proxy builders of furniture: desks, tables, chairs, stools, sofas, benches, beds, drawers,
cupboards, cabinets, a refrigerator, shelves, a door and the bathroom (toilet, sink, bathtub).

Each builder lays out its parts at ``(w, h, l)`` [m] in the object frame: x in [-l/2, l/2] (front
+x), y in [-w/2, w/2], z in [0, h]; :func:`~assets.make_proxy_models.build_model` normalises.
"""

from __future__ import annotations

import math

import numpy as np

from .parts import DARK, GLASS, METAL, Parts, WOOD
from .registry import builder


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


@builder("table")
def _table(p: Parts, w: float, h: float, l: float) -> None:
    p.block((-l / 2, -w / 2, h - 0.04), (l / 2, w / 2, h), 0.1)
    p.block(
        (-l / 2 + 0.06, -w / 2 + 0.06, h - 0.12), (l / 2 - 0.06, w / 2 - 0.06, h - 0.04), -0.2
    )  # apron
    for x in (-l / 2 + 0.06, l / 2 - 0.12):
        for y in (-w / 2 + 0.06, w / 2 - 0.12):
            p.block((x, y, 0), (x + 0.06, y + 0.06, h - 0.04), -0.15)
