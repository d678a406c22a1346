"""Read a MorphoNavi MCAP recording (:mod:`console.recording.recording`) back: the session state at any time.

:class:`Recording` reads a file once (the small state messages decoded, photos kept as bytes until
shown) and answers :meth:`Recording.state_at` with what the console showed at that time: scene,
route, mission, last capture, robot, mission progress and the recent log lines. A missing file, a
file that is not MCAP, a truncated or corrupt one, or an MCAP file that is not a MorphoNavi
recording raises :class:`ReplayError` with what is wrong. With ``salvage`` a truncated or corrupt
file is read chunk by chunk instead (:mod:`console.recording.salvage`): what is readable is replayed
and :attr:`Recording.salvage_note` says what was lost (``2 of 40 chunks unreadable: 12.3 s of 95.0 s lost``).

Times are nanoseconds since the epoch (the MCAP log times); frames as in :mod:`console.recording.recording_schemas`.
"""

from __future__ import annotations

import bisect
import json
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from pipeline.camera.geometry import Intrinsics, Pose
from pipeline.scene import Scene, scene_from_dict
from planner.grid import Workspace
from planner.mission import Mission

from console.recording import recording_schemas as rs
from console.session.session_types import CaptureRecord, Detection, RobotSnapshot, RouteSnapshot, RunStatus

MCAP_MAGIC = b"\x89MCAP0\r\n"


class ReplayError(ValueError):
    """A recording that cannot be replayed; the message says which file and why."""


@dataclass(frozen=True)
class ReplayInfo:
    """What the recorded console was set to: planning workspace, robot margin [m], route start (world)."""

    workspace: Workspace
    margin: float
    start: tuple[float, float, float]


@dataclass(frozen=True)
class ReplayState:
    """The session as recorded at ``time`` [ns]; each part is ``None`` before it was first recorded.

    ``versions`` holds, per part, the log time of the message it comes from (to tell what changed).
    ``search`` holds the steps (``/search/step`` records) of the search under way or last ended at that time,
    and ``search_result`` its end (``/search/result``) once it has ended.
    """

    time: int
    scene: Scene
    route: RouteSnapshot | None
    mission: Mission | None
    capture: CaptureRecord | None
    robot: RobotSnapshot | None
    run: RunStatus
    log: tuple[tuple[int, str], ...]
    versions: dict[str, int]
    search: tuple[dict[str, Any], ...] = ()
    search_result: dict[str, Any] | None = None


class _Track:
    """Messages of one topic in time order: ``(log time [ns], payload)``."""

    def __init__(self) -> None:
        self.times: list[int] = []
        self.items: list[Any] = []

    def add(self, ns: int, item: Any) -> None:
        self.times.append(ns)
        self.items.append(item)

    def at(self, ns: int) -> tuple[int, Any] | None:
        i = bisect.bisect_right(self.times, ns) - 1
        return (self.times[i], self.items[i]) if i >= 0 else None


def _pose(d: Any, where: str) -> Pose:
    try:
        t, q = d["translation"], d["quaternion_xyzw"]
        return Pose((float(t[0]), float(t[1]), float(t[2])), (float(q[0]), float(q[1]), float(q[2]), float(q[3])))
    except (KeyError, TypeError, ValueError, IndexError) as exc:
        raise ReplayError(f"{where}: not a pose ({exc})") from None


def _route(d: Any) -> RouteSnapshot:
    def arr(v: Any) -> np.ndarray:
        return np.asarray(v, dtype=np.float64).reshape(-1, 3)

    return RouteSnapshot(tuple(float(v) for v in d["start"]), tuple(arr(s) for s in d["registered"]),  # type: ignore[arg-type]
                         None if d["candidate"] is None else arr(d["candidate"]),
                         None if d["candidate_goal"] is None else tuple(float(v) for v in d["candidate_goal"]),  # type: ignore[arg-type]
                         tuple(tuple(float(v) for v in g) for g in d["goals"]))  # type: ignore[arg-type]


def _robot(d: Any, pose: Pose | None) -> RobotSnapshot:
    if d["landed"] is not None and not isinstance(d["landed"], bool):
        raise ValueError(f"landed: must be true, false or null, got {d['landed']!r}")
    return RobotSnapshot(pose=pose if pose is not None else _pose(d, "/robot/state"), mode=str(d["mode"]),
                         armed=bool(d["armed"]), battery=None if d["battery"] is None else float(d["battery"]),
                         healthy=bool(d["healthy"]), detail=str(d["detail"]), stamp=float(d["stamp"]),
                         messages=tuple((int(n), str(t)) for n, t in d["messages"]), landed=d["landed"],
                         **_trust(d))


def _trust(d: Any) -> dict[str, Any]:
    """Position validity, readiness and warnings of a ``/robot/state`` record (absent in older
    recordings: valid and ready); ``pose_age`` ``null`` means no position was ever known (inf)."""
    age = d.get("pose_age", 0.0)
    if age is not None and (isinstance(age, bool) or not isinstance(age, (int, float)) or not age >= 0):
        raise ValueError(f"pose_age: must be a number >= 0 or null, got {age!r}")
    for key in ("position_valid", "ready"):
        if not isinstance(d.get(key, True), bool):
            raise ValueError(f"{key}: must be true or false, got {d[key]!r}")
    return {"position_valid": d.get("position_valid", True), "pose_age": float("inf") if age is None else float(age),
            "ready": d.get("ready", True), "readiness": str(d.get("readiness", "")),
            "warnings": tuple(str(w) for w in d.get("warnings", ()))}


class Recording:
    """A recording read into memory (see the module docstring).

    Args:
        path: The ``.mcap`` file, or the parts of one rotated run in order (``run.mcap``,
            ``run-002.mcap``, ...), read as one timeline.
        salvage: Read a file without its footer (a console that was killed) up to where it ends, and
            a corrupt file chunk by chunk, skipping the chunks that cannot be read, instead of refusing
            it; :attr:`salvaged` tells whether that happened and :attr:`salvage_note` what was lost.
    """

    def __init__(self, path: str | Path | Sequence[str | Path], salvage: bool = False) -> None:
        self.paths = [Path(path)] if isinstance(path, (str, Path)) else [Path(p) for p in path]
        if not self.paths:
            raise ReplayError("no recording given")
        self.salvage = salvage
        self.salvaged = False
        self.salvage_reports: list[tuple[Path, Any]] = []  # (file, SalvageReport) of every salvaged part
        self.lost_settings = False  # the session's settings were in a lost chunk: default workspace shown
        self._tracks: dict[str, _Track] = {}
        self.info: ReplayInfo | None = None
        self._capture_cache: tuple[int, CaptureRecord] | None = None
        for self.path in self.paths:  # errors name the file being read
            self._read()
        self.path = self.paths[0]
        for tr in self._tracks.values():  # parts overlap where a part re-states the state it starts with
            order = sorted(range(len(tr.times)), key=tr.times.__getitem__)
            tr.times, tr.items = [tr.times[i] for i in order], [tr.items[i] for i in order]
        if self.info is None:
            if self.salvaged and any(tr.times for tr in self._tracks.values()):
                # the chunk holding the session's settings is lost, the rest is not: replay it in the
                # console's default workspace, and say so
                self.info = ReplayInfo(Workspace(), 0.35, (2.5, 0.7, 0.0))
                self.lost_settings = True
            elif self.salvaged:
                raise ReplayError(f"{self.path}: truncated before its first MorphoNavi message: nothing to salvage")
            else:
                raise ReplayError(f"{self.path}: not a MorphoNavi recording (no {rs.SESSION_INFO} message)")
        all_times = [t for tr in self._tracks.values() for t in tr.times]
        self.start, self.end = min(all_times), max(all_times)

    @property
    def salvage_note(self) -> str:
        """What a salvage read lost, for the operator (``""`` when nothing was salvaged)."""
        if len(self.salvage_reports) == 1:
            note = self.salvage_reports[0][1].summary()
        else:
            note = "; ".join(f"{p.name}: {r.summary()}" for p, r in self.salvage_reports)
        if self.lost_settings:
            note += "; the session's settings were lost with them: shown in the default workspace"
        return note

    @property
    def duration(self) -> float:
        """Length of the recording [s]."""
        return (self.end - self.start) / 1e9

    def count(self, topic: str) -> int:
        tr = self._tracks.get(topic)
        return len(tr.times) if tr is not None else 0

    def times(self, topic: str) -> list[int]:
        """Log times [ns] of a topic's messages."""
        tr = self._tracks.get(topic)
        return list(tr.times) if tr is not None else []

    # --- reading -------------------------------------------------------------------------------------
    def _read(self) -> None:
        p = self.path
        if not p.exists():
            raise ReplayError(f"{p}: no such file")
        if not p.is_file():
            raise ReplayError(f"{p}: not a file")
        try:
            with open(p, "rb") as f:
                head = f.read(len(MCAP_MAGIC))
                if head != MCAP_MAGIC:
                    raise ReplayError(f"{p}: not an MCAP file (it does not start with the MCAP magic bytes)")
                size = p.stat().st_size
                if size >= 2 * len(MCAP_MAGIC):
                    f.seek(size - len(MCAP_MAGIC))
                if size < 2 * len(MCAP_MAGIC) or f.read(len(MCAP_MAGIC)) != MCAP_MAGIC:
                    if not self.salvage:
                        from console.session.session_lock import holder

                        pid = holder(p.resolve().parent.parent) if p.resolve().parent.name == "recordings" else None
                        if pid is not None:
                            who = f"PID {pid}" if pid else "its PID unknown"
                            raise ReplayError(f"{p}: still being written by the running console ({who}): stop that "
                                              "console to replay the whole run, or --salvage to replay it up to "
                                              "its last two seconds")
                        raise ReplayError(f"{p}: truncated (no MCAP footer): the recording was not finished, e.g. the "
                                          "console was killed or the disk filled up; --salvage reads what it holds")
                    self._salvage(f)
                else:
                    from mcap.reader import make_reader

                    f.seek(0)
                    try:  # read whole before use: a corrupt chunk half-way must not leave half a timeline
                        # chunk CRCs checked: a flipped byte that LZ4 decodes silently is still caught
                        messages = list(make_reader(f, validate_crcs=True).iter_messages(log_time_order=True))
                    except Exception as exc:  # the mcap reader's errors for a corrupt file have no common base
                        if not self.salvage:
                            raise ReplayError(f"{p}: corrupt MCAP file ({type(exc).__name__}: {exc}); --salvage "
                                              "replays what is readable and says what was lost") from None
                        self._salvage(f)
                    else:
                        self._read_messages(messages)
        except ReplayError:
            raise
        except OSError as exc:
            raise ReplayError(f"{p}: cannot read: {exc.strerror or exc}") from None
        except Exception as exc:  # the mcap reader's errors for a corrupt file have no common base
            raise ReplayError(f"{p}: corrupt MCAP file ({type(exc).__name__}: {exc})") from None

    def _salvage(self, f: Any) -> None:
        """Read ``f`` chunk by chunk, keeping what is readable (:func:`console.recording.salvage.salvage`)."""
        from console.recording.salvage import salvage

        messages, report = salvage(f)
        self.salvaged = True
        self.salvage_reports.append((self.path, report))
        self._read_messages(messages)

    def _read_messages(self, messages: Any) -> None:
        from mcap_protobuf.decoder import DecoderFactory

        decoders: dict[int, Any] = {}
        factory = DecoderFactory()
        for schema, channel, message in messages:
            topic, ns, data = channel.topic, message.log_time, message.data
            where = f"{topic} at {ns} ns"
            if channel.message_encoding == "json":
                try:
                    value = json.loads(data)
                except ValueError as exc:
                    raise ReplayError(f"{self.path}: {where}: not JSON ({exc})") from None
                item = self._parse_json(topic, value, where)
            elif topic in (rs.POSE, rs.IMAGE, rs.DEPTH, rs.LOG):
                if schema is None:
                    raise ReplayError(f"{self.path}: {where}: no schema")
                dec = decoders.setdefault(channel.id, factory.decoder_for(channel.message_encoding, schema))
                if dec is None:
                    raise ReplayError(f"{self.path}: {where}: cannot decode {channel.message_encoding}")
                msg = dec(data)
                if topic == rs.POSE:
                    p, q = msg.pose.position, msg.pose.orientation
                    item = Pose((p.x, p.y, p.z), (q.x, q.y, q.z, q.w))
                elif topic == rs.LOG:
                    item = msg.message
                else:
                    item = bytes(msg.data)
            else:
                continue  # the Foxglove-only views (map, grid, paths, tf, calibration) are rebuilt from state
            if topic == rs.SESSION_INFO:
                self.info = item
            self._tracks.setdefault(topic, _Track()).add(ns, item)

    def _parse_json(self, topic: str, v: Any, where: str) -> Any:
        try:
            if topic == rs.SESSION_INFO:
                w = v["workspace"]
                ws = Workspace(tuple(float(x) for x in w["min"]), tuple(float(x) for x in w["max"]),  # type: ignore[arg-type]
                               float(w["resolution"]))
                s = v["start"]
                return ReplayInfo(ws, float(v["margin"]), (float(s[0]), float(s[1]), float(s[2])))
            if topic == rs.SCENE_JSON:
                return scene_from_dict(v)
            if topic == rs.ROUTE_JSON:
                return _route(v)
            if topic == rs.MISSION_JSON:
                return None if v["mission"] is None else Mission.from_dict(v["mission"])
            if topic == rs.ROBOT_STATE:
                return _robot(v, None)
            if topic in (rs.SEARCH_STEP, rs.SEARCH_RESULT) and not (isinstance(v, dict)
                                                                   and isinstance(v.get("search_id"), str)):
                raise ValueError("not a search record (no search_id)")
            if topic == rs.PROGRESS:
                return RunStatus(str(v["state"]), None if v["segment"] is None else int(v["segment"]),
                                 float(v["fraction"]), str(v["message"]))
            return v
        except ReplayError:
            raise
        except Exception as exc:
            raise ReplayError(f"{self.path}: {where}: malformed ({type(exc).__name__}: {exc})") from None

    # --- state at a time -------------------------------------------------------------------------------
    def _at(self, topic: str, ns: int) -> tuple[int, Any] | None:
        tr = self._tracks.get(topic)
        return tr.at(ns) if tr is not None else None

    def _capture(self, ns: int, meta: dict[str, Any]) -> CaptureRecord:
        if self._capture_cache is not None and self._capture_cache[0] == ns:
            return self._capture_cache[1]
        import cv2

        where = f"{rs.CAPTURE_META} at {ns} ns"
        image = self._at(rs.IMAGE, ns)
        if image is None or image[0] != ns:
            raise ReplayError(f"{self.path}: {where}: its photo is missing")
        bgr = cv2.imdecode(np.frombuffer(image[1], np.uint8), cv2.IMREAD_COLOR)
        if bgr is None:
            raise ReplayError(f"{self.path}: {where}: the photo is not a readable JPEG")
        depth = None
        d = self._at(rs.DEPTH, ns)
        if d is not None and d[0] == ns:
            mm = cv2.imdecode(np.frombuffer(d[1], np.uint8), cv2.IMREAD_UNCHANGED)
            if mm is not None:
                depth = mm.astype(np.float32) / 1000.0
                depth[mm == 0] = np.nan
        try:
            i = meta["intrinsics"]
            rec = CaptureRecord(
                id=str(meta["id"]), image=cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB),
                intrinsics=Intrinsics(float(i["fx"]), float(i["fy"]), float(i["cx"]), float(i["cy"]),
                                      int(i["width"]), int(i["height"])),
                camera_pose=_pose(meta["camera_pose"], where), robot_pose=_pose(meta["robot_pose"], where),
                detections=tuple(Detection(str(x["label"]), float(x["score"]), tuple(float(b) for b in x["bbox"]),  # type: ignore[arg-type]
                                           x.get("object_id")) for x in meta["detections"]),
                depth=depth, backend=str(meta.get("backend", "")),
                timings={str(k): float(t) for k, t in (meta.get("timings") or {}).items()},
                timestamp=float(meta["timestamp"]))
        except ReplayError:
            raise
        except Exception as exc:
            raise ReplayError(f"{self.path}: {where}: malformed ({type(exc).__name__}: {exc})") from None
        self._capture_cache = (ns, rec)
        return rec

    def state_at(self, ns: int, log_lines: int = 8) -> ReplayState:
        """The session as it was at ``ns`` (clamped to the recording) and the last ``log_lines`` log lines."""
        ns = min(max(int(ns), self.start), self.end)
        versions: dict[str, int] = {}

        def get(topic: str) -> Any:
            hit = self._at(topic, ns)
            if hit is None:
                return None
            versions[topic] = hit[0]
            return hit[1]

        scene = get(rs.SCENE_JSON) or Scene()
        meta = get(rs.CAPTURE_META)
        capture = self._capture(versions[rs.CAPTURE_META], meta) if meta is not None else None
        robot, pose = get(rs.ROBOT_STATE), get(rs.POSE)
        if robot is not None and pose is not None and versions[rs.POSE] > versions[rs.ROBOT_STATE]:
            robot = replace(robot, pose=pose)  # the pose is written more often than the rest of the state
        logs = self._tracks.get(rs.LOG)
        lines: tuple[tuple[int, str], ...] = ()
        if logs is not None:
            i = bisect.bisect_right(logs.times, ns)
            lines = tuple(zip(logs.times[max(0, i - log_lines):i], logs.items[max(0, i - log_lines):i]))
        steps, result = self._search_at(ns, versions)
        return ReplayState(ns, scene, get(rs.ROUTE_JSON), get(rs.MISSION_JSON), capture, robot,
                           get(rs.PROGRESS) or RunStatus(), lines, versions, steps, result)

    def _search_at(self, ns: int, versions: dict[str, int]) -> tuple[tuple[dict[str, Any], ...], dict[str, Any] | None]:
        """The steps of the search last stepped at ``ns`` and its result if it has ended by then."""
        tr = self._tracks.get(rs.SEARCH_STEP)
        i = bisect.bisect_right(tr.times, ns) if tr is not None else 0
        if tr is None or i == 0:
            return (), None
        versions[rs.SEARCH_STEP] = tr.times[i - 1]
        sid = tr.items[i - 1].get("search_id")
        steps = tuple(x for x in tr.items[:i] if x.get("search_id") == sid)
        res = self._tracks.get(rs.SEARCH_RESULT)
        j = bisect.bisect_right(res.times, ns) if res is not None else 0
        if res is not None and j > 0 and res.items[j - 1].get("search_id") == sid:
            versions[rs.SEARCH_RESULT] = res.times[j - 1]
            return steps, res.items[j - 1]
        return steps, None
