"""One photo in, a scene of 3D objects out: detection, segmentation, depth, distance, placement.

:class:`Mapper` runs the stages on one RGB image and returns a :class:`~pipeline.scene.Scene` whose
objects are in the world frame (z up), with their camera-frame (OpenCV: x right, y down, z forward) and
robot-frame (x forward, y left, z up) centres and the distance estimates in each object's ``source``,
and per-stage wall times [s] in the capture. It never writes files: save with
:meth:`Scene.save <pipeline.scene.Scene.save>` (atomic) once mapping succeeded.

Stages (timing keys), in the order they are announced to ``on_stage`` (:mod:`pipeline.stage_progress`):
``detect``; ``segment`` (the segmenter's image encoder, ``segment_encoder``, then one decoder run per
box, ``segment_decoder``); ``depth``; ``distance`` (size prior, depth-scale fitting, fusion,
placement). ``total`` is the wall time. With ``MapperConfig.segment = "auto"`` (the default) the
encoder runs only when a detection needs its mask (see there). The stages run one after another;
with ``MapperConfig.parallel`` detection, depth and (``segment="all"``) the encoder run concurrently.
"""

from __future__ import annotations

import math
import time
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Any, Callable, Sequence

import numpy as np

from pipeline.catalog import Catalog
from pipeline.ranging.distance import DepthScale, truncation
from pipeline.camera.geometry import (
    CameraError, CameraMount, Intrinsics, Pose, camera_pose_in_world, mount_from_gravity_height,
)
from pipeline.ranging.ground_contact import GroundModel
from pipeline.mapper_config import (
    LIGHT_MODELS, MAX_IMAGE_SIDE, MapperConfig, MapperError, ModelBundleLike, as_rgb8, gravity_in_camera,
    load_mapping_models, prompts_from_words,
)
from pipeline.models.base import DepthMap, Detection, Prompt
from pipeline.models.nms import nms
from pipeline.ranging.photo_floor import floor_pass
from pipeline.ranging.placement import heading_in_frame
from pipeline.ranging.ranger import MappedObject, Ranger
from pipeline.ranging.reasons import down_weight_reasons
from pipeline.scene import Capture, Scene, SceneObject, Source
from pipeline.segment_policy import mask_wanted
from pipeline.stage_progress import StageCallback, stage_reporter
from pipeline.models.tiled_detection import detect_planned


@dataclass
class MapResult:
    """Everything one mapping run produced: the scene and the intermediate results."""

    scene: Scene
    objects: list[MappedObject]
    depth: DepthMap | None
    depth_scale: DepthScale | None
    timings: dict[str, float]
    prompts: list[Prompt] = field(default_factory=list)


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
        pose_given: bool = True,
    ) -> Scene:
        """The scene (world frame) of the objects in ``image_rgb``; see :meth:`run`."""
        return self.run(image_rgb, intrinsics, mount, robot_pose, prompts, capture_id, image_name,
                        pose_given=pose_given).scene

    def run(
        self,
        image_rgb: np.ndarray,
        intrinsics: Intrinsics,
        mount: CameraMount | None = None,
        robot_pose: Pose | None = None,
        prompts: Sequence[str] | Sequence[Prompt] | None = None,
        capture_id: str | None = None,
        image_name: str | None = None,
        on_stage: StageCallback | None = None,
        pose_given: bool = True,
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
            on_stage: Called as each stage begins, in the order of :data:`pipeline.stage_progress.STAGES`
                (``detect``, ``segment``, ``depth``, ``distance``); see :mod:`pipeline.stage_progress`.
            pose_given: The mount's pitch, roll and height are known for this photo (checked against the
                photo's floor, :mod:`pipeline.ranging.photo_floor`). ``False``: only its yaw and position
                are; the camera's gravity and height come from the photo (the mount's height, when above
                5 cm, is the prior) and the scene's world frame follows them. A mount marked
                :attr:`~pipeline.camera.geometry.CameraMount.assumed` counts as ``False``.

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
        pose_given = pose_given and not mount.assumed  # a stand-in mount: the photo's floor decides
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
        ranger = Ranger(cfg, self.catalog, self._exact_depth,
                        self._ground(world_from_cam, gravity) if pose_given else None)
        timings: dict[str, float] = {}

        # --- detection, depth and the image encoder, concurrently ---------------------------------
        segmenter = getattr(self.models, "segmenter", None) if cfg.segment != "none" else None
        depth_model = getattr(self.models, "depth", None)
        report = stage_reporter(on_stage)
        early = segmenter is not None and cfg.segment == "all" and cfg.parallel
        enc_future = self._submit(segmenter.set_image, image, timings, "segment_encoder") if early else None
        depth_future = (self._submit(depth_model.estimate, image, timings, "depth")
                        if depth_model is not None and cfg.parallel else None)
        report("detect")
        # each detector (each member of a merged one) on the image and on tiles of its own input size
        detections = _timed(detect_planned, timings, "detect")(detector, image, pairs, cfg.detect_tile_factor)
        detections = sorted(detections, key=lambda d: -d.score)
        if cfg.same_object_iou is not None and len(detections) > 1:
            keep = nms(np.array([d.box for d in detections]), np.array([d.score for d in detections]),
                       cfg.same_object_iou)
            detections = [detections[i] for i in sorted(keep)]
        detections = detections[: cfg.max_objects]

        # --- segmentation: one decoder run per confident box ---------------------------------------
        report("segment")
        if enc_future is not None:
            enc_future.result()
        wanted = [  # see pipeline.segment_policy
            segmenter is not None and mask_wanted(cfg, det, w, h, ranger.needs_mask, self._exact_depth)
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
        report("depth")
        depth_map: DepthMap | None = (
            depth_future.result() if depth_future is not None
            else _timed(depth_model.estimate, timings, "depth")(image) if depth_model is not None else None
        )
        timings.setdefault("depth", 0.0)
        report("distance")

        # --- distance and placement -----------------------------------------------------------------
        t0 = time.perf_counter()
        objects = [ranger.measure(det, m, image.shape, intrinsics, gravity, depth_map) for det, m in zip(detections, masks)]
        if cfg.fusion == "sigma":
            ranger.mark_hidden_contacts(objects)  # a nearer object may hide a floor contact
        scale = ranger.depth_scale(objects, depth_map)
        floor = None
        if cfg.fusion == "sigma" and cfg.ground_contact and cfg.floor_fit:
            objects, scale, gravity, floor = floor_pass(
                ranger, detections, masks, objects, image.shape, intrinsics, gravity, depth_map, scale, pose_given,
                float(world_from_cam.translation[2]))
            if not pose_given and floor.estimate is not None:  # the world frame follows the photo's floor
                mount = mount_from_gravity_height(floor.estimate.gravity_cam, floor.estimate.camera_height, mount)
                world_from_cam = camera_pose_in_world(Pose.from_rotation(robot_pose.rotation, (
                    robot_pose.translation[0], robot_pose.translation[1], 0.0)), mount)
        fusion_note, trusted = ranger.place_all(objects, scale, intrinsics)
        if ranger.yaw_from_depth(scale, trusted):
            ranger.orient(objects, depth_map, scale, intrinsics, gravity)  # type: ignore[arg-type]
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
            models={**self._model_names(depth_map, scale), "fusion": fusion_note,
                    **({} if floor is None else {"camera_pose": floor.note}),
                    **({} if floor is None or floor.warning is None else {"camera_pose_warning": floor.warning})},
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

    @property
    def _exact_depth(self) -> bool:
        """Exact metric depth: configured, or declared by the depth backend (``exact = True``)."""
        return self.config.exact_depth or bool(getattr(self.models.depth, "exact", False))

    def _ground(self, world_from_cam: Pose, gravity: np.ndarray) -> GroundModel | None:
        """The floor under the camera (world z = 0) when the camera is more than 5 cm above it."""
        height = float(world_from_cam.translation[2])
        if not (self.config.fusion == "sigma" and self.config.ground_contact and 0.05 < height <= 100.0):
            return None
        cfg = self.config
        return GroundModel(tuple(float(v) for v in gravity / np.linalg.norm(gravity)), height,  # type: ignore[arg-type]
                           cfg.sigma_pitch, cfg.sigma_camera_height, cfg.sigma_floor)

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
                        distances=_distances(obj),
                        positions={"camera": _vec(c_cam), "robot": _vec(c_robot)},
                        down_weighted=down_weight_reasons(obj),
                    ),
                    # exact depth (a simulator's ground truth): no sigma; the map fusion's own model, tested
                    # on that simulator, applies (see pipeline.mapping.observation_sigma)
                    sigma=None if self._exact_depth else obj.sigma_along_ray,
                    cut=obj.cut_sides,
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


def _distances(obj: MappedObject) -> dict[str, float | None]:
    """The object's distance estimates [m, optical-axis depth of the centre] for ``source.distances``:
    size prior (``geometric``), depth map, fused, and with ``sigma`` fusion the floor contact
    (``ground_contact``, or ``ground_contact_bound`` when a nearer detection may hide it and it was used
    only as an upper bound, :mod:`pipeline.ranging.occlusion`)."""
    out: dict[str, float | None] = {"geometric": obj.geometric_z, "depth": obj.depth_z,
                                    "fused": obj.fused.distance if obj.fused else None}
    if obj.fusion is not None:
        gc = obj.cue("ground_contact")
        # a contact another detection may hide and that read too far was only an upper bound
        key = "ground_contact" if obj.contact_hidden_by is None else "ground_contact_bound"
        out[key] = gc.distance if gc is not None else None
    return out


def _vec(v: np.ndarray) -> tuple[float, float, float]:
    return (float(v[0]), float(v[1]), float(v[2]))


__all__ = [
    "LIGHT_MODELS", "MAX_IMAGE_SIDE", "MapResult", "MappedObject", "Mapper", "MapperConfig", "MapperError", "as_rgb8",
    "gravity_in_camera", "load_mapping_models", "prompts_from_words",
]
