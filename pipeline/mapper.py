"""One photo in, a scene of 3D objects out: detection, segmentation, depth, distance, placement.

:class:`Mapper` runs the stages on one RGB image and returns a :class:`~pipeline.scene.Scene` whose
objects are in the world frame (z up), with their camera-frame (OpenCV: x right, y down, z forward) and
robot-frame (x forward, y left, z up) centres and the distance estimates in each object's ``source``,
and per-stage wall times [s] in the capture. It never writes files: save with
:meth:`Scene.save <pipeline.scene.Scene.save>` (atomic) once mapping succeeded.

Stages (timing keys): ``detect`` and ``depth`` run concurrently with the segmenter's image encoder
(``segment_encoder``); then one decoder run per box (``segment_decoder``); then ``distance`` (size
prior, depth-scale fitting, fusion, placement). ``total`` is the wall time. With
``MapperConfig.segment = "auto"`` the encoder runs only when a detection needs its mask (see there).
"""

from __future__ import annotations

import math
import os
import re
import time
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Any, Callable, Literal, Protocol, Sequence

import numpy as np

from pipeline.catalog import Catalog
from pipeline.distance import (
    IDENTITY_SCALE, DepthScale, FusedDistance, Truncation, depth_fit_spread, fit_depth_scale, fuse_distances,
    inverse_variance_weights, mask_median_depth, truncation,
)
from pipeline.geometry import CameraError, CameraMount, Intrinsics, Pose, camera_pose_in_world
from pipeline.models.base import DepthMap, Detection, Detector, Prompt, Segmenter
from pipeline.models.nms import nms
from pipeline.orientation import length_axis_from_points
from pipeline.placement import GeometricEstimate, centre_on_ray, geometric_estimate, heading_in_frame
from pipeline.scene import Capture, Scene, SceneObject, Source
from pipeline.tiled_detection import detect_tiled

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
            ``f * h / h_px`` on the box-centre ray); see :mod:`pipeline.placement`.
        truncation_margin_px: A box side within this many pixels of the border is cut [px].
        handle_truncation: Use only box dimensions the image border does not cut (``False``: the
            paper's plain ``f * h / h_px`` whatever the border does).
        segment: ``all``: segment every detection (one encoder run, one decoder run per box).
            ``auto``: segment only detections whose distance depends on the mask (unknown size, or
            both box dimensions cut by the border), skipping the encoder when none does: a known-size
            object's distance comes from its box, and the median depth over the middle of the box is
            nearly as good as over the mask (dev set, dataset boxes: median error 10.0 % against
            9.4 %). ``none``: the box stands in for every mask.
        segment_min_score: Only detections at least this confident are segmented.
        max_objects: At most this many detections (best first) are mapped.
        fit_depth: Fit the depth map's scale (and shift for inverse depth) from the objects of known
            size. Relative depth needs it to become metric.
        refit_metric_min_refs: A ``metric`` depth map is rescaled only with at least this many
            reference objects (a metric model's scale is off outside its training domain).
        size_sigma: Relative spread of real sizes around the catalog's ``(w, h, l)`` (box fit).
        horizontal_sigma_scale: How much less the 2D box's left/right edges are trusted than its
            top/bottom (box fit): a box's width depends on the unknown yaw and on non-box shapes.
        parallel: Run detection, depth and the segmenter's encoder concurrently (threads).
        detect_tile_factor: For a detector with a fixed input size (``input_size``, e.g. YOLOX's
            416 px), photos whose longer side exceeds 1.25 tiles are also detected on overlapping
            tiles of ``detect_tile_factor`` times that size (small far objects, see
            :mod:`pipeline.tiled_detection`); ``None``: the whole image only. 1.5 (624 px tiles for
            YOLOX-Nano) was the best measured trade-off on the dev set: tiles of 1.0 / 0.75 input
            sizes (more, upscaled tiles) found no more objects for 2-3x the time and more false
            detections, and horizontal-flip test-time augmentation none more for twice the time.
        same_object_iou: Detections of different classes whose boxes overlap more than this (IoU) are
            taken for one object seen twice (a closed-vocabulary detector calls a bed "bed" and
            "sofa"): only the more confident stays. ``None``: keep both (class-aware NMS only).
        fusion: ``fixed``: the weights above (the paper). ``adaptive``: with at least three
            reference objects, inverse-variance weights from the size prior's spread
            (``geometric_sigma``) and the depth map's measured disagreement with the references
            (:func:`~pipeline.distance.depth_fit_spread`, minus the size-prior part); with fewer,
            the weights above. Adaptive fusion also drops a depth reading that disagrees with the
            size prior by more than ``gate_sigmas`` combined standard errors (log ratio).
        geometric_sigma: Relative error of a size-prior distance (the spread of real sizes).
        gate_sigmas: See ``fusion``.
        trust_depth_spread: Adaptive fusion: a metric depth map whose spread against the size priors
            (:func:`~pipeline.distance.depth_fit_spread`) is at most this is trusted over a size prior
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
            back-projected with the metric depth (:func:`~pipeline.orientation.length_axis_from_points`;
            facing the camera where the points do not determine it). ``None`` (default): only when the
            depth is trustworthy metric depth: exact (``exact_depth`` or a backend declaring it), or a
            metric map that adaptive fusion trusts (spread against the size priors within
            ``trust_depth_spread``). ``True``: whenever the depth map has a metric scale; ``False``: never.
    """

    w_geometric: float = 0.8
    w_depth: float = 0.2
    placement: Literal["box_fit", "ray"] = "box_fit"
    truncation_margin_px: float = 3.0
    handle_truncation: bool = True
    segment: Literal["all", "auto", "none"] = "all"
    segment_min_score: float = 0.0
    max_objects: int = 100
    fit_depth: bool = True
    refit_metric_min_refs: int = 2
    size_sigma: tuple[float, float, float] = (0.1, 0.1, 0.1)
    horizontal_sigma_scale: float = 4.0
    parallel: bool = True
    detect_tile_factor: float | None = 1.5
    same_object_iou: float | None = 0.8
    fusion: Literal["fixed", "adaptive"] = "adaptive"
    geometric_sigma: float = 0.1
    gate_sigmas: float = 3.0
    yaw_from_fit: bool = False
    trust_depth_spread: float = 0.3
    exact_depth: bool = False
    yaw_from_depth: bool | None = None

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
        if self.fusion not in ("fixed", "adaptive"):
            raise MapperError(f"fusion must be 'fixed' or 'adaptive', got {self.fusion!r}")
        if not self.geometric_sigma > 0:
            raise MapperError(f"geometric_sigma must be > 0, got {self.geometric_sigma}")
        if self.detect_tile_factor is not None and not self.detect_tile_factor >= 1.0:
            raise MapperError(f"detect_tile_factor must be >= 1 or None, got {self.detect_tile_factor}")


@dataclass
class MappedObject:
    """The mapper's working record of one detection (for debugging and the benchmark).

    Distances are optical-axis depths of the object's centre [m]; ``center_cam`` in the camera frame.
    """

    detection: Detection
    mask: np.ndarray | None
    mask_area: int | None
    truncation: Truncation
    size: tuple[float, float, float]
    size_known: bool
    geometric: GeometricEstimate | None = None
    depth_value: float | None = None
    depth_z: float | None = None
    fused: FusedDistance | None = None
    center_cam: np.ndarray | None = None
    object_id: str | None = None
    skipped: str | None = None
    length_axis_cam: np.ndarray | None = None
    """Unit horizontal length axis (camera frame) fitted from the depth points, when it was."""

    @property
    def geometric_z(self) -> float | None:
        return None if self.geometric is None else float(self.geometric.center[2])


@dataclass
class MapResult:
    """Everything one mapping run produced: the scene and the intermediate results."""

    scene: Scene
    objects: list[MappedObject]
    depth: DepthMap | None
    depth_scale: DepthScale | None
    timings: dict[str, float]
    prompts: list[Prompt] = field(default_factory=list)


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
            f"image has dtype {image.dtype}; the mapper takes 8-bit images (load files with pipeline.image_io, "
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


def load_mapping_models(
    set_name: str, model_dir: str | os.PathLike[str] | None, catalog: Catalog, threads: int | None = None
) -> Any:
    """The model set's bundle for the mapper.

    A closed-vocabulary detector's labels are mapped to catalog classes (``tvmonitor`` -> ``monitor``,
    ``diningtable`` -> ``table``; labels without a class are ignored). Threads: the mapper runs the
    detector and the depth model concurrently with the segmenter's encoder, so by default the light
    ones (:data:`LIGHT_MODELS`, tens of milliseconds) get one onnxruntime thread and the rest every
    core (``threads`` forces one count for all).
    """
    from pipeline.models.loader import ModelBundle, load_model, present_set_members

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
    return ModelBundle(
        detector=det,
        segmenter=load_model(seg_name, model_dir, threads=threads),
        depth=load_model(depth_name, model_dir, threads=n_threads(depth_name)),
        names=names,
    )


class Mapper:
    """Maps one photo to a scene.

    Args:
        models: Detector, segmenter (optional) and depth estimator (optional), e.g. from
            ``pipeline.models.registry.load_models``.
        catalog: Classes, prompts and size priors.
        config: Settings; see :class:`MapperConfig`.
    """

    def __init__(self, models: ModelBundleLike, catalog: Catalog, config: MapperConfig | None = None) -> None:
        if getattr(models, "detector", None) is None:
            raise MapperError("the model bundle has no detector")
        self.models = models
        self.catalog = catalog
        self.config = config or MapperConfig()
        self._pool: ThreadPoolExecutor | None = None

    def close(self) -> None:
        """Stop the worker threads (the mapper restarts them when used again)."""
        if self._pool is not None:
            self._pool.shutdown(wait=True)
            self._pool = None

    def __enter__(self) -> "Mapper":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def map_image(
        self,
        image_rgb: np.ndarray,
        intrinsics: Intrinsics,
        mount: CameraMount | None = None,
        robot_pose: Pose | None = None,
        prompts: Sequence[str] | None = None,
        capture_id: str | None = None,
        image_name: str | None = None,
    ) -> Scene:
        """The scene (world frame) of the objects in ``image_rgb``; see :meth:`run`."""
        return self.run(image_rgb, intrinsics, mount, robot_pose, prompts, capture_id, image_name).scene

    def run(
        self,
        image_rgb: np.ndarray,
        intrinsics: Intrinsics,
        mount: CameraMount | None = None,
        robot_pose: Pose | None = None,
        prompts: Sequence[str] | Sequence[Prompt] | None = None,
        capture_id: str | None = None,
        image_name: str | None = None,
    ) -> MapResult:
        """Map one image and keep the intermediate results.

        Args:
            image_rgb: uint8 HxWx3 RGB (grayscale and RGBA are converted).
            intrinsics: The camera for this image [px]; its size must match the image.
            mount: Camera on the robot (default :class:`CameraMount`).
            robot_pose: ``world <- robot`` at capture (default: the world origin).
            prompts: Words to look for (``None``: the catalog's prompts), or ``(text, class)`` pairs.
            capture_id: Id of the capture in the scene (default from the time).
            image_name: Image file name recorded in the capture.

        Raises:
            MapperError: Bad image, intrinsics that do not match it, empty prompts, or prompts the
                detector cannot find at all.
            ModelError: A model failed.
        """
        t_start = time.perf_counter()
        cfg = self.config
        image = as_rgb8(image_rgb)
        h, w = image.shape[:2]
        if not isinstance(intrinsics, Intrinsics):
            raise MapperError(f"intrinsics must be an Intrinsics, got {type(intrinsics).__name__}")
        try:
            intrinsics.check_image(w, h)
        except CameraError as exc:
            raise MapperError(str(exc)) from None
        mount = mount or CameraMount()
        robot_pose = robot_pose or Pose()
        pairs = self._prompts(prompts)
        detector = self.models.detector
        if not detector.vocabulary(pairs):
            classes = sorted({c for _, c in pairs})
            raise MapperError(
                f"detector {detector.name!r} cannot find any of the prompted classes ({', '.join(classes[:12])}"
                f"{', ...' if len(classes) > 12 else ''}); use an open-vocabulary model set or other words"
            )
        world_from_cam = camera_pose_in_world(robot_pose, mount)
        gravity = gravity_in_camera(world_from_cam)
        timings: dict[str, float] = {}

        # --- detection, depth and the image encoder, concurrently ---------------------------------
        segmenter = getattr(self.models, "segmenter", None) if cfg.segment != "none" else None
        depth_model = getattr(self.models, "depth", None)
        early = segmenter is not None and cfg.segment == "all"
        enc_future = self._submit(segmenter.set_image, image, timings, "segment_encoder") if early else None
        depth_future = self._submit(depth_model.estimate, image, timings, "depth") if depth_model else None
        tile_px = self._tile_px()
        if tile_px is None:
            detections = _timed(detector.detect, timings, "detect")(image, pairs)
        else:
            detections = _timed(detect_tiled, timings, "detect")(detector, image, pairs, tile_px)
        depth_map: DepthMap | None = depth_future.result() if depth_future else None
        if enc_future is not None:
            enc_future.result()
        detections = sorted(detections, key=lambda d: -d.score)
        if cfg.same_object_iou is not None and len(detections) > 1:
            keep = nms(np.array([d.box for d in detections]), np.array([d.score for d in detections]),
                       cfg.same_object_iou)
            detections = [detections[i] for i in sorted(keep)]
        detections = detections[: cfg.max_objects]

        # --- segmentation: one decoder run per confident box ---------------------------------------
        wanted = [
            segmenter is not None and det.score >= cfg.segment_min_score and det.width >= 2 and det.height >= 2
            and (cfg.segment == "all" or self._needs_mask(det, w, h))
            for det in detections
        ]
        if segmenter is not None and not early and any(wanted):
            _timed(segmenter.set_image, timings, "segment_encoder")(image)
        t0 = time.perf_counter()
        masks: list[np.ndarray | None] = [
            np.asarray(segmenter.segment_box(det.box).values, dtype=bool) if want else None  # type: ignore[union-attr]
            for det, want in zip(detections, wanted)
        ]
        timings["segment_decoder"] = time.perf_counter() - t0 if any(wanted) else 0.0
        timings.setdefault("segment_encoder", 0.0)
        timings["segment"] = timings["segment_encoder"] + timings["segment_decoder"]
        timings.setdefault("depth", 0.0)

        # --- distance and placement -----------------------------------------------------------------
        t0 = time.perf_counter()
        objects = [self._measure(det, m, image.shape, intrinsics, gravity, depth_map) for det, m in zip(detections, masks)]
        scale = self._depth_scale(objects, depth_map)
        weights, fusion_note = self._fusion_weights(objects, scale)
        for obj in objects:
            self._place(obj, scale, intrinsics, weights)
        if self._yaw_from_depth(scale, weights[3]):
            self._orient(objects, depth_map, scale, intrinsics, gravity)  # type: ignore[arg-type]
        timings["distance"] = time.perf_counter() - t0

        # --- scene ---------------------------------------------------------------------------------
        capture_id = capture_id or _default_capture_id()
        scene_objects = self._scene_objects(objects, capture_id, mount, world_from_cam)
        timings["total"] = time.perf_counter() - t_start
        capture = Capture(
            id=capture_id,
            timestamp=time.time(),
            image=image_name,
            intrinsics=intrinsics.to_dict(),
            robot_pose={"x": float(robot_pose.translation[0]), "y": float(robot_pose.translation[1]),
                        "z": float(robot_pose.translation[2]), "yaw": float(robot_pose.yaw)},
            camera_position=tuple(float(v) for v in world_from_cam.translation),  # type: ignore[arg-type]
            camera_quaternion=tuple(float(v) for v in world_from_cam.quaternion),  # type: ignore[arg-type]
            timings=dict(timings),
            models={**self._model_names(depth_map, scale), "fusion": fusion_note},
        )
        scene = Scene(objects=tuple(scene_objects), captures=(capture,))
        return MapResult(scene, objects, depth_map, scale, timings, pairs)

    # --- helpers ----------------------------------------------------------------------------------

    def _prompts(self, prompts: Sequence[str] | Sequence[Prompt] | None) -> list[Prompt]:
        if prompts is not None and not isinstance(prompts, str) and len(prompts) > 0 and all(
            isinstance(p, (tuple, list)) for p in prompts
        ):
            out = []
            for i, p in enumerate(prompts):
                if len(p) != 2 or not all(isinstance(s, str) and s.strip() for s in p):
                    raise MapperError(f"prompt {i + 1} must be a (text, class name) pair of words, got {p!r}")
                out.append((p[0].strip(), p[1].strip()))
            return out
        return prompts_from_words(self.catalog, prompts)  # type: ignore[arg-type]

    def _needs_mask(self, det: Detection, width: int, height: int) -> bool:
        """Whether the distance of ``det`` depends on its mask: unknown size, or a box the border cuts
        both vertically and horizontally (no size-prior distance: depth only)."""
        entry = self.catalog.lookup(det.label)
        if entry is None or entry.size is None:
            return True
        if not self.config.handle_truncation or det.width <= 0 or det.height <= 0:
            return False
        t = truncation(det.box, width, height, self.config.truncation_margin_px)
        return t.vertical_cut and t.horizontal_cut

    def _submit(self, fn: Callable[..., Any], arg: Any, timings: dict[str, float], key: str) -> Future[Any]:
        if not self.config.parallel:
            fut: Future[Any] = Future()
            try:
                fut.set_result(_timed(fn, timings, key)(arg))
            except BaseException as exc:  # re-raised by result()
                fut.set_exception(exc)
            return fut
        if self._pool is None:
            self._pool = ThreadPoolExecutor(max_workers=2, thread_name_prefix="mapper")
        return self._pool.submit(_timed(fn, timings, key), arg)

    def _measure(
        self,
        det: Detection,
        mask: np.ndarray | None,
        shape: tuple[int, ...],
        intr: Intrinsics,
        gravity: np.ndarray,
        depth_map: DepthMap | None,
    ) -> MappedObject:
        """Everything that does not need the depth scale: truncation, mask, geometric estimate, depth value."""
        cfg = self.config
        h, w = int(shape[0]), int(shape[1])
        box = det.box
        if det.width <= 0 or det.height <= 0:
            trunc = Truncation(True, True, True, True)
        elif cfg.handle_truncation:
            trunc = truncation(box, w, h, cfg.truncation_margin_px)
        else:
            trunc = Truncation()
        entry = self.catalog.lookup(det.label)
        size = entry.size if entry is not None else None
        obj = MappedObject(
            detection=det,
            mask=mask,
            mask_area=int(np.count_nonzero(mask)) if mask is not None else None,
            truncation=trunc,
            size=size if size is not None else (0.0, 0.0, 0.0),
            size_known=size is not None,
        )
        if det.width <= 0 or det.height <= 0:
            obj.skipped = "empty box"
            return obj
        if size is not None:
            obj.geometric = geometric_estimate(
                box, size, intr, trunc, gravity, cfg.placement,
                size_sigma=cfg.size_sigma, horizontal_sigma_scale=cfg.horizontal_sigma_scale,
            )
        if depth_map is not None:
            # without a mask, the middle half of the box: mostly the object, little background
            depth_region = mask if mask is not None and mask.any() else _box_mask(box, h, w, shrink=0.25)
            obj.depth_value = mask_median_depth(depth_map.values, depth_region)
        return obj

    @property
    def _exact_depth(self) -> bool:
        """Exact metric depth: configured, or declared by the depth backend (``exact = True``)."""
        return self.config.exact_depth or bool(getattr(self.models.depth, "exact", False))

    def _depth_scale(self, objects: list[MappedObject], depth_map: DepthMap | None) -> DepthScale | None:
        """Metric conversion of the depth map, fitted from the objects of known size when configured."""
        if depth_map is None:
            return None
        values, surfaces = self._references(objects)
        if depth_map.kind == "metric":
            if self._exact_depth:
                return IDENTITY_SCALE
            if self.config.fit_depth and len(values) >= max(1, self.config.refit_metric_min_refs):
                return fit_depth_scale(values, surfaces, "metric") or IDENTITY_SCALE  # type: ignore[arg-type]
            return IDENTITY_SCALE
        if not self.config.fit_depth or not values:
            return None  # relative depth without references has no metric meaning
        return fit_depth_scale(values, surfaces, depth_map.kind)  # type: ignore[arg-type]

    def _tile_px(self) -> int | None:
        """Tile side [px] for tiled detection, ``None`` when the detector has no fixed input size."""
        size = getattr(self.models.detector, "input_size", None)
        if self.config.detect_tile_factor is None or not isinstance(size, (tuple, list)) or not size:
            return None
        try:
            side = max(int(v) for v in size)
        except (TypeError, ValueError):
            return None
        return max(64, int(round(self.config.detect_tile_factor * side)))

    def _references(self, objects: list[MappedObject]) -> tuple[list[float], list[float]]:
        """Depth-map values and size-prior surface depths [m] of the objects usable as references."""
        refs = [o for o in objects if o.geometric is not None and o.depth_value is not None]
        values = [float(o.depth_value) for o in refs]  # type: ignore[arg-type]
        surfaces = [float(o.geometric.center[2]) - o.geometric.surface_offset for o in refs]  # type: ignore[union-attr]
        return values, surfaces

    def _fusion_weights(
        self, objects: list[MappedObject], scale: DepthScale | None
    ) -> tuple[tuple[float, float, float | None, bool], str]:
        """``((w_geometric, w_depth, gate, nearer_depth_wins), description)`` for this image (see
        :attr:`MapperConfig.fusion`). ``nearer_depth_wins``: the map is metric and agrees with the size
        priors here (spread within ``trust_depth_spread``), so it beats a size prior read off a box cut
        short (image border or occluder; see :func:`~pipeline.distance.fuse_distances`)."""
        cfg = self.config
        if self._exact_depth and scale is not None:
            return (0.0, 1.0, None, False), "exact depth: the depth map decides, size priors only where it has no reading"
        note = f"fixed: w_geometric {cfg.w_geometric:g}, w_depth {cfg.w_depth:g}"
        if cfg.fusion == "fixed" or scale is None:
            return (cfg.w_geometric, cfg.w_depth, None, False), note
        values, surfaces = self._references(objects)
        spread = depth_fit_spread(values, surfaces, scale)
        sg = cfg.geometric_sigma
        if spread is None or cfg.w_depth == 0 or cfg.w_geometric == 0:
            # the depth error the fixed weights imply: w_g / w_d = sigma_d^2 / sigma_g^2
            sd = sg * math.sqrt(cfg.w_geometric / cfg.w_depth) if cfg.w_depth > 0 and cfg.w_geometric > 0 else sg
            wg, wd = cfg.w_geometric, cfg.w_depth
            why = f"{note} (adaptive needs 3 reference objects, {len(values)} here)"
        else:
            # the spread holds both errors; the depth map's own is what exceeds the size prior's
            sd = math.sqrt(max(spread**2 - sg**2, MIN_DEPTH_SIGMA**2))
            wg, wd = inverse_variance_weights(sg, sd)
            why = (f"adaptive: w_geometric {wg:.2f}, w_depth {wd:.2f} (depth vs size priors: spread {spread:.0%} "
                   f"over {len(values)} reference objects)")
        gate = cfg.gate_sigmas * math.sqrt(sg**2 + sd**2)
        trusted = scale.kind == "metric" and spread is not None and spread <= cfg.trust_depth_spread
        if trusted:
            why += "; a nearer metric depth beats a size prior beyond the gate"
        return (wg, wd, gate, trusted), f"{why}; depth dropped beyond x{math.exp(gate):.2f} from the size prior"

    def _place(self, obj: MappedObject, scale: DepthScale | None, intr: Intrinsics,
               weights: tuple[float, float, float | None, bool]) -> None:
        """Depth-map distance, fusion and the camera-frame centre of one object."""
        if obj.skipped:
            return
        x1, y1, x2, y2 = obj.detection.box
        surface = None
        if scale is not None and obj.depth_value is not None:
            z = scale.to_metric(obj.depth_value)
            surface = float(z) if math.isfinite(float(z)) and float(z) > 0 else None
        uv = _region_centre(obj.mask, obj.detection.box)
        if surface is not None:
            if obj.geometric is not None:
                obj.depth_z = surface + obj.geometric.surface_offset
            else:
                half = self._half_depth(obj, surface, intr)
                obj.depth_z = float(centre_on_ray(uv, surface, half, intr)[2])
        obj.fused = fuse_distances(obj.geometric_z, obj.depth_z, *weights)
        if obj.fused is None:
            obj.skipped = "no distance: unknown size (or every dimension cut) and no metric depth"
            return
        if obj.geometric is not None:
            c = obj.geometric.center
            obj.center_cam = c * (obj.fused.distance / float(c[2]))
        else:
            assert surface is not None
            half = self._half_depth(obj, surface, intr)
            c = centre_on_ray(uv, surface, half, intr)
            obj.center_cam = c * (obj.fused.distance / float(c[2]))
        if not obj.size_known:
            obj.size = self._measured_size(obj, surface if surface is not None else obj.fused.distance, intr)

    def _yaw_from_depth(self, scale: DepthScale | None, trusted: bool) -> bool:
        """Whether objects get their yaw from the depth points (see :attr:`MapperConfig.yaw_from_depth`)."""
        if scale is None:
            return False
        if self.config.yaw_from_depth is not None:
            return self.config.yaw_from_depth
        return self._exact_depth or (trusted and scale.kind == "metric")

    @staticmethod
    def _orient(objects: list[MappedObject], depth_map: DepthMap, scale: DepthScale, intr: Intrinsics,
                gravity: np.ndarray) -> None:
        """Fit the length axis (camera frame) of every placed known-size object with a mask from its
        back-projected depth points [m]."""
        todo = [o for o in objects if o.center_cam is not None and o.size_known and o.mask is not None
                and o.mask.any()]
        if not todo:
            return
        depth_m = np.asarray(scale.to_metric(depth_map.values), dtype=np.float64)
        for obj in todo:
            obj.length_axis_cam = length_axis_from_points(obj.mask, depth_m, intr, gravity, obj.size)  # type: ignore[arg-type]

    def _half_depth(self, obj: MappedObject, surface_z: float, intr: Intrinsics) -> float:
        """Half the object's depth [m] along the ray: for a known size, the expected half extent of
        its footprint at unknown yaw, ``(w + l) / pi``; for an unknown size, half its measured width
        (a square footprint seen at a random yaw shows about ``4/pi`` of its side)."""
        if obj.size_known:
            w, _, l = obj.size
            return (w + l) / math.pi
        wpx = _region_width(obj.mask, obj.detection.box)
        return 0.5 * wpx * surface_z / intr.fx

    @staticmethod
    def _measured_size(obj: MappedObject, surface_z: float, intr: Intrinsics) -> tuple[float, float, float]:
        """Size ``(w, h, l)`` [m] of an unknown-size object from its mask extent at ``surface_z``; the
        footprint is taken square (``l = w``)."""
        x1, y1, x2, y2 = _region_box(obj.mask, obj.detection.box)
        wm = max((x2 - x1) * surface_z / intr.fx, 0.05)
        hm = max((y2 - y1) * surface_z / intr.fy, 0.05)
        return (wm, hm, wm)

    def _scene_objects(
        self, objects: list[MappedObject], capture_id: str, mount: CameraMount, world_from_cam: Pose
    ) -> list[SceneObject]:
        robot_from_cam = mount.pose
        R_world_cam = world_from_cam.rotation.as_matrix()
        counts: dict[str, int] = {}
        out: list[SceneObject] = []
        for obj in objects:
            if obj.center_cam is None or obj.fused is None:
                continue
            det = obj.detection
            counts[det.label] = counts.get(det.label, 0) + 1
            obj.object_id = f"{det.label}-{counts[det.label]}"
            c_cam = obj.center_cam
            c_robot = robot_from_cam.apply(c_cam)
            c_world = world_from_cam.apply(c_cam)
            if obj.length_axis_cam is not None:
                axis = np.asarray(obj.length_axis_cam, dtype=np.float64)
                if float(axis @ -c_cam) < 0:  # length axis (the object's front) towards the camera
                    axis = -axis
            elif self.config.yaw_from_fit and obj.geometric is not None and obj.geometric.axes is not None:
                axis = np.asarray(obj.geometric.axes[0], dtype=np.float64)
                if float(axis @ -c_cam) < 0:  # length axis (the object's front) towards the camera
                    axis = -axis
            else:
                axis = -c_cam  # facing the camera
            yaw = heading_in_frame(axis, R_world_cam)
            if not (np.all(np.isfinite(c_world)) and math.isfinite(yaw)):
                obj.skipped = "non-finite position"
                continue
            out.append(
                SceneObject(
                    id=obj.object_id,
                    label=det.label,
                    position=_vec(c_world),
                    size=tuple(float(v) for v in obj.size),  # type: ignore[arg-type]
                    yaw=yaw,
                    frame="world",
                    score=min(max(det.score, 0.0), 1.0),
                    size_known=obj.size_known,
                    source=Source(
                        capture=capture_id,
                        method=obj.fused.method,
                        bbox=det.box,
                        mask_area=obj.mask_area,
                        distances={"geometric": obj.geometric_z, "depth": obj.depth_z, "fused": obj.fused.distance},
                        positions={"camera": _vec(c_cam), "robot": _vec(c_robot)},
                    ),
                )
            )
        return out

    def _model_names(self, depth_map: DepthMap | None, scale: DepthScale | None) -> dict[str, str]:
        names = {"detector": str(self.models.detector.name)}
        seg = getattr(self.models, "segmenter", None) if self.config.segment != "none" else None
        names["segmenter"] = (
            "none (box as mask)" if seg is None
            else f"{seg.name} (only where the distance needs a mask)" if self.config.segment == "auto"
            else str(seg.name)
        )
        depth_model = getattr(self.models, "depth", None)
        names["depth"] = str(depth_model.name) if depth_model is not None else "none"
        if depth_map is not None:
            names["depth_kind"] = depth_map.kind
            if scale is not None:
                names["depth_scale"] = (
                    f"{scale.kind}: scale {scale.scale:.6g}, shift {scale.shift:.6g}, "
                    f"{scale.n_inliers}/{scale.n_refs} reference objects"
                )
            else:
                names["depth_scale"] = "none: no reference object of known size"
        names["placement"] = self.config.placement
        return names


# --- small helpers -------------------------------------------------------------------------------


def _timed(fn: Callable[..., Any], timings: dict[str, float], key: str) -> Callable[..., Any]:
    def wrapper(*args: Any) -> Any:
        t0 = time.perf_counter()
        try:
            return fn(*args)
        finally:
            timings[key] = time.perf_counter() - t0

    return wrapper


def _default_capture_id() -> str:
    t = time.time()
    return time.strftime("capture-%Y%m%d-%H%M%S", time.localtime(t)) + f"-{int((t % 1) * 1000):03d}"


def _vec(v: np.ndarray) -> tuple[float, float, float]:
    return (float(v[0]), float(v[1]), float(v[2]))


def _box_mask(box: Sequence[float], h: int, w: int, shrink: float = 0.0) -> np.ndarray:
    """The box (optionally shrunk by ``shrink`` of its size on each side) as a bool HxW mask."""
    x1, y1, x2, y2 = box
    dx, dy = shrink * (x2 - x1), shrink * (y2 - y1)
    c1, c2 = int(max(0, math.floor(x1 + dx))), int(min(w, math.ceil(x2 - dx)))
    r1, r2 = int(max(0, math.floor(y1 + dy))), int(min(h, math.ceil(y2 - dy)))
    m = np.zeros((h, w), dtype=bool)
    if c2 > c1 and r2 > r1:
        m[r1:r2, c1:c2] = True
    return m


def _region_box(mask: np.ndarray | None, box: Sequence[float]) -> tuple[float, float, float, float]:
    if mask is not None and mask.any():
        rows = np.flatnonzero(mask.any(axis=1))
        cols = np.flatnonzero(mask.any(axis=0))
        return (float(cols[0]), float(rows[0]), float(cols[-1] + 1), float(rows[-1] + 1))
    x1, y1, x2, y2 = box
    return (float(x1), float(y1), float(x2), float(y2))


def _region_width(mask: np.ndarray | None, box: Sequence[float]) -> float:
    x1, _, x2, _ = _region_box(mask, box)
    return x2 - x1


def _region_centre(mask: np.ndarray | None, box: Sequence[float]) -> tuple[float, float]:
    """Pixel centre of the mask's bounding box (the detection box without a mask)."""
    x1, y1, x2, y2 = _region_box(mask, box)
    return ((x1 + x2) / 2, (y1 + y2) / 2)


__all__ = [
    "LIGHT_MODELS", "MAX_IMAGE_SIDE", "MapResult", "MappedObject", "Mapper", "MapperConfig", "MapperError", "as_rgb8",
    "gravity_in_camera", "load_mapping_models", "prompts_from_words",
]
