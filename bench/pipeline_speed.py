"""Mapping speed on 640 x 480 photos: all stages, concurrent (default) vs one after another (baseline).

Every photo of a dataset folder in the format of ``../shared/bench/dev`` is resized to 640 x 480
(intrinsics scaled with it) and mapped ``--repeats`` times with the offline models. Prints the
median time per stage and in total [s] for the default mapper and for the sequential baseline
(``MapperConfig(parallel=False)``), and their ratio.

    .venv/bin/python bench/pipeline_speed.py [DATASET_DIR] [--models DIR] [--repeats 3] [--segment all|auto|none]
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:] = [p for p in sys.path if Path(p or ".").resolve() != Path(__file__).resolve().parent]
sys.path.insert(0, str(ROOT))  # the repository's packages, also without an installed checkout

from pipeline.catalog import default_catalog  # noqa: E402
from pipeline.geometry import CameraMount, Intrinsics, Pose  # noqa: E402
from pipeline.image_io import load_image  # noqa: E402
from pipeline.mapper import Mapper, MapperConfig, load_mapping_models  # noqa: E402

W, H = 640, 480


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


def run(mapper: Mapper, shots: list[tuple[np.ndarray, Intrinsics]], repeats: int) -> dict[str, float]:
    """Median time per stage over all photos and repeats [s]."""
    per_stage: dict[str, list[float]] = {}
    for _ in range(repeats):
        for img, intr in shots:
            scene = mapper.map_image(img, intr, CameraMount(), Pose())
            for k, v in scene.captures[0].timings.items():
                per_stage.setdefault(k, []).append(v)
    return {k: statistics.median(v) for k, v in per_stage.items()}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dataset", nargs="?", type=Path, default=ROOT.parent / "shared" / "bench" / "dev")
    ap.add_argument("--models", type=Path, default=None, help="offline model folder (default: the usual places)")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--segment", choices=("all", "auto", "none"), default="all")
    args = ap.parse_args()
    catalog = default_catalog()
    models = load_mapping_models("offline", args.models, catalog)
    shots = photos(args.dataset)
    if not shots:
        print(f"no photos in {args.dataset}", file=sys.stderr)
        return 2
    config = MapperConfig(segment=args.segment)
    with Mapper(models, catalog, config) as warm:
        warm.map_image(shots[0][0], shots[0][1], CameraMount(), Pose())
    results = {}
    for name, cfg in (("concurrent (default)", config), ("sequential (baseline)", replace(config, parallel=False))):
        with Mapper(models, catalog, cfg) as mapper:
            results[name] = run(mapper, shots, args.repeats)
    print(f"{len(shots)} photos at {W}x{H}, {args.repeats} repeats, segment={args.segment}; median [s] per stage:")
    stages = sorted({k for r in results.values() for k in r} - {"total"}) + ["total"]
    print(f"{'':24s}" + "".join(f"{s:>17s}" for s in stages))
    for name, r in results.items():
        print(f"{name:24s}" + "".join(f"{r.get(s, float('nan')):17.3f}" for s in stages))
    a, b = results["concurrent (default)"]["total"], results["sequential (baseline)"]["total"]
    print(f"total: {a:.3f} s concurrent vs {b:.3f} s sequential: {b / a:.2f}x; target <= 1.0 s: "
          f"{'met' if a <= 1.0 else 'NOT met'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
