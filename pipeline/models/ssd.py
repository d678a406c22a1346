"""SSD MobileNetV2 detector with the Open Images (OIDv4) 23-class head (MediaPipe Objectron stage 1), and
a detector that merges two closed-vocabulary detectors.

The model (``oidv4_ssd/oidv4_ssd.onnx``, see ``../shared/models/README.md``): input
``normalized_input_image_tensor`` float32 ``[1, 3, 300, 300]``, the whole RGB image *stretched* to
300 x 300 (bilinear, no letterbox), ``x / 127.5 - 1``; outputs ``boxes`` ``[1, 1917, 4]`` (x0, y0, x1,
y1 normalised to the original image) and ``scores`` ``[1, 1917, 24]`` (sigmoid; column 0 is the
background). Per class: scores above the threshold, class-wise NMS (IoU 0.45).

Its vocabulary (Desk, Box, Table, Computer monitor, Laptop, Mug, ...) complements COCO's: the
:class:`MergedDetector` runs both and merges their detections, either every class of both
(``policy="union"``) or class-aware (``policy="class_aware"``: each class from the member that owns
it, see :meth:`MergedDetector.roles`).
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Iterable, Literal, Mapping, Sequence

import cv2
import numpy as np

from pipeline.models.base import Detection, ModelError, Prompt, check_image, closed_vocabulary
from pipeline.models.nms import batched_nms, box_iou
from pipeline.models.session import IOSignature, TensorSpec, open_session, run
from pipeline.models.yolox import read_labels

INPUT = "normalized_input_image_tensor"
SIGNATURE = IOSignature(
    inputs=(TensorSpec(INPUT, 4, (1, 3, 300, 300)),),
    outputs=(TensorSpec("boxes", 3, (1, None, 4)), TensorSpec("scores", 3, (1, None, None))),
)
DEFAULT_SCORE_THRESHOLD = 0.3
"""Minimum class score (the threshold the model's README used; its best indoor scores are ~0.66)."""
SAME_OBJECT_LABELS: tuple[frozenset[str], ...] = (frozenset({"Desk", "Table"}),)
"""Labels of one object at two levels of the Open Images class hierarchy (a Desk is a Table): the model
scores both on the same object (Table 0.66 and Desk 0.53 on the ScanNet table, IoU 0.91), so their
overlapping boxes are one object (:func:`suppress_same_object`). Labels mapped to one catalog class
(Mug, Coffee cup) are already merged by the class-aware NMS."""


def suppress_same_object(dets: Sequence[Detection], groups: Sequence[frozenset[str]],
                         iou: float) -> list[Detection]:
    """``dets`` without the boxes whose backend label (``prompt``) shares a group of ``groups`` with a
    more confident box overlapping it by more than ``iou``; order kept."""
    if not groups or len(dets) < 2:
        return list(dets)
    boxes = np.array([d.box for d in dets], dtype=np.float64)
    overlap = box_iou(boxes, boxes)
    dropped = [False] * len(dets)
    for a in sorted(range(len(dets)), key=lambda i: -dets[i].score):
        if dropped[a]:
            continue
        for b in range(len(dets)):
            if (b != a and not dropped[b] and dets[b].label != dets[a].label and overlap[a, b] > iou
                    and any(dets[a].prompt in g and dets[b].prompt in g for g in groups)):
                dropped[b] = True
    return [d for d, gone in zip(dets, dropped) if not gone]


def preprocess(image_rgb: np.ndarray, size: tuple[int, int] = (300, 300)) -> np.ndarray:
    """``[1, 3, H, W]`` float32: the whole image stretched to ``size`` (h, w), scaled to -1..1."""
    x = cv2.resize(image_rgb, (size[1], size[0]), interpolation=cv2.INTER_LINEAR).astype(np.float32) / 127.5 - 1.0
    return np.ascontiguousarray(x.transpose(2, 0, 1)[None])


class SsdDetector:
    """Closed-vocabulary SSD (OIDv4 labels).

    Args:
        model_path: The ``.onnx`` file (decoded boxes and scores).
        labels: Label of each score column, column 0 the background.
        label_map: Backend label -> class name; labels not in it are ignored. ``None``: identity.
        score_threshold: Minimum class score.
        nms_iou: IoU above which a lower-scoring box of the same class is dropped.
        threads: onnxruntime intra-op threads.
        tile_factor: Tiles of this many input sizes besides the whole image and its square windows
            (:func:`pipeline.models.tiled_detection.detect_planned`); ``None`` (default): none. On the dev set,
            merged class-aware, 450 / 300 px tiles (1.5 / 1.0) found no object that the whole image
            and its windows missed, for 15 / 4 more unmatched detections
            (``bench/detector_variants.py``; README, "Second detector").

    Attributes:
        input_size: ``(300, 300)``, the model's input (h, w) [px].
        stretches_input: ``True``: the whole image is stretched to the input (no letterbox), so
            tiled detection also runs it on square windows (aspect ratio kept).
    """

    stretches_input = True
    same_object_labels = SAME_OBJECT_LABELS

    def __init__(self, model_path: Path | str, labels: Sequence[str], label_map: Mapping[str, str] | None = None, *,
                 score_threshold: float = DEFAULT_SCORE_THRESHOLD, nms_iou: float = 0.45,
                 threads: int | None = None, name: str = "oidv4_ssd", tile_factor: float | None = None) -> None:
        if tile_factor is not None and not (isinstance(tile_factor, (int, float)) and tile_factor >= 0.5):
            raise ModelError(f"model {name!r}: tile_factor must be >= 0.5 or None, got {tile_factor!r}")
        self.tile_factor = tile_factor
        self.input_size: tuple[int, int] = (300, 300)
        self.name = name
        self.score_threshold = float(score_threshold)
        self.nms_iou = float(nms_iou)
        self.labels = list(labels)
        self.label_map: dict[str, str] = dict(label_map) if label_map is not None else {l: l for l in self.labels[1:]}
        self.session = open_session(model_path, SIGNATURE, threads=threads, model_name=name)
        cols = self.session.get_outputs()[1].shape[2]
        if isinstance(cols, int) and cols != len(self.labels):
            raise ModelError(f"model {name!r}: scores have {cols} columns but {len(self.labels)} labels were given")
        self.last_timings: dict[str, float] = {}

    @classmethod
    def from_dir(cls, model_dir: Path | str, label_map: Mapping[str, str] | None = None, **kwargs: object) -> SsdDetector:
        """Load ``oidv4_ssd.onnx`` and ``labelmap.txt`` from ``model_dir``."""
        model_dir = Path(model_dir)
        labels = read_labels(model_dir / "labelmap.txt", str(kwargs.get("name", "oidv4_ssd")))
        return cls(model_dir / "oidv4_ssd.onnx", labels, label_map, **kwargs)  # type: ignore[arg-type]

    def vocabulary(self, prompts: Sequence[Prompt]) -> frozenset[str]:
        """Class names of ``prompts`` that some backend label maps to."""
        return closed_vocabulary(prompts, self.label_map, self.name)

    def detect(self, image_rgb: np.ndarray, prompts: Sequence[Prompt]) -> list[Detection]:
        """Detections of the prompts' classes, best first."""
        image = check_image(image_rgb, self.name)
        wanted = self.vocabulary(prompts)
        columns = [i for i, l in enumerate(self.labels) if i > 0 and self.label_map.get(l) in wanted]
        if not columns:
            self.last_timings = {"detect": 0.0}
            return []
        t0 = time.perf_counter()
        h, w = image.shape[:2]
        boxes, scores = run(self.session, ["boxes", "scores"], {INPUT: preprocess(image)}, f"model {self.name!r}")
        boxes = np.asarray(boxes, dtype=np.float64)[0] * np.array([w, h, w, h])
        boxes[:, [0, 2]] = np.clip(boxes[:, [0, 2]], 0, w)
        boxes[:, [1, 3]] = np.clip(boxes[:, [1, 3]], 0, h)
        scores = np.asarray(scores, dtype=np.float64)[0]
        out_b, out_s, out_l = [], [], []
        for c in columns:  # one box may be kept for several classes (a desk is also a table), as MediaPipe does
            keep = scores[:, c] > self.score_threshold
            if keep.any():
                out_b.append(boxes[keep])
                out_s.append(scores[keep, c])
                out_l += [self.labels[c]] * int(keep.sum())
        if not out_b:
            self.last_timings = {"detect": time.perf_counter() - t0}
            return []
        b, s = np.concatenate(out_b), np.concatenate(out_s)
        classes = [self.label_map[l] for l in out_l]
        order = batched_nms(b, s, classes, self.nms_iou)
        self.last_timings = {"detect": time.perf_counter() - t0}
        found = [Detection(tuple(b[i].tolist()), float(s[i]), classes[i], out_l[i])  # type: ignore[arg-type]
                 for i in order if b[i, 2] > b[i, 0] and b[i, 3] > b[i, 1]]
        return suppress_same_object(found, self.same_object_labels, self.nms_iou)


def _margin(score: float, threshold: float) -> float:
    """How far ``score`` is above its detector's own threshold, as a share of the way to 1: puts the
    scores of detectors with different scales on one scale for a cross-detector tie."""
    return (score - threshold) / max(1e-6, 1.0 - threshold)


class MergedDetector:
    """Two detectors run on the same image, their detections merged.

    Args:
        first: The primary detector (YOLOX-Nano: COCO-trained, the better boxes).
        second: The second detector (the Open Images SSD).
        nms_iou: Same-class boxes overlapping more than this (IoU) keep only the best.
        policy: ``union``: every class of both members, class-aware NMS over the union (scores
            compared as they are). ``class_aware``: each class comes from one member only
            (:meth:`roles`), and a box of one member overlapping a box of another class of the other
            member by more than ``same_object_iou`` is taken for the same object seen twice (a Desk
            and a dining table): the one further above its own detector's score threshold stays.
        second_owns: ``class_aware``: classes both members know that are taken from the second (the
            Open Images ``Table`` is any table, COCO's ``dining table`` is one kind).
        same_object_iou: See ``policy``; ``None``: cross-member boxes of different classes all stay.

    ``input_size`` is the first member's; :func:`pipeline.models.tiled_detection.detect_planned` tiles each
    member to its own. Each member's ``label_map`` stays its own (the mapper maps labels per member).
    """

    def __init__(self, first: object, second: object, nms_iou: float = 0.5, *,
                 policy: Literal["union", "class_aware"] = "union", second_owns: Iterable[str] = (),
                 same_object_iou: float | None = 0.8) -> None:
        if policy not in ("union", "class_aware"):
            raise ModelError(f"MergedDetector.policy: must be 'union' or 'class_aware', got {policy!r}")
        if same_object_iou is not None and not 0.0 < float(same_object_iou) <= 1.0:
            raise ModelError(f"MergedDetector.same_object_iou: must be in (0, 1] or None, got {same_object_iou!r}")
        self.members = (first, second)
        self.name = (f"{getattr(first, 'name', 'detector')}+{getattr(second, 'name', 'detector')} "
                     f"({'union' if policy == 'union' else 'class-aware'})")  # which merge ran, in every header
        self.score_threshold = min(float(getattr(first, "score_threshold", 0.0)),
                                   float(getattr(second, "score_threshold", 0.0)))
        self.nms_iou = float(nms_iou)
        self.policy = policy
        self.second_owns = frozenset(second_owns)
        self.same_object_iou = None if same_object_iou is None else float(same_object_iou)
        size = getattr(first, "input_size", None)
        if size is not None:
            self.input_size = size
        self.last_timings: dict[str, float] = {}

    def vocabulary(self, prompts: Sequence[Prompt]) -> frozenset[str]:
        """The union of the members' vocabularies."""
        return frozenset().union(*(m.vocabulary(prompts) for m in self.members))  # type: ignore[attr-defined]

    def roles(self, prompts: Sequence[Prompt]) -> tuple[frozenset[str], frozenset[str]]:
        """Classes of ``prompts`` taken from the first and from the second member. ``union``: each
        member's whole vocabulary. ``class_aware``: the second gives the classes the first lacks and
        those of ``second_owns``; the first gives the rest of its own."""
        v1, v2 = (frozenset(m.vocabulary(prompts)) for m in self.members)  # type: ignore[attr-defined]
        if self.policy == "union":
            return v1, v2
        from_second = (v2 - v1) | (v2 & self.second_owns)
        return v1 - from_second, from_second

    def detect(self, image_rgb: np.ndarray, prompts: Sequence[Prompt]) -> list[Detection]:
        """Both members' detections on the whole image, merged (:meth:`merge`), best first."""
        t0 = time.perf_counter()
        per_member = [m.detect(image_rgb, prompts) for m in self.members]  # type: ignore[attr-defined]
        out = self.merge(per_member, prompts)
        self.last_timings = {"detect": time.perf_counter() - t0}
        return out

    def merge(self, per_member: Sequence[Sequence[Detection]], prompts: Sequence[Prompt]) -> list[Detection]:
        """One list from each member's detections (in :attr:`members` order), best first: classes
        filtered by :meth:`roles`, class-aware NMS (``nms_iou``), then (``class_aware``) cross-member
        duplicates of different classes resolved by the score margin above each member's threshold."""
        if len(per_member) != len(self.members):
            raise ModelError(f"{self.name}: merge expects {len(self.members)} detection lists, got {len(per_member)}")
        allowed = self.roles(prompts)
        dets: list[Detection] = []
        origin: list[int] = []
        for k, found in enumerate(per_member):  # a member's hierarchy duplicates (its whole image, windows, tiles)
            groups = getattr(self.members[k], "same_object_labels", ())
            for d in suppress_same_object(found, groups, float(getattr(self.members[k], "nms_iou", self.nms_iou))):
                if d.label in allowed[k]:
                    dets.append(d)
                    origin.append(k)
        if not dets:
            return []
        order = batched_nms(np.array([d.box for d in dets], dtype=np.float64), np.array([d.score for d in dets]),
                            [d.label for d in dets], self.nms_iou)
        if self.policy == "union" or self.same_object_iou is None:
            return [dets[i] for i in order]
        thresholds = [float(getattr(m, "score_threshold", 0.0)) for m in self.members]
        margin = np.array([_margin(dets[i].score, thresholds[origin[i]]) for i in order])
        boxes = np.array([dets[i].box for i in order], dtype=np.float64)
        iou = box_iou(boxes, boxes)
        dropped = np.zeros(len(order), dtype=bool)
        for a in np.argsort(-margin, kind="stable"):
            if dropped[a]:
                continue
            for b in range(len(order)):
                if (b != a and not dropped[b] and origin[order[b]] != origin[order[a]]
                        and dets[order[b]].label != dets[order[a]].label and iou[a, b] > self.same_object_iou):
                    dropped[b] = True
        return [dets[i] for i, gone in zip(order, dropped) if not gone]


__all__ = ["DEFAULT_SCORE_THRESHOLD", "MergedDetector", "SAME_OBJECT_LABELS", "SIGNATURE", "SsdDetector",
           "preprocess", "suppress_same_object"]
