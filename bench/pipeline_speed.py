"""Mapping speed on 640 x 480 photos, per stage, as ratios against the previous default in the same run.

Every photo of a dataset folder in the format of ``../shared/bench/dev`` is resized to 640 x 480
(intrinsics scaled with it) and mapped ``--repeats`` times with the offline models, under each
configuration below. The configurations take turns photo by photo (not one block after another), so
a load that changes during the run weighs on all of them alike, and the ratios hold on a machine
shared with other work even when the absolute times do not.

Configurations (``MapperConfig``):

- ``baseline``: the previous default, ``segment="all"`` with ``parallel=True`` (detection, depth
  and the MobileSAM encoder concurrently, one decoder run per box);
- ``all, sequential``: the same stages one after another (what the concurrency buys with the encoder);
- ``auto, concurrent``: ``segment="auto"`` (the encoder only when a mask changes a distance) with
  detection and depth concurrently;
- ``auto, sequential``: ``segment="auto"``, one stage after another (the new default).

Prints the median time per stage and in total [s] per configuration, the speed-up of each stage
against the baseline (``baseline median / configuration median``; ``-`` where a stage did not run),
photos per second, and whether the target (<= 0.10 s median per photo) is met; the mean total and
the photo runs that needed the encoder (a mask that changes a distance) show what the median hides.

    .venv/bin/python bench/pipeline_speed.py [DATASET_DIR] [--models DIR] [--repeats 3]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
from pathlib import Path

import cv2
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:] = [p for p in sys.path if Path(p or ".").resolve() != Path(__file__).resolve().parent]
sys.path.insert(0, str(ROOT))  # the repository's packages, also without an installed checkout

from pipeline.catalog import default_catalog  # noqa: E402
from pipeline.camera.geometry import CameraMount, Intrinsics, Pose  # noqa: E402
from pipeline.camera.image_io import load_image  # noqa: E402
from pipeline.mapper import Mapper, MapperConfig, load_mapping_models  # noqa: E402

W, H = 640, 480
TARGET_S = 0.10
"""Median time per 640 x 480 photo the issue asks for [s] (10 photos per second)."""

CONFIGS: dict[str, MapperConfig] = {
    "baseline (all, concurrent)": MapperConfig(segment="all", parallel=True),
    "all, sequential": MapperConfig(segment="all", parallel=False),
    "auto, concurrent": MapperConfig(segment="auto", parallel=True),
    "auto, sequential": MapperConfig(segment="auto", parallel=False),
}
BASELINE = "baseline (all, concurrent)"
STAGES = ("detect", "segment_encoder", "segment_decoder", "depth", "distance", "total")


def photos(dataset: Path) -> list[tuple[np.ndarray, Intrinsics]]:
    """Every sample resized to 640 x 480 with its scaled intrinsics."""
    out = []
    for meta_path in sorted(dataset.glob("*/*.json")):
        meta = json.loads(meta_path.read_text())
        if "K" not in meta:
            continue
        img = load_image(meta_path.parent / meta["image"])
        intr = Intrinsics.from_K(meta["K"], meta["width"], meta["height"]).scaled(W, H)
        out.append((cv2.resize(img, (W, H), interpolation=cv2.INTER_AREA), intr))
    return out


def measure(mappers: dict[str, Mapper], shots: list[tuple[np.ndarray, Intrinsics]],
            repeats: int) -> dict[str, dict[str, list[float]]]:
    """Times per stage [s] per configuration, one entry per photo run (0 where a stage did not run)."""
    samples: dict[str, dict[str, list[float]]] = {name: {} for name in mappers}
    for _ in range(repeats):
        for img, intr in shots:
            for name, mapper in mappers.items():  # configurations take turns on each photo
                t = mapper.map_image(img, intr, CameraMount(), Pose()).captures[0].timings
                for k in STAGES:
                    samples[name].setdefault(k, []).append(float(t.get(k, 0.0)))
    return samples


def ratio(base: float, value: float) -> str:
    """``base / value`` as ``12.3x``; ``-`` when the stage did not run (or took no measurable time)."""
    if value <= 1e-6:
        return "-" if base <= 1e-6 else "not run"
    return f"{base / value:.2f}x"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dataset", nargs="?", type=Path, default=ROOT.parent / "shared" / "bench" / "dev")
    ap.add_argument("--models", type=Path, default=None, help="offline model folder (default: the usual places)")
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    if args.repeats < 1:
        print("--repeats: must be >= 1", file=sys.stderr)
        return 2
    catalog = default_catalog()
    models = load_mapping_models("offline", args.models, catalog)
    shots = photos(args.dataset)
    if not shots:
        print(f"no photos in {args.dataset}", file=sys.stderr)
        return 2
    mappers = {name: Mapper(models, catalog, cfg) for name, cfg in CONFIGS.items()}
    try:
        for mapper in mappers.values():  # warm-up: onnxruntime's first runs allocate
            mapper.map_image(shots[0][0], shots[0][1], CameraMount(), Pose())
        samples = measure(mappers, shots, args.repeats)
    finally:
        for mapper in mappers.values():
            mapper.close()
    n = len(shots) * args.repeats
    medians = {name: {k: statistics.median(v) for k, v in s.items()} for name, s in samples.items()}
    means = {name: {k: statistics.fmean(v) for k, v in s.items()} for name, s in samples.items()}
    encoder_runs = {name: sum(v > 0 for v in s["segment_encoder"]) for name, s in samples.items()}
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"{len(shots)} photos at {W}x{H}, {args.repeats} repeats, {os.cpu_count()} cores, load average "
          f"{load:.1f} at the end; median [s] per stage (segment_* and depth overlap detect when concurrent):")
    print(f"{'':28s}" + "".join(f"{s:>16s}" for s in STAGES) + f"{'mean total':>12s}{'encoder runs':>14s}")
    for name, r in medians.items():
        print(f"{name:28s}" + "".join(f"{r[s]:16.4f}" for s in STAGES) + f"{means[name]['total']:12.4f}"
              + f"{encoder_runs[name]:>8d} / {n}")
    print(f"speed-up against {BASELINE} (baseline median / median):")
    base = medians[BASELINE]
    for name, r in medians.items():
        if name != BASELINE:
            print(f"{name:28s}" + "".join(f"{ratio(base[s], r[s]):>16s}" for s in STAGES))
    best = min((n_ for n_ in medians if n_ != BASELINE), key=lambda n_: medians[n_]["total"])
    t = medians[best]["total"]
    print(f"fastest: {best}: {t:.3f} s per photo ({1.0 / t:.1f} photos/s), {base['total'] / t:.1f}x the baseline "
          f"({base['total']:.3f} s); target <= {TARGET_S:.2f} s: {'met' if t <= TARGET_S else 'NOT met'}")
    with_enc = [t for t, e in zip(samples[best]["total"], samples[best]["segment_encoder"]) if e > 0]
    if with_enc:
        print(f"  {len(with_enc)} of {n} photo runs needed a mask for a distance (the encoder ran): median "
              f"{statistics.median(with_enc):.3f} s; mean over all runs {means[best]['total']:.3f} s")
    c, s = medians["auto, concurrent"]["total"], medians["auto, sequential"]["total"]
    print(f"concurrency with segment=auto: {s / c:.2f}x the sequential run; with segment=all: "
          f"{medians['all, sequential']['total'] / base['total']:.2f}x")
    return 0


if __name__ == "__main__":
    sys.exit(main())
