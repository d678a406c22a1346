"""Mapping error of ground-truth perception on simulator renders against the hidden world.

Run from the repository root::

    python bench/sim_mapping.py

Renders the paper's room from a few robot poses (world frame, z up [m]), maps each render through
the real :class:`~pipeline.mapper.Mapper` with the ground-truth backend (boxes, masks, metric depth
from the renderer: what the console does without model weights), matches every mapped object to the
nearest hidden object of its label and prints the 3D centre error [m], the error relative to the
camera distance [%], the objects mapped outside the 5 x 8 x 3 m workspace and the yaw error mod pi
[deg] of the objects with a clear length axis (hidden size ``|l - w| > 0.2 m``; yaw = heading of the
length axis about world z, see :mod:`pipeline.scene`). ``--compare`` also maps without the yaw from
depth points (``MapperConfig(yaw_from_depth=False)``: every object faces the camera).

``--tour [--noise] [--seed N] [--extended] [--table SEEDS]`` is the map-fusion benchmark of issue 12 (see :mod:`bench.sim_tour`):
the robot captures from :data:`bench.sim_tour.TOUR` (10 poses: the good ones plus a close-up of a desk
and views with objects cut by the border) and the captures are folded into one map by
:func:`pipeline.mapping.map_fusion.fuse` and, in the same run, by the merge the console used before
(``bench/legacy_merge.py``: newest estimate wins).
"""

from __future__ import annotations

import argparse
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

import numpy as np  # noqa: E402

from console.link.sim import SimRobot  # noqa: E402
from console.link.world import paper_room  # noqa: E402
from console.session.mapping_job import ground_truth_bundle_for  # noqa: E402
from pipeline.catalog import default_catalog  # noqa: E402
from pipeline.camera.geometry import Pose  # noqa: E402
from pipeline.mapper import Mapper, MapperConfig  # noqa: E402
from planner.grid import Workspace  # noqa: E402

POSES: list[tuple[float, float, float]] = [
    (2.5, 0.7, math.pi / 2),  # the start, facing the box line
    (1.0, 1.0, math.pi / 2 - 0.4),
    (4.2, 0.9, math.pi / 2 + 0.5),
    (2.5, 5.0, math.pi / 2),  # behind the line, facing the dog
    (0.8, 5.2, 0.3),
]
"""Robot poses ``(x [m], y [m], yaw [rad])`` on the floor, world frame."""


CLEAR_LENGTH_AXIS = 0.2
"""Smallest ``|l - w|`` [m] of a hidden object whose yaw error is measured."""


def yaw_error_mod_pi(a: float, b: float) -> float:
    """Angle [rad] in ``[0, pi/2]`` between two headings taken modulo pi (a box is symmetric under a
    half turn)."""
    d = (a - b) % math.pi
    return min(d, math.pi - d)


def measure(config: MapperConfig | None = None) -> dict[str, float]:
    """Map every pose, print one line per pose and the totals; returns the totals."""
    truth = paper_room().objects
    ws = Workspace()
    catalog = default_catalog()
    errors: list[float] = []
    rel: list[float] = []
    yaw_err: list[float] = []
    outside = mapped = 0
    for x, y, yaw in POSES:
        robot = SimRobot(start=Pose.from_xyz_yaw(x, y, 0.0, yaw), manual_clock=True)
        robot.connect()
        shot = robot.capture()
        robot.close()
        with Mapper(ground_truth_bundle_for(shot), catalog, config) as mapper:
            res = mapper.run(shot.image, shot.intrinsics, shot.mount, shot.robot_pose, capture_id="bench")
        cam = np.asarray(shot.camera_pose.translation, dtype=np.float64)
        pose_err = []
        out_here = 0
        for obj in res.scene.objects:
            same = [t for t in truth if t.label == obj.label]
            if not same:
                continue
            t = min(same, key=lambda t: math.dist(t.position, obj.position))
            e = math.dist(t.position, obj.position)
            pose_err.append(e)
            rel.append(e / max(float(np.linalg.norm(np.asarray(t.position) - cam)), 1e-6))
            out_here += not ws.contains(obj.position)
            if abs(t.size[2] - t.size[0]) > CLEAR_LENGTH_AXIS:
                yaw_err.append(yaw_error_mod_pi(obj.yaw, t.yaw))
        mapped += len(res.scene.objects)
        outside += out_here
        errors += pose_err
        med = float(np.median(pose_err)) if pose_err else float("nan")
        print(f"pose ({x:.1f}, {y:.1f}, yaw {math.degrees(yaw):5.1f} deg): {len(res.scene.objects):2d} objects "
              f"({len(shot.ground_truth.visible)} visible), median error {med:.2f} m, outside workspace {out_here}")
    e, r = np.array(errors), np.array(rel)
    totals = {"mapped": mapped, "matched": len(e), "median_m": float(np.median(e)), "mean_m": float(e.mean()),
              "median_rel": float(np.median(r)), "mean_rel": float(r.mean()), "outside": outside,
              "yaw_n": len(yaw_err), "yaw_median_deg": math.degrees(float(np.median(yaw_err))) if yaw_err else math.nan,
              "yaw_max_deg": math.degrees(max(yaw_err)) if yaw_err else math.nan}
    print(f"all: {mapped} mapped, {len(e)} matched; 3D centre error median {totals['median_m']:.3f} m, "
          f"mean {totals['mean_m']:.3f} m; relative to distance median {100 * totals['median_rel']:.1f} %, "
          f"mean {100 * totals['mean_rel']:.1f} %; outside the workspace {outside}")
    print(f"yaw error mod pi over {totals['yaw_n']} objects with |l - w| > {CLEAR_LENGTH_AXIS} m: median "
          f"{totals['yaw_median_deg']:.1f} deg, max {totals['yaw_max_deg']:.1f} deg")
    return totals


def _parse(argv: list[str]) -> argparse.Namespace:
    from sim_tour import add_tour_options  # noqa: E402  (bench/ is on sys.path when run as a script)

    parser = argparse.ArgumentParser(
        prog="sim_mapping.py", description="Mapping error of ground-truth perception on simulator renders "
                                           "against the hidden world (per pose and in total).")
    parser.add_argument("--compare", action="store_true",
                        help="also map without the yaw from depth points (every object faces the camera), "
                             "as the baseline in the same run")
    parser.add_argument("--tour", action="store_true",
                        help="the map-fusion benchmark instead: a tour of captures fused into one map, beside "
                             "the former merge (see bench/sim_tour.py)")
    add_tour_options(parser)
    args = parser.parse_args(argv)
    if (args.noise or args.seed != 1 or args.extended or args.table is not None) and not args.tour:
        parser.error("--noise, --seed, --extended and --table go with --tour")
    return args


if __name__ == "__main__":
    args = _parse(sys.argv[1:])
    if args.tour:
        from sim_tour import main as tour_main  # noqa: E402

        tour_main([a for a in sys.argv[1:] if a != "--tour"])
        sys.exit(0)
    if args.compare:
        print("without yaw from depth points (every object faces the camera):")
        measure(MapperConfig(yaw_from_depth=False))
        print("with the default configuration:")
    measure()
