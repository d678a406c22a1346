"""How the second detector (the Open Images SSD) is best run and merged with YOLOX-Nano, on a dataset in
the format of ``../shared/bench/dev``: detection only (no distances), so each variant costs no mapping.

Each detector runs once per photo and input plan at a low score threshold (0.1); the variants then
filter and merge those detections:

- input plans of the SSD (it stretches the whole image to 300 x 300): ``whole``; ``whole+windows``
  (square windows of the short side for photos wider than 3:2, the product's plan); ``whole+tiles450`` /
  ``whole+tiles300`` (square tiles of 1.5 / 1.0 input sizes besides the whole image);
- merges: the SSD alone; ``union`` (every class of both, :class:`pipeline.models.ssd.MergedDetector`
  ``policy="union"``); ``class_aware`` (the product's: desk, cardboard_box and table from the SSD,
  every other class from YOLOX-Nano); ``agreement`` (class-aware, plus YOLOX-Nano detections of 0.1-0.25
  confirmed by an SSD box of the same class, IoU >= 0.5, SSD score >= 0.2).

Scoring as ``morphonavi bench`` does it, on the detections (placement not run, so an object the mapper
could not place still counts): cross-class duplicates at IoU > 0.8 keep the more confident
(``MapperConfig.same_object_iou``), then greedy one-to-one matching by 2D IoU >= 0.5 with the same
class; found = matched ground-truth objects of catalog classes; precision on the fully annotated
photos; unmatched = all photos. Time = mean per photo of that plan's detector runs [s].

    .venv/bin/python bench/detector_variants.py [DATASET_DIR] [--models DIR]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Callable

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from pipeline.bench.evaluate import load_dataset, match_greedy  # noqa: E402
from pipeline.catalog import Catalog  # noqa: E402
from pipeline.camera.image_io import read_image  # noqa: E402
from pipeline.models.base import Detection  # noqa: E402
from pipeline.models.nms import box_iou, nms  # noqa: E402
from pipeline.models.ssd import MergedDetector, SsdDetector  # noqa: E402
from pipeline.models.yolox import YoloxDetector  # noqa: E402
from pipeline.models.tiled_detection import detect_planned, merge_detections, tile_detections  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def ssd_plans(ssd: SsdDetector, image: np.ndarray, prompts: list) -> dict[str, tuple[list[Detection], float]]:
    """The SSD's detections and time [s] under each input plan."""
    out = {}
    h, w = image.shape[:2]
    for name, tile_factor in (("whole", None), ("whole+windows", None), ("whole+tiles450", 1.5), ("whole+tiles300", 1.0)):
        t0 = time.perf_counter()
        if name == "whole+windows":
            ssd.tile_factor = None
            found = detect_planned(ssd, image, prompts)
        elif name == "whole":
            found = ssd.detect(image, prompts)
        else:  # square tiles of its own input size, no windows
            found = list(ssd.detect(image, prompts))
            side = int(round(tile_factor * 300))
            if max(w, h) > 1.25 * side:
                found = merge_detections(found + tile_detections(ssd, image, prompts, side, square=True), 0.5)
        out[name] = (found, time.perf_counter() - t0)
    return out


def score(samples: list, dets: dict[str, list[Detection]]) -> tuple[int, int, int, int]:
    """``(found, matched on complete photos, detections on complete photos, unmatched on all photos)``."""
    found = m_c = d_c = unmatched = 0
    for s in samples:
        ds = sorted(dets[s.id], key=lambda d: -d.score)
        if len(ds) > 1:
            keep = nms(np.array([d.box for d in ds]), np.array([d.score for d in ds]), 0.8)
            ds = [ds[i] for i in sorted(keep)]
        gts = [o for o in s.objects if o.cls is not None]
        pairs = match_greedy(np.array([d.box for d in ds]).reshape(-1, 4), [d.label for d in ds],
                             np.array([o.box for o in gts]).reshape(-1, 4), [o.cls for o in gts], 0.5)
        found += len(pairs)
        unmatched += len(ds) - len(pairs)
        if not s.partial_annotation:
            m_c += len(pairs)
            d_c += len(ds)
    return found, m_c, d_c, unmatched


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("dataset", nargs="?", default=str(ROOT.parent / "shared" / "bench" / "dev"))
    ap.add_argument("--models", default=str(ROOT.parent / "shared" / "models"))
    args = ap.parse_args()
    catalog = Catalog.load()
    prompts = catalog.prompts()
    samples = load_dataset(args.dataset, catalog)
    yolox = YoloxDetector.from_dir(Path(args.models) / "yolox_nano", threads=1, score_threshold=0.1)
    yolox.label_map = {l: e.name for l in yolox.labels if (e := catalog.lookup(l)) is not None}
    ssd = SsdDetector.from_dir(Path(args.models) / "oidv4_ssd", threads=1, score_threshold=0.1)
    ssd.label_map = {l: e.name for l in ssd.labels[1:] if (e := catalog.lookup(l)) is not None}
    y_raw: dict[str, list[Detection]] = {}
    s_raw: dict[str, dict[str, tuple[list[Detection], float]]] = {}
    y_time = []
    for s in samples:
        image = read_image(s.image_path).image
        t0 = time.perf_counter()
        y_raw[s.id] = detect_planned(yolox, image, prompts, 1.5)
        y_time.append(time.perf_counter() - t0)
        s_raw[s.id] = ssd_plans(ssd, image, prompts)
    yolox.score_threshold, ssd.score_threshold = 0.25, 0.3  # the product's thresholds, for the merge margins
    n_gt = sum(1 for s in samples for o in s.objects if o.cls is not None)

    def keep(ds: list[Detection], t: float) -> list[Detection]:
        return [d for d in ds if d.score >= t]

    def row(name: str, pick: Callable[[str], list[Detection]], seconds: float) -> None:
        f, mc, dc, u = score(samples, {s.id: pick(s.id) for s in samples})
        prec = f"{mc}/{dc} = {mc / dc:.1%}" if dc else "-"
        print(f"{name:44s} {f:3d}/{n_gt}  {prec:>16s}  {u:4d}  {seconds:6.3f}")

    print(f"{'variant':44s} {'found':>6s}  {'precision (full)':>16s}  {'unm.':>4s}  {'time s':>6s}")
    row("YOLOX-Nano alone (0.25, 624 px tiles)", lambda i: keep(y_raw[i], 0.25), float(np.mean(y_time)))
    for plan in ("whole", "whole+windows", "whole+tiles450", "whole+tiles300"):
        t_ssd = float(np.mean([s_raw[s.id][plan][1] for s in samples]))
        for t in (0.3, 0.4):
            row(f"SSD alone, {plan}, {t}", lambda i: keep(s_raw[i][plan][0], t), t_ssd)
        for policy in ("union", "class_aware"):
            merged = MergedDetector(yolox, ssd, policy=policy, second_owns={"table"})
            row(f"YOLOX + SSD {policy}, {plan}, 0.3",
                lambda i: merged.merge([keep(y_raw[i], 0.25), keep(s_raw[i][plan][0], 0.3)], prompts),
                float(np.mean(y_time)) + t_ssd)
        merged = MergedDetector(yolox, ssd, policy="class_aware", second_owns={"table"})

        def agreement(i: str) -> list[Detection]:
            base = merged.merge([keep(y_raw[i], 0.25), keep(s_raw[i][plan][0], 0.3)], prompts)
            weak = [d for d in y_raw[i] if 0.1 <= d.score < 0.25]
            strong_ssd = [e for e in s_raw[i][plan][0] if e.score >= 0.2]
            for d in weak:
                same = [e.box for e in strong_ssd if e.label == d.label]
                if same and box_iou(np.array([d.box]), np.array(same)).max() >= 0.5:
                    base.append(d)
            return base

        row(f"YOLOX + SSD agreement, {plan}", agreement, float(np.mean(y_time)) + t_ssd)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
