"""Capture & map, off the UI thread: photo + pose from the robot -> perception -> spawned objects.

One job runs at a time. Its stages report progress to the session (``JobStatus``), so every tab
shows the same progress bar; the outcome (or the error) is announced as a notice. The session then
holds the new capture (photo, detections, depth, camera pose), the merged world-frame objects, the
rebuilt grid and the replanned candidate.

The robot side is a :data:`TakePhoto` callable (the link's ``capture``, returning a
:class:`~console.link.base.CaptureResult`) and the pipeline side a :class:`Perceiver`, so the job
works with any link (simulated or MAVLink) and any perception backend (offline models, or the
simulator's ground truth when no model weights are installed).
"""

from __future__ import annotations

import logging
import threading
import time
import uuid
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Protocol

import numpy as np

from pipeline.mapping.map_fusion import fuse
from pipeline.scene import Scene

from console.link.base import CaptureResult
from console.session.job_thread import BackgroundRun
from console.session.model_preload import ModelPreload
from console.session.pinned_notes import pinned_far, pinned_views

from console.session.session import CaptureRecord, Detection, JobStatus, Session, SessionError
from console.session.session_types import MappingError
from console.wording import plural

log = logging.getLogger(__name__)

JOB_NAME = "Capture & map"


@dataclass(frozen=True)
class Perception:
    """What the pipeline made of a shot.

    Attributes:
        scene: Objects in the world frame (and the capture record).
        detections: Boxes in the photo, for display.
        depth: Depth along the optical axis [m] (H x W), or ``None``.
        timings: Wall time per stage [s].
    """

    scene: Scene
    detections: tuple[Detection, ...] = ()
    depth: np.ndarray | None = None
    timings: dict[str, float] = field(default_factory=dict)


Progress = Callable[[float, str], None]
"""``progress(fraction in [0, 1], stage text)``."""

STAGE_TEXT = {
    "detect": "detect: finding objects",
    "segment": "segment: masks where a distance needs one",
    "depth": "depth: estimating the depth map",
    "distance": "distance: ranging and placing the objects",
}
"""What the progress bar says as each mapping stage (:data:`pipeline.stage_progress.STAGES`) begins."""

WAITING_TEXT = "waiting for the models to load"

TakePhoto = Callable[[], CaptureResult]


class Perceiver(Protocol):
    """A perception backend: photo -> world-frame objects."""

    label: str
    """Shown to the operator (e.g. ``ground truth (simulator; no model weights)``)."""

    def perceive(self, shot: CaptureResult, capture_id: str, progress: Progress) -> Perception:
        """Objects of ``shot`` in the world frame; ``capture_id`` goes into their ``source``."""
        ...


def capture_id(shot: CaptureResult) -> str:
    """A capture id for the session: the photo's name when it has one, else a fresh id."""
    stem = "".join(c if c.isalnum() or c in "-_" else "_" for c in (shot.name or ""))[:40]
    return f"cap-{stem}-{uuid.uuid4().hex[:4]}" if stem else f"cap-{uuid.uuid4().hex[:8]}"


class MappingJob(BackgroundRun):
    """Runs :data:`TakePhoto` -> :class:`Perceiver` -> ``session.spawn`` in a worker thread.

    Args:
        session: Where progress and results go.
        take_photo: Asks the robot for a photo and its pose (blocking).
        perceiver: The perception backend.
        preload: The background loading of the perceiver's models (:mod:`console.session.model_preload`);
            a run waits for it after taking the photo, saying so in its progress.
        pair: Re-places a shot at the robot's pose at its frame's time (a live camera:
            :func:`console.session.photo_pose.photo_pairing`); raises when no pose is near it.
    """

    def __init__(self, session: Session, take_photo: TakePhoto, perceiver: Perceiver,
                 preload: ModelPreload | None = None,
                 pair: Callable[[CaptureResult], CaptureResult] | None = None) -> None:
        # re-entrant: start() reports 'starting' under it and the session's listeners read ``held`` then
        super().__init__(threading.RLock())
        self._session = session
        self._take_photo = take_photo
        self._pair = pair
        self.perceiver = perceiver
        self.preload = preload
        self._held: tuple[Scene, str] | None = None
        self._job_name = JOB_NAME  # what the progress says runs (Look around runs captures under its own name)

    @property
    def held(self) -> str | None:
        """Id of the capture held back for disagreeing with the map, ``None`` if none is."""
        with self._lock:
            return None if self._held is None else self._held[1]

    def resolve_held(self, action: str) -> str:
        """The operator's answer to a held-back capture: ``merge`` it into the map anyway, ``replace``
        the map's objects (all but the pinned ones) with it, or ``discard`` it; returns what was done.

        Raises:
            SessionError: No capture is held back, an unknown action, or the session refused it.
        """
        if action not in ("merge", "replace", "discard"):
            raise SessionError(f"action must be merge, replace or discard, got {action!r}")
        with self._lock:
            held, self._held = self._held, None
        if held is None:
            raise SessionError("no capture is held back")
        scene, cap_id = held
        if action == "discard":
            return f"capture {cap_id} discarded"
        if action == "replace":
            for obj in self._session.scene.objects:
                if not obj.is_pinned:
                    self._session.delete_object(obj.id)
        ws = self._session.workspace  # as a capture that was not held back: nothing new outside the workspace
        _, preview = fuse(self._session.scene, scene, bounds=(ws.min, ws.max), check_consistency=False)
        if preview.not_added:
            scene = scene.with_objects([o for o in scene.objects if o.id not in preview.not_added])
        report = self._session.spawn(scene, origin=f"capture {cap_id}")
        return f"capture {cap_id}: {len(report.added)} new, {len(report.updated)} updated ({action})"

    def start(self) -> bool:
        """Start a run in the background; ``False`` if one is already running."""
        with self._lock:
            if self._alive():
                return False
            self._job_name = JOB_NAME
            # every tab sees the capture running from the click on
            self._launch(self.run, "mapping-job", announce=lambda: self._report(0.0, "starting"))
            return True

    def _report(self, fraction: float, message: str) -> None:
        self._session.set_job(JobStatus(self._job_name, True, max(0.0, min(1.0, fraction)), message))

    def run_as(self, name: str) -> bool:
        """One cycle in the calling thread as a step of another job (``name`` in the progress, e.g.
        ``Look around · heading 2/6 (150°)``); ``False`` at once when a capture is already running."""
        with self._lock:
            if self._alive():
                return False
            self._thread = threading.current_thread()
        try:
            return self.run(name)
        finally:
            with self._lock:
                self._thread = None

    def run(self, name: str = JOB_NAME) -> bool:
        """One capture-and-map cycle in the calling thread; ``True`` on success."""
        t0 = time.perf_counter()
        self._job_name = name
        try:
            self._report(0.02, "asking the robot for a photo")
            try:
                shot = self._take_photo()
            except MappingError:
                raise
            except Exception as exc:  # the link's errors, whatever their type
                from console.link.camera_source import CameraSourceError

                if isinstance(exc, CameraSourceError):  # a frozen or lost live camera: its own words
                    raise MappingError(f"the camera gave no usable photo: {exc}") from exc
                raise MappingError(f"the robot did not deliver a photo: {exc}") from exc
            if self._pair is not None:  # a live camera's frame at the robot's pose of that moment
                try:
                    shot = self._pair(shot)
                except Exception as exc:
                    raise MappingError(f"the photo cannot be placed: {exc}") from exc
            t_capture = time.perf_counter() - t0
            if self.preload is not None:
                self.preload.wait_ready(lambda f, text: self._report(0.15, f"{WAITING_TEXT}: {text} ({f:.0%})"))
            self._report(0.15, f"photo {shot.image.shape[1]}x{shot.image.shape[0]} received; "
                               f"perception: {self.perceiver.label}")

            def sub(f: float, text: str) -> None:
                self._report(0.15 + 0.7 * max(0.0, min(1.0, f)), text)

            cap_id = self._session.next_capture_id(shot.name, shot.source)  # unique across restarts
            try:
                result = self.perceiver.perceive(shot, cap_id, sub)
            except MappingError:
                raise
            except Exception as exc:
                log.exception("perception failed")
                raise MappingError(f"perception ({self.perceiver.label}) failed: {exc}") from exc
            n = len(result.scene.objects)
            self._report(0.88, f"spawning {n} objects, rebuilding the grid, replanning")
            timings = {"capture": t_capture, **result.timings}
            self._session.check_plausible(result.scene, f"capture {cap_id} refused")  # before anything is shown
            self._session.set_capture(CaptureRecord(
                id=cap_id, image=shot.image, intrinsics=shot.intrinsics, camera_pose=shot.camera_pose,
                robot_pose=shot.robot_pose, detections=result.detections, depth=result.depth,
                backend=self.perceiver.label, timings=timings, timestamp=shot.timestamp,
            ))
            # the fusion is pure: a dry run against the map says what will happen to each object and
            # whether the capture agrees with the map at all (the session's merge never holds back)
            ws, mapped = self._session.workspace, self._session.scene
            _, preview = fuse(mapped, result.scene, bounds=(ws.min, ws.max))
            if preview.held_back:
                with self._lock:
                    self._held = (result.scene, cap_id)
                text = f"capture {cap_id} held back: {preview.held_back}"
                self._session.set_job(JobStatus(name, False, 1.0, text))
                self._session.notify("Capture held back", f"{text} The map is unchanged: merge it anyway, replace "
                                     "the map with it, or discard it.", "warning")
                return True
            drop = preview.not_added  # e.g. an object outside the workspace: said in the notes, not added
            report = self._session.spawn(result.scene.with_objects([o for o in result.scene.objects if o.id not in drop])
                                         if drop else result.scene, origin=f"capture {cap_id}")
            known = self._observe_known(cap_id, shot, result)  # the known space, one undo step with the capture
            dt = time.perf_counter() - t0
            rejected, pinned = preview.rejected, len(pinned_views(preview))  # pinned: seen again, not moved
            summary = (f"{plural(n, 'object')} seen ({len(report.added)} new, {len(report.updated)} updated"
                       + (f", {pinned} kept pinned" if pinned else "")
                       + (f", {len(rejected)} not used" if rejected else "") + f") in {dt:.1f} s")
            far = pinned_far(preview, result.scene, mapped)  # a pinned object the capture sees elsewhere
            dropped = ("; not used: " + "; ".join(f"{o.name}: {o.reason}" for o in rejected)) if rejected else ""
            # a close-up drops only what it cannot range: each one and why stays on the panel
            self._session.set_job(JobStatus(name, False, 1.0, summary + "".join(f"; {f}" for f in far) + dropped + known))
            notes = far + preview.notes() + list(report.notes)
            body = summary + ("; " + "; ".join(notes) if notes else "")
            self._session.notify("Mapped", body, "warning" if rejected or far else "success")
            if far:  # its own notice, shown whole: the Mapped one may show only its counts
                self._session.notify("Pinned object seen elsewhere", "; ".join(far), "warning")
            from pipeline.camera.pose_check import floor_check

            for warning in floor_check(result.scene):  # objects under the floor / floating: a wrong camera pose
                self._session.notify("Check the camera pose", f"capture {cap_id}: {warning}", "warning")
            return True
        except (MappingError, SessionError) as exc:  # SessionError: e.g. an implausible object refused
            self._session.set_job(JobStatus(self._job_name, False, 0.0, "failed", str(exc)))
            self._session.notify("Capture & map failed", str(exc), "error")
            return False
        except Exception as exc:  # a bug: report it, keep the console alive
            log.exception("mapping job crashed")
            self._session.set_job(JobStatus(self._job_name, False, 0.0, "failed", repr(exc)))
            self._session.notify("Capture & map failed", f"internal error: {exc!r}", "error")
            return False


    def _observe_known(self, cap_id: str, shot: CaptureResult, result: Perception) -> str:
        """Cast the capture's depth through the session's known space; the panel's words about it.

        The depth is the perception's (the simulator's rendered depth, a depth model's scaled map) or,
        without one, the mapped boxes'. Says how many occupied cells no mapped object explains and how
        much of the near depth the mapped objects explain, and warns when that is little.
        """
        observe = getattr(self._session, "observe_capture", None)
        if observe is None:
            return ""
        exact = self.perceiver.label.startswith("ground truth")
        try:
            summary = observe(cap_id, result.depth, shot.intrinsics, shot.camera_pose, shot.robot_pose, exact=exact)
        except SessionError as exc:
            return f"; {exc}"
        text = f"; {plural(summary.unlabelled, 'unlabelled obstacle cell')}"
        if result.depth is None:
            return text + " (no depth: known space from the mapped boxes)"
        from console.session.known_space_state import DEPTH_NOISE_REL
        from pipeline.mapping.known_space_update import DepthNoise, explained_share

        ws = self._session.workspace
        noise = DepthNoise() if exact else DepthNoise(relative=DEPTH_NOISE_REL)  # the walls: as the known space's
        ex = explained_share(np.nan_to_num(np.asarray(result.depth, dtype=np.float64), nan=0.0), shot.intrinsics,
                             shot.camera_pose, self._session.scene.objects, ws.min, ws.max, noise=noise)
        text += f"; mapped objects explain {100 * ex.share:.0f} % of the near depth"
        if ex.low:
            self._session.notify(
                "Little of the photo explained",
                f"capture {cap_id}: the mapped objects explain only {100 * ex.share:.0f} % of the near depth: the depth "
                "sees obstacles the detector did not name (drawn as unlabelled obstacles; the planner avoids them)",
                "warning")
        return text


# --- perception backends ----------------------------------------------------------------------------

GROUND_TRUTH_LABEL = "ground truth (simulator render; no model weights)"


class MapperPerceiver:
    """The mapping pipeline (:class:`pipeline.mapper.Mapper`) on a model bundle.

    Args:
        label: Shown to the operator.
        bundle_for: Builds the detector / segmenter / depth bundle for a shot (the offline models,
            loaded once, or the ground truth of a simulator render); raises :class:`MappingError`
            with an operator-facing message when it cannot.
    """

    def __init__(self, label: str, bundle_for: Callable[[CaptureResult], Any]) -> None:
        self.label = label
        self._bundle_for = bundle_for
        self._catalog: Any = None

    def preload(self, progress: Progress) -> None:
        """Load what the first capture would otherwise load: the mapper's modules, the catalog and
        (offline models) the model weights, run once on a blank photo. Raises :class:`MappingError`."""
        from pipeline.catalog import default_catalog
        from pipeline.mapper import Mapper  # noqa: F401  (imports scipy, the models' runtime, ...)

        progress(0.02, "catalog")
        if self._catalog is None:
            self._catalog = default_catalog()
        prepare = getattr(self._bundle_for, "preload", None)
        if prepare is not None:
            prepare(lambda f, text: progress(0.05 + 0.95 * max(0.0, min(1.0, f)), text))
        progress(1.0, "ready")

    def perceive(self, shot: CaptureResult, capture_id: str, progress: Progress) -> Perception:
        from pipeline.catalog import default_catalog
        from pipeline.mapper import Mapper
        from pipeline.stage_progress import StageFractions

        progress(0.0, f"preparing {self.label}")
        bundle = self._bundle_for(shot)
        if self._catalog is None:
            self._catalog = default_catalog()
        fractions = StageFractions()

        def on_stage(stage: str) -> None:
            progress(0.05 + 0.9 * fractions.at_start(stage), STAGE_TEXT.get(stage, stage))

        with Mapper(bundle, self._catalog) as mapper:
            res = mapper.run(shot.image, shot.intrinsics, shot.mount, shot.robot_pose, capture_id=capture_id,
                             image_name=shot.name or None, on_stage=on_stage)
        progress(1.0, f"{len(res.scene.objects)} objects placed")
        dets = tuple(
            Detection(m.detection.label, float(m.detection.score), tuple(m.detection.box), m.object_id)  # type: ignore[arg-type]
            for m in res.objects
        )
        depth = None
        if res.depth is not None:
            values = np.asarray(res.depth.values, dtype=np.float64)
            if res.depth_scale is not None:
                depth = np.asarray(res.depth_scale.to_metric(values), dtype=np.float32)
            elif res.depth.kind == "metric":
                depth = np.where(values > 0, values, np.nan).astype(np.float32)
        return Perception(res.scene, dets, depth, dict(res.timings))


def ground_truth_bundle_for(shot: CaptureResult) -> Any:
    """The ground-truth perception bundle of a simulator render (boxes, masks, depth)."""
    from pipeline.models.ground_truth import ground_truth_bundle

    gt = shot.ground_truth
    if gt is None:
        raise MappingError("this photo carries no ground truth; start the console with --models DIR "
                           "to map it with the offline models")
    masks = None
    if gt.instances is not None and gt.visible:
        masks = [gt.instances == v.index for v in gt.visible]
    return ground_truth_bundle([v.bbox for v in gt.visible], [v.label for v in gt.visible], masks, gt.depth)


class OfflineModels:
    """The offline model set, loaded by :meth:`preload` (at console start) or on first use (in the
    mapping thread), and kept."""

    def __init__(self, model_dir: Path | None) -> None:
        self.model_dir = model_dir
        self._bundle: Any = None
        self._lock = threading.Lock()

    def _load(self) -> Any:
        from pipeline.catalog import default_catalog
        from pipeline.mapper import load_mapping_models
        from pipeline.models.base import ModelError

        if self._bundle is None:
            try:
                # closed-vocabulary labels (COCO) mapped to catalog classes
                self._bundle = load_mapping_models("offline", self.model_dir, default_catalog())
            except ModelError as exc:  # ModelMissingError names `morphonavi models fetch NAME`
                raise MappingError(str(exc)) from None
        return self._bundle

    def __call__(self, shot: CaptureResult) -> Any:
        with self._lock:
            return self._load()

    def preload(self, progress: Progress) -> None:
        """Load the weights, then run each model once on a blank 640 x 480 photo (onnxruntime's
        first run allocates its buffers), reporting each step. Raises :class:`MappingError`."""
        from pipeline.catalog import default_catalog
        from pipeline.models.base import ModelError

        with self._lock:
            progress(0.0, f"loading {offline_models_label(self.model_dir)}")
            bundle = self._load()
            blank = np.full((480, 640, 3), 127, np.uint8)
            try:
                progress(0.4, "first run of the detector")
                bundle.detector.detect(blank, list(default_catalog().prompts()))
                if bundle.depth is not None:
                    progress(0.5, "first run of the depth model")
                    bundle.depth.estimate(blank)
                if bundle.segmenter is not None:
                    progress(0.6, "first run of the segmenter")
                    bundle.segmenter.set_image(blank)
                    bundle.segmenter.segment_box((200.0, 150.0, 440.0, 330.0))
            except ModelError as exc:
                raise MappingError(str(exc)) from None
            progress(1.0, "models ready")


NOISY_LABEL = "ground truth with perception noise (simulator render: box jitter, missed and false detections)"


def simulator_perceiver(perception: str = "exact") -> MapperPerceiver:
    """The simulator's ground-truth perception, ``exact`` or ``noisy`` (like a real detector's)."""
    if perception == "noisy":
        from console.link.sim_perception_noise import noisy_bundle_for

        return MapperPerceiver(NOISY_LABEL, noisy_bundle_for())
    return MapperPerceiver(GROUND_TRUTH_LABEL, ground_truth_bundle_for)


def missing_offline_models(model_dir: Path | None) -> list[str]:
    """Registry names of the offline set's models not found (in ``model_dir`` or the default places)."""
    from pipeline.models.registry import locate, set_members

    return [n for n in set_members("offline") if locate(n, model_dir) is None]


def choose_perceiver(link: Any, model_dir: Path | None, perception: str = "exact") -> Perceiver:
    """The perception backend for a link.

    With ``model_dir`` the offline models are used (a simulator falls back to its ground truth,
    labelled so, when they are missing). Without it, a simulator maps its renders with ground-truth
    perception (``perception="noisy"``: through :mod:`console.link.sim_perception_noise`), and a real
    robot uses the offline models from the default model folders.
    """
    from console.link.sim import SimRobot

    simulated = isinstance(link, SimRobot)
    if model_dir is None and simulated:
        return simulator_perceiver(perception)
    missing = missing_offline_models(model_dir)
    where = str(model_dir) if model_dir is not None else "the default model folders"
    if missing and simulated:
        log.warning("offline models %s missing in %s: the simulator's ground truth is used instead "
                    "(fetch them with: morphonavi models fetch %s)", ", ".join(missing), where, " ".join(missing))
        return MapperPerceiver(f"ground truth (simulator render; models {', '.join(missing)} missing in {where})",
                               ground_truth_bundle_for)
    if missing:
        log.warning("offline models %s missing in %s: Capture & map will fail until they are fetched",
                    ", ".join(missing), where)
    return MapperPerceiver(f"offline models ({offline_models_label(model_dir)}) from {where}", OfflineModels(model_dir))


def offline_models_label(model_dir: Path | None) -> str:
    """What the offline set runs here: YOLOX-Nano, with the Open Images SSD beside it when fetched."""
    from pipeline.models.registry import locate

    second = " + Open Images SSD" if locate("oidv4_ssd", model_dir) is not None else ""
    return f"YOLOX-Nano{second}, MobileSAM, FastDepth"
