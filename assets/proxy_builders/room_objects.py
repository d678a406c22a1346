"""Proxy builders of things found in a room: the paper's suitcase, compressor, cardboard box,
sports mat and robot dog, a monitor, a laptop, a backpack, a bottle, a cup, a trash bin, a plant.

Each builder lays out its parts at ``(w, h, l)`` [m] in the object frame: x in [-l/2, l/2] (front
+x), y in [-w/2, w/2], z in [0, h]; :func:`~assets.make_proxy_models.build_model` normalises.
"""

from __future__ import annotations

import math

import numpy as np

from .parts import DARK, GLASS, METAL, Parts, TERRACOTTA, WHITE, WOOD
from .registry import builder


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
