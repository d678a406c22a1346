"""Evaluation on a folder of photos with ground-truth 3D objects: the paper's three metrics.

Dataset layout (``../shared/bench/README.md``): ``index.json`` lists the samples
(``{"source", "json", "image", ...}``); each sample JSON holds the image size, ``K`` [px], optionally
``gravity_cam`` (unit gravity in the camera frame) and ``objects`` with ``label``, ``label_raw``,
``center_cam`` (OpenCV camera frame, metres), ``size`` and 2D boxes ``bbox2d_gt`` (the dataset's own,
when present) / ``bbox2d_proj`` (the projected 3D box).

Metrics, over ground-truth objects whose label the catalog resolves (others are excluded and
counted by label):

- detection ratio: share of those objects matched by a detection of the same class; also over the
  objects whose class is in the detector's vocabulary;
- 3D centre error of matched objects: ``|estimated - true|`` of the camera-frame centre [m], and
  relative to the true distance ``|center_cam|``; mean and median;
- time per image per stage [s] (means of the captures' timings);
- precision: on the samples whose annotation is complete (``partial_annotation`` false), the share
  of placed detections that match a ground-truth object, and the number that match none. It makes a
  lower detector threshold's cost visible; an unmatched detection of a partially annotated sample may
  be a real, unlabelled object and is left out. It is a lower bound: a detection of a labelled object
  whose box differs from the dataset's (e.g. an amodal box of a half-hidden person) counts as
  unmatched.

Matching: greedy one-to-one by 2D IoU between a detection box and the object's 2D box
(``bbox2d_gt`` when the dataset has one, else ``bbox2d_proj``), same class only, IoU >=
``iou_threshold`` (default 0.5).

The camera of each sample is given to the mapper as a mount whose pitch and roll put gravity where
``gravity_cam`` says (a level camera when absent), on a robot at the world origin: the mapper's
camera-frame centres are compared with ``center_cam``.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Sequence

import numpy as np
from scipy.spatial.transform import Rotation

from pipeline.bench.report import BenchReport, format_report, models_line, summarise  # noqa: F401 (re-exported)
from pipeline.catalog import Catalog
from pipeline.camera.geometry import OPTICAL_TO_BODY, CameraError, CameraMount, Intrinsics, Pose, mount_from_gravity_height
from pipeline.models.ground_truth import GroundTruthBundle, GroundTruthDetector
from pipeline.camera.image_io import read_image
from pipeline.mapper import Mapper, MapperConfig, MapResult
from pipeline.models.nms import box_iou


class BenchError(ValueError):
    """The dataset folder or a sample file is malformed; the message names the file and field."""


@dataclass(frozen=True)
class GTObject:
    """One ground-truth object: ``cls`` is the catalog class (``None``: not in the catalog)."""

    label: str
    label_raw: str
    cls: str | None
    center_cam: np.ndarray
    box: tuple[float, float, float, float]


@dataclass(frozen=True)
class BenchSample:
    """One photo of the dataset."""

    id: str
    source: str
    image_path: Path
    intrinsics: Intrinsics
    gravity_cam: tuple[float, float, float] | None
    partial_annotation: bool
    objects: tuple[GTObject, ...]
    camera_height: float | None = None
    """Camera centre above the floor [m] (the sample's ``camera_height``), ``None`` when absent."""

    @property
    def pose_given(self) -> bool:
        """The sample gives the camera's gravity (with or without its height: without, there is no floor
        cue, as before the floor fit); a sample without ``gravity_cam`` is mapped with the pose from the photo."""
        return self.gravity_cam is not None

    @property
    def mount(self) -> CameraMount:
        """The camera on a level robot at the world origin: pitch and roll from ``gravity_cam``, height
        ``camera_height`` (floor at world z = 0, so ground-contact ranging knows the floor)."""
        if self.camera_height is None:
            return mount_from_gravity(self.gravity_cam)
        return mount_from_gravity_height(self.gravity_cam or (0.0, 1.0, 0.0), self.camera_height)


def _field(data: dict[str, Any], key: str, where: str) -> Any:
    if key not in data:
        raise BenchError(f"{where}: missing field {key!r}")
    return data[key]


def _read_json(path: Path) -> Any:
    """The JSON in ``path``; :class:`BenchError` naming the file (and the line and column of a syntax error)."""
    from pipeline.file_kind import os_error_words

    try:
        return json.loads(path.read_text(encoding="utf-8-sig"))
    except FileNotFoundError:
        raise BenchError(f"{path}: no such file") from None
    except OSError as exc:
        raise BenchError(f"{path}: cannot read it: {os_error_words(exc, path)}") from None
    except UnicodeDecodeError:
        raise BenchError(f"{path}: is not text (not UTF-8): expected JSON") from None
    except json.JSONDecodeError as exc:
        raise BenchError(f"{path}: not valid JSON (line {exc.lineno}, column {exc.colno}): {exc.msg}") from None
    except RecursionError:
        raise BenchError(f"{path}: not usable JSON: nested too deeply") from None


def _box4(v: Any, where: str) -> tuple[float, float, float, float]:
    try:
        x1, y1, x2, y2 = (float(x) for x in v)
    except (TypeError, ValueError):
        raise BenchError(f"{where}: expected [x1, y1, x2, y2], got {v!r}") from None
    return (x1, y1, x2, y2)


def load_dataset(dataset_dir: str | Path, catalog: Catalog) -> list[BenchSample]:
    """Read ``index.json`` and every sample JSON; labels resolve to catalog classes.

    Raises:
        BenchError: Missing folder, index or sample file, or a malformed field (named).
    """
    root = Path(dataset_dir)
    if not root.is_dir():
        raise BenchError(f"{root}: not a folder (expected a dataset with index.json)")
    index = _read_json(root / "index.json")
    if not isinstance(index, list) or not index:
        raise BenchError(f"{root / 'index.json'}: must be a non-empty list of samples")
    samples = []
    for i, entry in enumerate(index):
        where = f"{root / 'index.json'}[{i}]"
        if not isinstance(entry, dict):
            raise BenchError(f"{where}: must be an object")
        jpath = root / str(_field(entry, "json", where))
        data = _read_json(jpath)
        if not isinstance(data, dict):
            raise BenchError(f"{jpath}: must be an object")
        image_rel = entry.get("image") or (Path(str(_field(entry, "json", where))).parent / str(_field(data, "image", str(jpath))))
        try:
            intr = Intrinsics.from_K(_field(data, "K", str(jpath)), int(_field(data, "width", str(jpath))),
                                     int(_field(data, "height", str(jpath))))
        except (CameraError, TypeError, ValueError) as exc:
            raise BenchError(f"{jpath}: bad camera: {exc}") from None
        g = data.get("gravity_cam")
        gravity = None
        if g is not None:
            try:
                gv = np.asarray(g, dtype=np.float64).reshape(3)
            except (TypeError, ValueError):
                raise BenchError(f"{jpath}: gravity_cam must be 3 numbers, got {g!r}") from None
            if not np.all(np.isfinite(gv)) or np.linalg.norm(gv) < 1e-6:
                raise BenchError(f"{jpath}: gravity_cam must be a non-zero finite vector, got {g!r}")
            gravity = tuple(float(v) for v in gv / np.linalg.norm(gv))
        height = data.get("camera_height")
        if height is not None:
            if isinstance(height, bool) or not isinstance(height, (int, float)) or not (
                    math.isfinite(height) and 0 < height <= 100):
                raise BenchError(f"{jpath}: camera_height must be a number within 0..100 m, got {height!r}")
            height = float(height)
        objs = []
        for j, o in enumerate(data.get("objects") or []):
            ow = f"{jpath}: objects[{j}]"
            label = str(_field(o, "label", ow))
            raw = str(o.get("label_raw") or label)
            entry_c = catalog.lookup(label) or catalog.lookup(raw)
            box_v = o.get("bbox2d_gt") or _field(o, "bbox2d_proj", ow)
            center = np.asarray(_field(o, "center_cam", ow), dtype=np.float64).reshape(-1)
            if center.shape != (3,) or not np.all(np.isfinite(center)):
                raise BenchError(f"{ow}.center_cam: expected 3 finite numbers [m]")
            objs.append(GTObject(label, raw, entry_c.name if entry_c else None, center, _box4(box_v, f"{ow}.bbox2d")))
        samples.append(
            BenchSample(
                id=str(_field(entry, "json", where)).rsplit(".", 1)[0],
                source=str(entry.get("source") or data.get("source") or ""),
                image_path=root / str(image_rel),
                intrinsics=intr,
                gravity_cam=gravity,  # type: ignore[arg-type]
                partial_annotation=bool(data.get("partial_annotation", False)),
                objects=tuple(objs),
                camera_height=height,
            )
        )
    return samples


def mount_from_gravity(gravity_cam: Sequence[float] | None) -> CameraMount:
    """A mount at the robot origin whose pitch and roll put world gravity at ``gravity_cam`` (camera
    frame) for a robot standing level at yaw 0; a level camera for ``None``."""
    if gravity_cam is None:
        return CameraMount(position=(0.0, 0.0, 0.0))
    g = np.asarray(gravity_cam, dtype=np.float64)
    g = g / np.linalg.norm(g)
    # robot <- camera rotation R with R @ g = (0, 0, -1): tilt the level optical frame onto g
    tilt, _ = Rotation.align_vectors([[0.0, 0.0, -1.0]], [OPTICAL_TO_BODY.apply(g)])
    yaw, pitch, roll = tilt.as_euler("ZYX")
    return CameraMount(position=(0.0, 0.0, 0.0), pitch=float(pitch), yaw=float(yaw), roll=float(roll))


def match_greedy(
    det_boxes: np.ndarray, det_classes: Sequence[str], gt_boxes: np.ndarray, gt_classes: Sequence[str | None],
    iou_threshold: float,
) -> list[tuple[int, int, float]]:
    """One-to-one ``(detection index, ground-truth index, IoU)`` pairs of the same class, best IoU first."""
    if len(det_classes) == 0 or len(gt_classes) == 0:
        return []
    iou = box_iou(np.asarray(det_boxes).reshape(-1, 4), np.asarray(gt_boxes).reshape(-1, 4))
    same = np.array([[dc == gc for gc in gt_classes] for dc in det_classes])
    iou = np.where(same, iou, 0.0)
    pairs = [(float(iou[i, j]), i, j) for i, j in zip(*np.nonzero(iou >= iou_threshold))]
    used_d: set[int] = set()
    used_g: set[int] = set()
    out = []
    for v, i, j in sorted(pairs, key=lambda p: -p[0]):
        if i in used_d or j in used_g:
            continue
        used_d.add(i)
        used_g.add(j)
        out.append((int(i), int(j), v))
    return out


def run_bench(
    dataset_dir: str | Path,
    models: Any | None,
    catalog: Catalog,
    *,
    gt_boxes: bool = False,
    config: MapperConfig | None = None,
    iou_threshold: float = 0.5,
    limit: int | None = None,
    sources: Sequence[str] | None = None,
    progress: bool = True,
    drop_pose: bool = False,
) -> BenchReport:
    """Run the mapper on every sample of ``dataset_dir`` and score it.

    Args:
        dataset_dir: Folder with ``index.json``.
        models: Bundle with ``detector``, ``segmenter``, ``depth`` (``None`` only with ``gt_boxes``:
            geometric distances from the boxes alone).
        catalog: Classes and size priors.
        gt_boxes: Use the dataset's 2D boxes (catalog classes) as detections: isolates the distance
            error from the detector. The segmenter and depth model of ``models`` still run.
        config: Mapper settings.
        iou_threshold: Minimum 2D IoU of a match.
        limit: Only the first ``limit`` samples.
        sources: Only samples of these sources (``sunrgbd``, ``kitti`` ...).
        progress: Show a progress bar (stderr).
        drop_pose: Give the mapper no camera pose for any photo (no ``gravity_cam``, no ``camera_height``):
            the camera's gravity and height then come from the photo itself (a sample without
            ``gravity_cam`` is always run so).
    """
    from tqdm import tqdm

    if models is None and not gt_boxes:
        raise BenchError("models are required unless gt_boxes is set")
    samples = load_dataset(dataset_dir, catalog)
    if sources:
        samples = _of_sources(samples, sources, dataset_dir)
    if limit is not None:
        samples = samples[: max(0, int(limit))]
    if not samples:
        raise BenchError(f"{dataset_dir}: no samples to run (check --limit / --source)")
    cfg = config or MapperConfig()
    prompts = catalog.prompts()
    shared_mapper = None if gt_boxes else Mapper(models, catalog, cfg)
    vocab = set(c for _, c in prompts) if gt_boxes else set(models.detector.vocabulary(prompts))
    records: list[dict[str, Any]] = []
    excluded: dict[str, int] = {}
    model_names: dict[str, str] = {}
    try:
        for sample in tqdm(samples, desc="bench", unit="img", disable=not progress):
            loaded = read_image(sample.image_path, min_side=8)  # upright: EXIF orientation applied, said when present
            if loaded.note:
                tqdm.write(loaded.note)
            for warning in loaded.warnings:
                tqdm.write(f"warning: {warning}")
            image = loaded.image
            mapper = shared_mapper
            if gt_boxes:
                known = [o for o in sample.objects if o.cls is not None]
                bundle = GroundTruthBundle(
                    GroundTruthDetector([o.box for o in known], [o.cls for o in known],  # type: ignore[misc]
                                        name="ground-truth perception (dataset 2D boxes)"),
                    getattr(models, "segmenter", None) if models is not None else None,
                    getattr(models, "depth", None) if models is not None else None,  # type: ignore[arg-type]
                )
                mapper = Mapper(bundle, catalog, cfg)
            assert mapper is not None
            pose_given = not drop_pose and sample.pose_given
            result = mapper.run(image, sample.intrinsics, sample.mount if pose_given else mount_from_gravity(None),
                                Pose(), prompts=prompts, capture_id=sample.id, image_name=sample.image_path.name,
                                pose_given=pose_given)
            model_names = dict(result.scene.captures[0].models)
            for o in sample.objects:
                if o.cls is None:
                    excluded[o.label] = excluded.get(o.label, 0) + 1
            records.append({**_score_sample(sample, result, vocab, iou_threshold), "pose_given": pose_given,
                            "camera_pose": result.scene.captures[0].models.get("camera_pose"),
                            "camera_pose_warning": result.scene.captures[0].models.get("camera_pose_warning")})
            if gt_boxes:
                mapper.close()
    finally:
        if shared_mapper is not None:
            shared_mapper.close()
    if getattr(models, "note", ""):  # e.g. the set's second detector is not fetched
        model_names["note"] = str(models.note)  # type: ignore[union-attr]
    summary = summarise(records, excluded)
    return BenchReport(str(dataset_dir), "gt-boxes" if gt_boxes else "detector", model_names, summary, records)


def _of_sources(samples: Sequence[BenchSample], sources: Sequence[str], dataset_dir: str | Path) -> list[BenchSample]:
    """The samples of ``sources``, matched ignoring case; a source without samples is a BenchError listing them."""
    present = sorted({s.source for s in samples})
    missing = [x for x in sources if x.strip().lower() not in {p.lower() for p in present}]
    if missing:
        raise BenchError(f"--source {', '.join(missing)}: no such source in {dataset_dir} (its sources: "
                         f"{', '.join(present) or 'none'}; matched ignoring case)")
    return [s for s in samples if s.source.lower() in {x.strip().lower() for x in sources}]


def _score_sample(sample: BenchSample, result: MapResult, vocab: set[str], iou_threshold: float) -> dict[str, Any]:
    gts = [o for o in sample.objects if o.cls is not None]
    placed = [o for o in result.objects if o.center_cam is not None]
    det_boxes = np.array([o.detection.box for o in placed]).reshape(-1, 4)
    gt_boxes = np.array([o.box for o in gts]).reshape(-1, 4)
    pairs = match_greedy(det_boxes, [o.detection.label for o in placed], gt_boxes, [o.cls for o in gts], iou_threshold)
    matches = []
    for i, j, iou in pairs:
        est, gt = placed[i], gts[j]
        err = float(np.linalg.norm(est.center_cam - gt.center_cam))  # type: ignore[operator]
        dist = float(np.linalg.norm(gt.center_cam))
        gz = float(gt.center_cam[2])
        cues = {c.name: {"distance": round(c.distance, 3), "sigma": round(c.sigma, 4),
                         "error_m": round(abs(c.distance - gz), 4), "error_rel": round(abs(c.distance - gz) / gz, 4)}
                for c in est.cues}
        matches.append({
            "label": gt.cls, "iou": round(iou, 3), "score": round(est.detection.score, 3),
            "method": est.fused.method if est.fused else None,
            "cut": list(est.cut_sides),
            "cues": cues,
            "rejected": [n for n, _ in est.fusion.rejected] if est.fusion else [],
            "size_prior_doubt": next((c.note.split("; ", 1)[1] for c in est.cues
                                      if c.name == "size_prior" and "down-weighted" in c.note), None),
            "contact_hidden_by": est.contact_hidden_by,  # set: the ground contact was only an upper bound
            "height": None if est.height is None else {"how": est.height.how, "m": round(est.height.height, 3)},
            "sigma_z": None if est.sigma_z is None else round(est.sigma_z, 4),
            "error_z": round(abs(float(est.center_cam[2]) - gz), 4),  # type: ignore[index]
            "gt_center": [round(float(v), 3) for v in gt.center_cam],
            "est_center": [round(float(v), 3) for v in est.center_cam],  # type: ignore[union-attr]
            "distances": {"geometric": est.geometric_z, "depth": est.depth_z,
                          "fused": est.fused.distance if est.fused else None},
            "error_m": round(err, 4), "gt_distance_m": round(dist, 3), "error_rel": round(err / dist, 4),
        })
    matched_gt = {j for _, j, _ in pairs}
    matched_det = {i for i, _, _ in pairs}
    unmatched = [
        {"label": o.detection.label, "score": round(o.detection.score, 3),
         "box": [round(v, 1) for v in o.detection.box],
         "best_iou_same_class": round(float(max((box_iou(np.array([o.detection.box]), np.array([g.box]))[0, 0]
                                                 for g in gts if g.cls == o.detection.label), default=0.0)), 3)}
        for i, o in enumerate(placed) if i not in matched_det
    ]
    return {
        "id": sample.id,
        "source": sample.source,
        "size": [sample.intrinsics.width, sample.intrinsics.height],
        "partial_annotation": sample.partial_annotation,
        "n_gt": len(gts),
        "n_gt_vocab": sum(1 for o in gts if o.cls in vocab),
        "n_matched": len(pairs),
        "n_matched_vocab": sum(1 for j in matched_gt if gts[j].cls in vocab),
        "missed": [gts[j].cls for j in range(len(gts)) if j not in matched_gt],
        "n_detections": len(result.objects),
        "n_placed": len(placed),
        "n_unmatched_detections": len(placed) - len(pairs),
        "n_unplaced": sum(1 for o in result.objects if o.center_cam is None),
        "unmatched_detections": unmatched,
        "depth_scale": result.scene.captures[0].models.get("depth_scale"),
        "timings": {k: round(v, 4) for k, v in result.timings.items()},
        "matches": matches,
    }


