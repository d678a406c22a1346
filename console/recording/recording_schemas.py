"""Session snapshots as Foxglove well-known messages (protobuf) and MorphoNavi JSON records.

Pure conversions, no I/O: :mod:`console.recording.recording` calls them on its writer thread and writes the
bytes into the MCAP file. The Foxglove topics (``foxglove.*`` schemas from ``foxglove-sdk``) let
the Foxglove app show the run without plugins; the ``/morphonavi/*`` JSON topics carry the exact
session state that :mod:`console.recording.replay` reads back.

Frames: ``world`` is the console's world frame (z up) [m]; ``robot`` is the robot body frame
(``world <- robot`` is the robot pose); ``camera`` is the capture camera in the OpenCV optical
frame (``world <- camera`` is the capture's camera pose). Times are nanoseconds since the epoch.
"""

from __future__ import annotations

import json
import math
from typing import Any, Mapping, Sequence

import numpy as np
from foxglove import messages as fm

from pipeline.rotation import yaw_quat_xyzw
from pipeline.scene import Scene
from planner.grid import CellState, PlanningGrid
from planner.mission import Mission

from console.session.session_types import CaptureRecord, Notice, RobotSnapshot, RouteSnapshot, RunStatus

# topic -> (schema name, message encoding); JSON topics carry the schemas of console.recording.channel_schemas
POSE = "/robot/pose"
TF = "/tf"
ROBOT_STATE = "/robot/state"
IMAGE = "/camera/image"
CALIBRATION = "/camera/calibration"
DEPTH = "/camera/depth"
CAPTURE_META = "/morphonavi/capture"
MAP = "/map/objects"
GRID = "/map/grid"
PATHS = "/paths"
LOG = "/log"
PROGRESS = "/mission/progress"
SCENE_JSON = "/morphonavi/scene"
ROUTE_JSON = "/morphonavi/route"
MISSION_JSON = "/morphonavi/mission"
SESSION_INFO = "/morphonavi/session"
AGENT_EVENTS = "/agent/events"  # a language-model agent's tool calls, proposals, the operator's decisions
KNOWN_SPACE = "/map/known_space"  # the known space (pipeline.mapping.known_space JSON form) and its counts
SEARCH_STEP = "/search/step"  # a search step: viewpoint chosen (gain, cost, why), move, capture, pause ...
SEARCH_RESULT = "/search/result"  # how a search ended (result.json with the search id)

FOXGLOVE_TYPES: dict[str, Any] = {
    POSE: fm.PoseInFrame, TF: fm.FrameTransform, IMAGE: fm.CompressedImage, CALIBRATION: fm.CameraCalibration,
    DEPTH: fm.CompressedImage, MAP: fm.SceneUpdate, GRID: fm.SceneUpdate, PATHS: fm.SceneUpdate, LOG: fm.Log,
}
JSON_TOPICS: dict[str, str] = {
    ROBOT_STATE: "morphonavi.RobotState", CAPTURE_META: "morphonavi.Capture", PROGRESS: "morphonavi.MissionProgress",
    SCENE_JSON: "morphonavi.Scene", ROUTE_JSON: "morphonavi.Route", MISSION_JSON: "morphonavi.Mission",
    SESSION_INFO: "morphonavi.Session", AGENT_EVENTS: "morphonavi.AgentEvent",
    KNOWN_SPACE: "morphonavi.KnownSpace", SEARCH_STEP: "morphonavi.SearchStep", SEARCH_RESULT: "morphonavi.SearchResult",
}

OCCUPIED_RGBA = (0.86, 0.2, 0.18, 0.6)
DANGEROUS_RGBA = (0.94, 0.75, 0.12, 0.35)
CANDIDATE_RGBA = (0.84, 0.15, 0.16, 1.0)
REGISTERED_RGBA = (0.16, 0.63, 0.27, 1.0)
KIND_RGBA = {"walk": (0.12, 0.47, 0.71, 1.0), "takeoff": (1.0, 0.5, 0.05, 1.0), "fly": (0.58, 0.4, 0.74, 1.0),
             "land": (0.55, 0.34, 0.29, 1.0)}
LOG_LEVELS = {"info": fm.LogLevel.Info, "success": fm.LogLevel.Info, "warning": fm.LogLevel.Warning,
              "error": fm.LogLevel.Error}


def stamp(ns: int) -> fm.Timestamp:
    """A Foxglove timestamp from nanoseconds since the epoch."""
    return fm.Timestamp(sec=int(ns // 1_000_000_000), nsec=int(ns % 1_000_000_000))


def _pose(translation: Sequence[float], quat_xyzw: Sequence[float]) -> fm.Pose:
    t, q = translation, quat_xyzw
    return fm.Pose(position=fm.Vector3(x=float(t[0]), y=float(t[1]), z=float(t[2])),
                   orientation=fm.Quaternion(x=float(q[0]), y=float(q[1]), z=float(q[2]), w=float(q[3])))


def _yaw_pose(position: Sequence[float], yaw: float) -> fm.Pose:
    return _pose(position, yaw_quat_xyzw(yaw))


def _color(rgba: Sequence[float]) -> fm.Color:
    return fm.Color(r=float(rgba[0]), g=float(rgba[1]), b=float(rgba[2]), a=float(rgba[3]))


def json_bytes(data: Any) -> bytes:
    """Compact JSON (NaN and infinities written as ``null``)."""
    def clean(v: Any) -> Any:
        if isinstance(v, float):
            return v if math.isfinite(v) else None
        if isinstance(v, dict):
            return {str(k): clean(x) for k, x in v.items()}
        if isinstance(v, (list, tuple)):
            return [clean(x) for x in v]
        if isinstance(v, np.ndarray):
            return clean(v.tolist())
        if isinstance(v, np.generic):
            return clean(v.item())
        return v

    return json.dumps(clean(data), separators=(",", ":")).encode("utf-8")


# --- robot -------------------------------------------------------------------------------------------
def robot_messages(snap: RobotSnapshot) -> tuple[fm.PoseInFrame, fm.FrameTransform]:
    """The robot pose as ``PoseInFrame`` (frame ``world``) and the ``world -> robot`` transform."""
    ns = int(round(snap.stamp * 1e9))
    t, q = snap.pose.translation, snap.pose.quaternion
    pose = fm.PoseInFrame(timestamp=stamp(ns), frame_id="world", pose=_pose(t, q))
    tf = fm.FrameTransform(timestamp=stamp(ns), parent_frame_id="world", child_frame_id="robot",
                           translation=fm.Vector3(x=float(t[0]), y=float(t[1]), z=float(t[2])),
                           rotation=fm.Quaternion(x=float(q[0]), y=float(q[1]), z=float(q[2]), w=float(q[3])))
    return pose, tf


def robot_json(snap: RobotSnapshot) -> dict[str, Any]:
    """Everything in a :class:`RobotSnapshot`, pose as ``translation`` [m] + ``quaternion_xyzw``;
    ``pose_age`` [s] is ``null`` while no position was ever known (``inf`` in the snapshot: JSON
    has no infinity)."""
    age = getattr(snap, "pose_age", 0.0)
    return {"translation": list(snap.pose.translation), "quaternion_xyzw": list(snap.pose.quaternion),
            "mode": snap.mode, "armed": snap.armed, "battery": snap.battery, "healthy": snap.healthy,
            "detail": snap.detail, "stamp": snap.stamp, "messages": [list(m) for m in snap.messages],
            "landed": snap.landed, "position_valid": bool(getattr(snap, "position_valid", True)),
            "pose_age": float(age) if math.isfinite(age) else None, "ready": bool(getattr(snap, "ready", True)),
            "readiness": str(getattr(snap, "readiness", "")), "warnings": list(getattr(snap, "warnings", ()))}


# --- capture -----------------------------------------------------------------------------------------
def capture_meta(rec: CaptureRecord) -> dict[str, Any]:
    """The capture's metadata (the ``session.json`` form of :mod:`console.session.capture_files`, no files)."""
    cp, rp = rec.camera_pose, rec.robot_pose
    return {
        "id": rec.id, "intrinsics": rec.intrinsics.to_dict(),
        "camera_pose": {"translation": list(cp.translation), "quaternion_xyzw": list(cp.quaternion)},
        "robot_pose": {"translation": list(rp.translation), "quaternion_xyzw": list(rp.quaternion)},
        "detections": [{"label": d.label, "score": d.score, "bbox": list(d.bbox), "object_id": d.object_id}
                       for d in rec.detections],
        "backend": rec.backend, "timings": dict(rec.timings), "timestamp": rec.timestamp,
    }


def capture_messages(rec: CaptureRecord, jpeg_quality: int = 88) -> list[tuple[str, Any]]:
    """The photo (JPEG), its calibration and the depth (16-bit PNG [mm], 0 = unknown), frame ``camera``."""
    import cv2

    ns = int(round(rec.timestamp * 1e9))
    ok, jpg = cv2.imencode(".jpg", cv2.cvtColor(rec.image, cv2.COLOR_RGB2BGR), [cv2.IMWRITE_JPEG_QUALITY, jpeg_quality])
    if not ok:
        raise ValueError(f"capture {rec.id}: the photo cannot be encoded as JPEG")
    i = rec.intrinsics
    K = [i.fx, 0.0, i.cx, 0.0, i.fy, i.cy, 0.0, 0.0, 1.0]
    out: list[tuple[str, Any]] = [
        (IMAGE, fm.CompressedImage(timestamp=stamp(ns), frame_id="camera", data=jpg.tobytes(), format="jpeg")),
        (CALIBRATION, fm.CameraCalibration(
            timestamp=stamp(ns), frame_id="camera", width=i.width, height=i.height,
            distortion_model="plumb_bob" if i.dist else "", D=[float(d) for d in i.dist],
            K=K, R=[1.0, 0, 0, 0, 1.0, 0, 0, 0, 1.0], P=[i.fx, 0.0, i.cx, 0.0, 0.0, i.fy, i.cy, 0.0, 0.0, 0.0, 1.0, 0.0])),
    ]
    if rec.depth is not None:
        mm = np.clip(np.nan_to_num(rec.depth, nan=0.0, posinf=0.0, neginf=0.0) * 1000.0, 0, 65535).astype(np.uint16)
        ok, png = cv2.imencode(".png", mm)
        if ok:
            out.append((DEPTH, fm.CompressedImage(timestamp=stamp(ns), frame_id="camera", data=png.tobytes(), format="png")))
    t, q = rec.camera_pose.translation, rec.camera_pose.quaternion
    out.append((TF, fm.FrameTransform(timestamp=stamp(ns), parent_frame_id="world", child_frame_id="camera",
                                      translation=fm.Vector3(x=float(t[0]), y=float(t[1]), z=float(t[2])),
                                      rotation=fm.Quaternion(x=float(q[0]), y=float(q[1]), z=float(q[2]), w=float(q[3])))))
    return out


# --- map, grid, paths ------------------------------------------------------------------------------
def map_update(scene: Scene, ns: int, color_of: Any, glb_of: Any, prev_ids: Sequence[str] = ()) -> fm.SceneUpdate:
    """One entity per object: a box of its size, its label, its colour and its proxy model.

    Args:
        color_of: ``label -> (r, g, b)`` in 0..255.
        glb_of: ``label -> bytes | None``: the proxy model (a unit-cube GLB, y-up as glTF says; Foxglove turns glTF models into
            its z-up frame, x = length, y = width, z = up, so the pose is the yaw and the scale ``(l, w, h)``).
        prev_ids: Object ids of the previous update: those gone are deleted.
    """
    ts = stamp(ns)
    ids = {o.id for o in scene.objects}
    deletions = [fm.SceneEntityDeletion(timestamp=ts, type=fm.SceneEntityDeletionType.MatchingId, id=f"object/{i}")
                 for i in prev_ids if i not in ids]
    entities = []
    for o in scene.objects:
        w, h, l = (float(v) for v in o.size)
        rgb = color_of(o.label)
        col = (rgb[0] / 255, rgb[1] / 255, rgb[2] / 255)
        pose = _yaw_pose(o.position, o.yaw)
        glb = glb_of(o.label)
        models = [fm.ModelPrimitive(pose=pose, scale=fm.Vector3(x=l, y=w, z=h), color=_color((*col, 1.0)),
                                    media_type="model/gltf-binary", data=glb)] if glb else []
        top = (o.position[0], o.position[1], o.position[2] + h / 2 + 0.1)
        entities.append(fm.SceneEntity(
            timestamp=ts, frame_id="world", id=f"object/{o.id}", frame_locked=False,
            metadata=[fm.KeyValuePair(key="label", value=o.label), fm.KeyValuePair(key="score", value=f"{o.score:.2f}")],
            cubes=[fm.CubePrimitive(pose=pose, size=fm.Vector3(x=l, y=w, z=h), color=_color((*col, 0.35 if glb else 0.8)))],
            texts=[fm.TextPrimitive(pose=_pose(top, (0, 0, 0, 1)), billboard=True, font_size=14.0, scale_invariant=True,
                                    color=_color((1, 1, 1, 1)), text=f"{o.label} ({o.id})")],
            models=models))
    return fm.SceneUpdate(deletions=deletions, entities=entities)


def grid_update(grid: PlanningGrid, ns: int) -> fm.SceneUpdate:
    """The grid's occupied (red) and dangerous (yellow) cells as cubes, one entity per layer."""
    ws, ts = grid.workspace, stamp(ns)
    entities = []
    for name, state, rgba, frac in (("occupied", CellState.OCCUPIED, OCCUPIED_RGBA, 0.9),
                                    ("dangerous", CellState.DANGEROUS, DANGEROUS_RGBA, 0.5)):
        centres = ws.centers(np.argwhere(grid.state == state))
        s = ws.resolution * frac
        size, col = fm.Vector3(x=s, y=s, z=s), _color(rgba)
        cubes = [fm.CubePrimitive(pose=_pose(c, (0, 0, 0, 1)), size=size, color=col) for c in centres]
        entities.append(fm.SceneEntity(timestamp=ts, frame_id="world", id=f"grid/{name}", cubes=cubes))
    return fm.SceneUpdate(entities=entities)


def _line(points: np.ndarray, rgba: Sequence[float], thickness: float) -> fm.LinePrimitive:
    pts = [fm.Point3(x=float(p[0]), y=float(p[1]), z=float(p[2])) for p in np.asarray(points).reshape(-1, 3)]
    return fm.LinePrimitive(type=fm.LinePrimitiveLineType.LineStrip, pose=_pose((0, 0, 0), (0, 0, 0, 1)),
                            thickness=thickness, scale_invariant=False, points=pts, color=_color(rgba))


def paths_update(route: RouteSnapshot, mission: Mission | None, ns: int) -> fm.SceneUpdate:
    """Candidate (red), registered (green) and mission (coloured per segment kind) lines."""
    ts = stamp(ns)
    cand = [_line(route.candidate, CANDIDATE_RGBA, 0.04)] if route.candidate is not None and len(route.candidate) > 1 else []
    reg = [_line(seg, REGISTERED_RGBA, 0.04) for seg in route.registered if len(seg) > 1]
    mis = [_line(np.asarray(s.waypoints), KIND_RGBA.get(s.kind.value, (1, 1, 1, 1)), 0.06)
           for s in (mission.segments if mission is not None else ()) if len(s.waypoints) > 1]
    return fm.SceneUpdate(entities=[fm.SceneEntity(timestamp=ts, frame_id="world", id=f"paths/{name}", lines=lines)
                                    for name, lines in (("candidate", cand), ("registered", reg), ("mission", mis))])


def route_json(route: RouteSnapshot) -> dict[str, Any]:
    """A :class:`RouteSnapshot` as JSON (world frame [m])."""
    return {"start": list(route.start), "registered": [np.asarray(s).tolist() for s in route.registered],
            "candidate": None if route.candidate is None else np.asarray(route.candidate).tolist(),
            "candidate_goal": None if route.candidate_goal is None else list(route.candidate_goal),
            "goals": [list(g) for g in route.goals]}


def run_json(run: RunStatus) -> dict[str, Any]:
    return {"state": run.state, "segment": run.segment, "fraction": run.fraction, "message": run.message}


def log_message(ns: int, text: str, level: str = "info", name: str = "console") -> fm.Log:
    """An operator action or notice as a ``foxglove.Log`` line."""
    return fm.Log(timestamp=stamp(ns), level=LOG_LEVELS.get(level, fm.LogLevel.Info), message=text, name=name)


def notice_log(ns: int, notice: Notice) -> fm.Log:
    return log_message(ns, f"{notice.title}: {notice.body}", notice.level, "notice")


def session_info(workspace: Any, margin: float, start: Sequence[float], extra: Mapping[str, Any] = ()) -> dict[str, Any]:
    """What replay needs to rebuild the grid: workspace bounds and cell size [m], robot margin [m]."""
    return {"workspace": {"min": list(workspace.min), "max": list(workspace.max), "resolution": workspace.resolution},
            "margin": margin, "start": list(start), **dict(extra)}
