"""The mapper's settings, input checks and model loading (used by :mod:`pipeline.mapper`).

:class:`MapperConfig` holds every setting of the mapping pipeline; :func:`as_rgb8` and
:func:`prompts_from_words` check its inputs; :func:`load_mapping_models` loads a model set's bundle
with its labels mapped to catalog classes.
"""

from __future__ import annotations

import math
import os
import re
from dataclasses import dataclass
from typing import Any, Literal, Protocol, Sequence

import numpy as np

from pipeline.catalog import Catalog
from pipeline.camera.geometry import Pose
from pipeline.models.base import Detector, Prompt

MAX_IMAGE_SIDE = 8000
"""Largest accepted image side [px]."""

MIN_DEPTH_SIGMA = 0.05
"""Smallest relative error credited to a depth map in adaptive fusion (the best monocular models'
AbsRel is about 5 %)."""


class MapperError(ValueError):
    """Bad input to the mapper (image, intrinsics, prompts, configuration)."""


class ModelBundleLike(Protocol):
    """The three backends the mapper uses (``pipeline.models.registry`` bundles fit this)."""

    detector: Detector
    segmenter: Segmenter | None
    depth: Any  # DepthEstimator | None


@dataclass(frozen=True)
class MapperConfig:
    """Mapper settings.

    Attributes:
        w_geometric: Weight of the size-prior distance in the fusion (the paper's 0.8).
        w_depth: Weight of the depth-map distance (the paper's 0.2).
        placement: ``box_fit`` (3D box fitted to the 2D box under gravity) or ``ray`` (the paper's
            ``f * h / h_px`` on the box-centre ray); see :mod:`pipeline.ranging.placement`.
        truncation_margin_px: A box side within this many pixels of the border is cut [px].
        handle_truncation: Use only box dimensions the image border does not cut (``False``: the
            paper's plain ``f * h / h_px`` whatever the border does).
        segment: ``auto`` (default): segment only detections whose distance depends on the mask
            (unknown size, or both box dimensions cut by the border) or whose yaw is fitted to the
            mask's depth points (see :mod:`pipeline.segment_policy`), skipping the encoder when none
            does: a known-size object's distance comes from its box, and the median depth over the middle of the box is
            nearly as good as over the mask (dev set, dataset boxes: median error 10.0 % against
            9.4 %); on the dev set ``auto`` and ``all`` give the same median error, with and without
            dataset boxes, at 1/50 of the time (README, "Mapping speed"). ``all``: segment every
            detection (one encoder run, one decoder run per box; the default until then). ``none``:
            the box stands in for every mask.
        segment_min_score: Only detections at least this confident are segmented.
        max_objects: At most this many detections (best first) are mapped.
        fit_depth: Fit the depth map's scale (and shift for inverse depth) from the objects of known
            size. Relative depth needs it to become metric.
        refit_metric_min_refs: A ``metric`` depth map is rescaled only with at least this many
            reference objects (a metric model's scale is off outside its training domain).
        size_sigma: Relative spread of real sizes around the catalog's ``(w, h, l)`` (box fit).
        horizontal_sigma_scale: How much less the 2D box's left/right edges are trusted than its
            top/bottom (box fit): a box's width depends on the unknown yaw and on non-box shapes.
        parallel: Run detection, depth and (``segment="all"``) the segmenter's encoder concurrently
            (threads). Off by default: on 2 cores it bought no consistent gain
            (``bench/pipeline_speed.py`` on the loaded machine: 0.94x and 1.13x the sequential run
            with ``auto`` in two runs, 0.96x and 0.98x with ``all``); kept for that benchmark.
        detect_tile_factor: For a detector with a fixed input size (``input_size``, e.g. YOLOX's
            416 px), photos whose longer side exceeds 1.25 tiles are also detected on overlapping
            tiles of ``detect_tile_factor`` times that size (small far objects, see
            :mod:`pipeline.models.tiled_detection`); ``None``: the whole image only. 1.5 (624 px tiles for
            YOLOX-Nano) was the best measured trade-off on the dev set: tiles of 1.0 / 0.75 input
            sizes (more, upscaled tiles) found no more objects for 2-3x the time and more false
            detections, and horizontal-flip test-time augmentation none more for twice the time.
            Each member of a merged detector is tiled to its own input size (its own ``tile_factor``
            attribute wins), and a detector that stretches its input also runs on square windows
            (:func:`pipeline.models.tiled_detection.detect_planned`).
        same_object_iou: Detections of different classes whose boxes overlap more than this (IoU) are
            taken for one object seen twice (a closed-vocabulary detector calls a bed "bed" and
            "sofa"): only the more confident stays. ``None``: keep both (class-aware NMS only).
        fusion: ``sigma`` (default): every cue (size prior, ground contact, depth) gives a distance and
            a sigma, fused by inverse variance with outlier rejection (:mod:`pipeline.ranging.ranger`,
            :mod:`pipeline.ranging.fusion`). ``fixed``: the weights above (the paper). ``adaptive``: with at least three
            reference objects, inverse-variance weights from the size prior's spread
            (``geometric_sigma``) and the depth map's measured disagreement with the references
            (:func:`~pipeline.ranging.distance.depth_fit_spread`, minus the size-prior part); with fewer,
            the weights above. Adaptive fusion also drops a depth reading that disagrees with the
            size prior by more than ``gate_sigmas`` combined standard errors (log ratio).
        geometric_sigma: Relative error of a size-prior distance (the spread of real sizes).
        gate_sigmas: See ``fusion``.
        trust_depth_spread: Adaptive fusion: a metric depth map whose spread against the size priors
            (:func:`~pipeline.ranging.distance.depth_fit_spread`) is at most this is trusted over a size prior
            that puts an object beyond the gate *farther* than the map (a box cut short by the border
            or an occluder; renders' exact depth: up to ~0.3 from occluded references; FastDepth on KITTI: larger).
        exact_depth: The depth map is exact metric depth (ground-truth perception of a simulator's
            render): it is never rescaled from the size priors, and where it has a reading it decides
            the distance (the size prior is used only where it has none).
        yaw_from_fit: Give objects the yaw of the fitted 3D box instead of facing the camera. Off by
            default: a 2D box hardly constrains the yaw (a yaw and its mirror image about the viewing
            ray give the same box; on noise-free renders the fitted yaw of near-square footprints
            was off by up to ~50 degrees). :attr:`yaw_from_depth` takes precedence where it applies.
        yaw_from_depth: Give known-size objects the yaw of the footprint fitted to their mask's pixels
            back-projected with the metric depth (:func:`~pipeline.ranging.orientation.length_axis_from_points`;
            facing the camera where the points do not determine it). ``None`` (default): only when the
            depth is trustworthy metric depth: exact (``exact_depth`` or a backend declaring it), or a
            metric map that adaptive fusion trusts (spread against the size priors within
            ``trust_depth_spread``). ``True``: whenever the depth map has a metric scale; ``False``: never.
        ground_contact: ``sigma`` fusion: range floor-standing objects (catalog ``on_floor``) from where
            their box bottom meets the floor, when the camera height is known (camera above world
            z = 0 by more than 5 cm); see :mod:`pipeline.ranging.ground_contact`.
        measure_height: ``sigma`` fusion with a known floor: a floor-standing object of known class gets
            the height its box's top edge shows at its fused distance (fused with the catalog's; at
            least the visible height when the border cuts the top), its bottom staying on the floor;
            see :mod:`pipeline.ranging.measured_height`.
        sigma_pitch: 1-sigma of the camera's pitch knowledge [rad] (ground contact) when the pose is given:
            0.015 rad (0.86 deg), the one constant chosen on the dev set (0.01 / 0.015 / 0.02 tried: 0.015
            gave the lowest detector median, 8.3 % against 9.0 / 8.9 %, and the same dataset-box median):
            a vehicle's or robot's nominal camera pitch against the road or floor ahead.
        sigma_camera_height: 1-sigma of the camera height [m] (ground contact).
        sigma_floor: 1-sigma of the floor under an object differing from the plane [m] (ground contact).
        depth_sigma: ``sigma`` fusion: relative 1-sigma of a depth map that could not be checked
            against at least three objects' other cues on the photo.
        floor_fit: ``sigma`` fusion with ground contact: fit the floor from the photo (object contacts, a
            trusted depth map's plane; :mod:`pipeline.ranging.photo_floor`): with the pose given, a check
            that warns and widens the ground-contact sigma on disagreement; without it, the camera's
            gravity and height.
    """

    w_geometric: float = 0.8
    w_depth: float = 0.2
    placement: Literal["box_fit", "ray"] = "box_fit"
    truncation_margin_px: float = 3.0
    handle_truncation: bool = True
    segment: Literal["all", "auto", "none"] = "auto"
    segment_min_score: float = 0.0
    max_objects: int = 100
    fit_depth: bool = True
    refit_metric_min_refs: int = 2
    size_sigma: tuple[float, float, float] = (0.1, 0.1, 0.1)
    horizontal_sigma_scale: float = 4.0
    parallel: bool = False
    detect_tile_factor: float | None = 1.5
    same_object_iou: float | None = 0.8
    fusion: Literal["fixed", "adaptive", "sigma"] = "sigma"
    geometric_sigma: float = 0.1
    gate_sigmas: float = 3.0
    yaw_from_fit: bool = False
    trust_depth_spread: float = 0.3
    exact_depth: bool = False
    yaw_from_depth: bool | None = None
    ground_contact: bool = True
    measure_height: bool = True
    sigma_pitch: float = 0.015
    sigma_camera_height: float = 0.03
    sigma_floor: float = 0.05
    depth_sigma: float = 0.3
    floor_fit: bool = True

    def __post_init__(self) -> None:
        if self.w_geometric < 0 or self.w_depth < 0 or self.w_geometric + self.w_depth <= 0:
            raise MapperError(f"fusion weights must be >= 0 and not both 0, got {self.w_geometric}, {self.w_depth}")
        if self.segment not in ("all", "auto", "none"):
            raise MapperError(f"segment must be 'all', 'auto' or 'none', got {self.segment!r}")
        if self.placement not in ("box_fit", "ray"):
            raise MapperError(f"placement must be 'box_fit' or 'ray', got {self.placement!r}")
        if self.max_objects < 1:
            raise MapperError(f"max_objects must be >= 1, got {self.max_objects}")
        if self.truncation_margin_px < 0:
            raise MapperError(f"truncation_margin_px must be >= 0, got {self.truncation_margin_px}")
        if self.fusion not in ("fixed", "adaptive", "sigma"):
            raise MapperError(f"fusion must be 'sigma', 'fixed' or 'adaptive', got {self.fusion!r}")
        for key in ("sigma_pitch", "sigma_camera_height", "sigma_floor"):
            v = getattr(self, key)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v >= 0):
                raise MapperError(f"{key}: must be a finite number >= 0, got {v!r}")
        if not (isinstance(self.depth_sigma, (int, float)) and math.isfinite(self.depth_sigma) and self.depth_sigma > 0):
            raise MapperError(f"depth_sigma: must be a finite number > 0, got {self.depth_sigma!r}")
        if not self.geometric_sigma > 0:
            raise MapperError(f"geometric_sigma must be > 0, got {self.geometric_sigma}")
        if self.detect_tile_factor is not None and not self.detect_tile_factor >= 1.0:
            raise MapperError(f"detect_tile_factor must be >= 1 or None, got {self.detect_tile_factor}")



def prompts_from_words(catalog: Catalog, words: Sequence[str] | None) -> list[Prompt]:
    """``(prompt text, class name)`` pairs: the catalog's prompts for ``None``; else each word, its
    class being the catalog class it resolves to, or the word itself in snake_case (unknown size).

    Raises:
        MapperError: ``words`` is empty or holds an empty word.
    """
    if words is None:
        return list(catalog.prompts())
    if isinstance(words, str):
        words = [words]
    words = list(words)
    if not words:
        raise MapperError("the prompt list is empty: give at least one word, or no --prompts for the catalog's")
    out: list[Prompt] = []
    for i, w in enumerate(words):
        if not isinstance(w, str) or not w.strip():
            raise MapperError(f"prompt {i + 1} is empty: every prompt must name something, got {w!r}")
        text = w.strip()
        entry = catalog.lookup(text)
        cls = entry.name if entry is not None else (re.sub(r"[^a-z0-9]+", "_", text.lower()).strip("_") or text)
        out.append((text, cls))
    return out


def as_rgb8(image: object) -> np.ndarray:
    """``image`` as uint8 HxWx3 RGB; grayscale (HxW, HxWx1) is repeated, an alpha channel dropped.

    Raises:
        MapperError: Not an array, empty, 16-bit or float, wrong channel count, or a side > 8000 px.
    """
    if not isinstance(image, np.ndarray):
        raise MapperError(f"image must be a numpy array (HxWx3 uint8 RGB), got {type(image).__name__}")
    if image.size == 0:
        raise MapperError(f"image is empty (shape {image.shape})")
    if image.dtype != np.uint8:
        raise MapperError(
            f"image has dtype {image.dtype}; the mapper takes 8-bit images (load files with pipeline.camera.image_io, "
            "which converts 16-bit ones)"
        )
    if image.ndim == 2:
        image = image[:, :, None]
    if image.ndim != 3 or image.shape[2] not in (1, 3, 4):
        raise MapperError(f"image must be HxW, HxWx1, HxWx3 or HxWx4, got shape {image.shape}")
    h, w = image.shape[:2]
    if max(h, w) > MAX_IMAGE_SIDE:
        raise MapperError(f"image is {w}x{h} px; the mapper accepts at most {MAX_IMAGE_SIDE} px a side (resize it "
                          "and scale the intrinsics with Intrinsics.scaled)")
    if min(h, w) < 8:
        raise MapperError(f"image is {w}x{h} px; too small to map")
    if image.shape[2] == 1:
        image = np.repeat(image, 3, axis=2)
    elif image.shape[2] == 4:
        image = image[:, :, :3]
    return np.ascontiguousarray(image)


def gravity_in_camera(world_from_camera: Pose) -> np.ndarray:
    """Unit gravity (world ``-z``) in the camera frame."""
    return world_from_camera.rotation.inv().apply([0.0, 0.0, -1.0])


LIGHT_MODELS = frozenset({"yolox_nano", "fastdepth"})
"""Models that take tens of milliseconds: one thread each leaves the cores to the segmenter's encoder."""


SECOND_DETECTORS = ("oidv4_ssd",)
"""Detectors that can run beside a set's own (``--models offline+oidv4_ssd``), merged class-aware."""


def _with_second_detector(det: Any, name: str, model_dir: str | os.PathLike[str] | None, catalog: Catalog,
                          set_name: str = "offline") -> Any:
    """``det`` merged with the second detector ``name`` (:class:`pipeline.models.ssd.MergedDetector`).

    The second detector is a registry model found like every other (``--model-dir``, else
    ``$MORPHONAVI_MODELS`` / the user cache, then ``../shared/models``); missing, the error names
    ``morphonavi models fetch NAME``; present but broken (does not load), it names the re-fetch and
    ``--models SET-NAME`` (``set_name``: run without it)."""
    from pipeline.models.base import ModelError, ModelMissingError
    from pipeline.models.loader import load_model
    from pipeline.models.ssd import MergedDetector

    if name not in SECOND_DETECTORS:
        raise MapperError(f"--models ...+{name}: unknown second detector (known: {', '.join(SECOND_DETECTORS)})")
    try:
        second = load_model(name, model_dir, threads=1)
    except ModelMissingError:
        raise
    except ModelError as exc:
        raise ModelError(f"second detector {name!r}: {exc}; re-fetch it with: morphonavi models fetch {name} "
                         f"(check with: morphonavi models verify {name}), or run without it: "
                         f"--models {set_name}-{name}") from None
    second.label_map = {l: e.name for l in second.labels[1:] if (e := catalog.lookup(l)) is not None}
    return MergedDetector(det, second)


SECOND_OWNS: dict[str, frozenset[str]] = {"oidv4_ssd": frozenset({"table"})}
"""Classes both detectors know that the class-aware merge takes from the second one: Open Images'
``Table`` is any table, COCO's ``dining table`` one kind (dev set: the SSD finds the ScanNet table at
0.66, YOLOX-Nano neither table even at 0.1). Its classes COCO lacks (desk, cardboard_box) always come
from it; every other shared class (person, car, chair, ...) from the set's own detector."""

AUTO_SECOND: dict[str, str] = {"offline": "oidv4_ssd"}
"""Second detector added to a set when its files are present (``--models offline`` = YOLOX-Nano and,
when fetched, the Open Images SSD, merged class-aware); ``SET-NAME`` leaves it out."""


def load_mapping_models(
    set_name: str, model_dir: str | os.PathLike[str] | None, catalog: Catalog, threads: int | None = None
) -> Any:
    """The model set's bundle for the mapper.

    ``set_name`` is a set of :data:`pipeline.models.registry.MODEL_SETS`, optionally with a second
    detector: ``offline+oidv4_ssd`` (required: missing files are an error) merges it class-aware
    (:class:`pipeline.models.ssd.MergedDetector`, ``second_owns`` from :data:`SECOND_OWNS`),
    ``offline+oidv4_ssd:union`` merges every class of both (the first merge, kept for comparison),
    ``offline-oidv4_ssd`` leaves it out. A plain set adds its :data:`AUTO_SECOND` detector when the
    files are present; when they are not, the bundle's ``note`` says so (the bench prints it).

    A closed-vocabulary detector's labels are mapped to catalog classes (``tvmonitor`` -> ``monitor``,
    ``diningtable`` -> ``table``; labels without a class are ignored). Threads: the mapper runs the
    detector and the depth model concurrently with the segmenter's encoder, so by default the light
    ones (:data:`LIGHT_MODELS`, tens of milliseconds) get one onnxruntime thread and the rest every
    core (``threads`` forces one count for all).
    """
    from pipeline.models.loader import ModelBundle, load_model, present_set_members
    from pipeline.models.registry import locate
    from pipeline.models.ssd import MergedDetector

    note = ""
    forms = "offline, offline-oidv4_ssd, offline+oidv4_ssd, offline+oidv4_ssd:union, default, cloud"
    if "+" in set_name and "-" in set_name.partition("+")[0]:
        raise MapperError(f"--models {set_name}: leaves a second detector out ('-') and adds one ('+') at once; "
                          f"give one of: {forms}")
    if set_name.count("+") > 1:
        raise MapperError(f"--models {set_name}: at most one second detector ('SET+NAME'); give one of: {forms}")
    if "+" in set_name:
        whole = set_name
        set_name, _, extra = set_name.partition("+")
        extra, _, policy = extra.partition(":")
        if not extra:
            raise MapperError(f"--models {whole}: no second detector named after '+' "
                              f"(known: {', '.join(SECOND_DETECTORS)}); give one of: {forms}")
        if policy not in ("", "union"):
            raise MapperError(f"--models ...+{extra}:{policy}: unknown merge (known: {extra}, {extra}:union)")
    elif "-" in set_name:
        set_name, _, left_out = set_name.partition("-")
        if not left_out:
            raise MapperError(f"--models {set_name}-: no detector named after '-'; give one of: {forms}")
        if left_out != AUTO_SECOND.get(set_name):
            raise MapperError(f"--models {set_name}-{left_out}: the set {set_name!r} adds no {left_out!r} "
                              f"(it adds: {AUTO_SECOND.get(set_name) or 'nothing'})")
        extra, policy = "", ""
    else:
        extra, policy = AUTO_SECOND.get(set_name, ""), ""
        if extra and locate(extra, model_dir) is None:
            note = (f"second detector {extra!r} not fetched: {set_name} runs without it "
                    f"(morphonavi models fetch {extra})")
            extra = ""
    names = present_set_members(set_name, model_dir)
    det_name, seg_name, depth_name = names

    def n_threads(name: str) -> int | None:
        return threads if threads is not None else (1 if name in LIGHT_MODELS else None)

    det = load_model(det_name, model_dir, threads=n_threads(det_name))
    labels = getattr(det, "labels", None)
    if labels is not None and hasattr(det, "label_map"):
        mapping = {}
        for label in labels:
            entry = catalog.lookup(label)
            if entry is not None:
                mapping[label] = entry.name
        det.label_map = mapping
    if extra:
        merged = _with_second_detector(det, extra, model_dir, catalog, set_name)
        if policy != "union":
            merged = MergedDetector(*merged.members, policy="class_aware", second_owns=SECOND_OWNS.get(extra, ()))
        det = merged
    bundle = ModelBundle(
        detector=det,
        segmenter=load_model(seg_name, model_dir, threads=threads),
        depth=load_model(depth_name, model_dir, threads=n_threads(depth_name)),
        names=names,
    )
    bundle.note = note  # type: ignore[attr-defined]
    return bundle
