"""Mission log: every console run recorded as MCAP (Foxglove's well-known schemas), off the session lock.

:class:`Recorder` subscribes to the session's announcements (:mod:`console.session.topics`) and only
*observes*: its listener takes a snapshot reference, stamps it and puts it on a queue; a writer
thread turns it into messages (:mod:`console.recording.recording_schemas`) and writes them with the ``mcap``
writer. The session's lock is never held while encoding or writing.

Files: ``<session>/recordings/morphonavi-<UTC time>.mcap``; past ``max_bytes`` a file is finished and
the next part ``...-002.mcap`` starts with the current state written again (stamped with the time of
the switch), so every part opens on its own. Robot state arrives at up to 50 Hz: pose and ``/tf`` are written at most ``pose_hz`` times
a second, the state JSON at most twice a second or when its mode, arming, health or messages change.

The data reach the file every ``FLUSH_S`` seconds at least (the current chunk is ended), so a console
that is killed leaves a file without its footer that ``morphonavi replay --salvage`` still reads up to
the last two seconds. A folder that cannot be created or written, or a full disk, stops the recording
with ONE notice to every operator; the console goes on.

Times are nanoseconds since the epoch (MCAP log time = when the session announced the change).
"""

from __future__ import annotations

import logging
import os
import queue
import threading
import time
from pathlib import Path
from typing import Any, Callable

from pipeline.scene import scene_to_dict

from console.recording import recording_schemas as rs
from console.recording.channel_schemas import schema_bytes
from console.session.session_types import Notice, RobotSnapshot
from console.session.topics import AGENT, CAPTURE, GRID, JOB, MISSION, NOTICE, ROBOT, ROUTE, RUN, SCENE, SEARCH, SELECTION, SETTINGS

log = logging.getLogger(__name__)

RECORDINGS_DIR = "recordings"
MAX_BYTES = 512 * 1024 * 1024  # rotate past this size [bytes]
FLUSH_S = 2.0  # the data reach the file at least this often [s]
QUEUE_SIZE = 4096  # announcements waiting for the writer; robot states are dropped first when full
_STATE_TOPICS = (rs.SESSION_INFO, rs.SCENE_JSON, rs.MAP, rs.GRID, rs.ROUTE_JSON, rs.MISSION_JSON, rs.PATHS,
                 rs.CAPTURE_META, rs.IMAGE, rs.CALIBRATION, rs.DEPTH, rs.PROGRESS, rs.KNOWN_SPACE)
KNOWN = "known_space"  # the session's topic (console.session.known_space_state.KNOWN_SPACE)


class Recorder:
    """Writes one session's changes into MCAP files in ``folder`` (see the module docstring).

    Args:
        session: The :class:`~console.session.session.Session` to observe.
        folder: Where the files go (created); default ``<session folder>/recordings``.
        max_bytes: Size [bytes] past which the next part starts.
        pose_hz: Robot pose / tf messages per second at most.
        state_hz: Robot state JSON messages per second at most (changes of mode etc. always).
        live: A :class:`~console.recording.recording_live.LiveView` that gets every message too (closed with the recorder).
    """

    def __init__(self, session: Any, folder: str | Path | None = None, max_bytes: int = MAX_BYTES,
                 pose_hz: float = 10.0, state_hz: float = 2.0, live: Any = None) -> None:
        if not (isinstance(max_bytes, int) and max_bytes > 0):
            raise ValueError(f"max_bytes: must be a positive whole number of bytes, got {max_bytes!r}")
        for name, hz in (("pose_hz", pose_hz), ("state_hz", state_hz)):
            if not (isinstance(hz, (int, float)) and 0 < hz <= 1000):
                raise ValueError(f"{name}: must be within 0..1000 Hz, got {hz!r}")
        self.session = session
        self.folder = Path(folder) if folder is not None else Path(session.folder) / RECORDINGS_DIR
        self.max_bytes = max_bytes
        self._pose_dt = 1.0 / pose_hz
        self._state_dt = 1.0 / state_hz
        self._queue: queue.Queue[tuple[str, int, Any] | None] = queue.Queue(QUEUE_SIZE)
        self._thread: threading.Thread | None = None
        self._unsubscribe: Callable[[], None] | None = None
        self._last_ns = 0
        self._ns_lock = threading.Lock()
        self._last_pose = -1e18
        self._last_state = -1e18
        self._state_key: Any = None
        self._run_key: Any = None
        self._run_at = -1e18
        self._failed: str | None = None
        self.dropped = 0
        self.live = live
        self.cpu_seconds = 0.0  # CPU spent by the listener and the writer thread [s] (bench/recording_overhead.py)
        self.paths: list[Path] = []
        self.counts: dict[str, int] = {}
        # writer-thread state
        self._writer: Any = None
        self._stream: Any = None
        self._channels: dict[str, int] = {}
        self._latest: dict[str, tuple[int, bytes]] = {}  # state topics: last message, written again in a new part
        self._map_ids: tuple[str, ...] = ()
        self._proxies: Any = None
        self._base = time.strftime("morphonavi-%Y%m%d-%H%M%S", time.gmtime())

    # --- life -------------------------------------------------------------------------------------
    @property
    def failed(self) -> str | None:
        """Why recording stopped, or ``None`` while it works."""
        return self._failed

    def start(self) -> "Recorder":
        """Record the session's current state, then every change, until :meth:`close`."""
        s = self.session
        self._thread = threading.Thread(target=self._run, name="mcap-recorder", daemon=True)
        self._thread.start()
        self._put(rs.SESSION_INFO, rs.session_info(s.workspace, s.margin, s.route_snapshot().start))
        self._put(SCENE, s.scene)
        self._put(GRID, s.grid)
        if getattr(s, "known_space", None) is not None:
            self._put(KNOWN, (s.known_space, s.known_summary()))
        self._put(ROUTE, (s.route_snapshot(), s.mission))
        self._put(MISSION, (s.route_snapshot(), s.mission))
        if s.capture is not None:
            self._put(CAPTURE, s.capture)
        self._put(RUN, s.run)
        if s.robot is not None:
            self._put(ROBOT, (s.robot, True, True))
        self._unsubscribe = s.subscribe(self._on_event)
        return self

    def close(self, timeout: float = 30.0) -> None:
        """Stop listening, write what is queued and finish the file (idempotent)."""
        if self._unsubscribe is not None:
            self._unsubscribe()
            self._unsubscribe = None
        if self._thread is not None:
            self._queue.put(None)
            self._thread.join(timeout)
            self._thread = None
        if self.dropped:
            log.warning("recording: %d robot states dropped (the writer fell behind)", self.dropped)
        if self.live is not None:
            self.live.close()

    # --- listener (runs on the thread that changed the session: cheap) -----------------------------
    def _put(self, topic: str, payload: Any, droppable: bool = False) -> None:
        """Stamp and queue: log times strictly increase in the order the writer sees them."""
        if self._failed is not None:
            return
        with self._ns_lock:
            self._last_ns = max(time.time_ns(), self._last_ns + 1)
            try:
                self._queue.put((topic, self._last_ns, payload), block=not droppable, timeout=5.0)
            except queue.Full:
                self.dropped += 1

    def _on_event(self, topic: str, payload: Any) -> None:
        if self._failed is not None:
            return
        t0 = time.thread_time()
        try:
            self._listen(topic, payload)
        finally:
            self.cpu_seconds += time.thread_time() - t0  # approximate under concurrent announcements

    def _listen(self, topic: str, payload: Any) -> None:
        if topic == ROBOT:
            self._on_robot(payload)
            return
        s = self.session
        if topic == SCENE:
            self._put(SCENE, s.scene)
        elif topic == GRID:
            self._put(GRID, s.grid)
        elif topic == ROUTE:
            self._put(ROUTE, (s.route_snapshot(), s.mission))
        elif topic == MISSION:
            self._put(MISSION, (s.route_snapshot(), s.mission))
        elif topic == RUN:
            key = (payload.state, payload.segment, payload.message)
            now = time.monotonic()
            if key != self._run_key or now - self._run_at >= 0.5:  # progress alone: at most 2 Hz
                self._run_key, self._run_at = key, now
                self._put(RUN, payload)
        elif topic in (CAPTURE, NOTICE, AGENT, SEARCH):
            self._put(topic, payload)
        elif topic == KNOWN:
            self._put(KNOWN, (s.known_space, payload))
        elif topic == JOB and payload is not None and not payload.running:
            self._put(JOB, payload)
        elif topic == SELECTION:
            self._put(rs.LOG, f"selected {payload}" if payload else "selection cleared")
        elif topic == SETTINGS:
            st = s.settings
            self._put(rs.LOG, f"settings: goals on {st.goal_mode}"
                      + (f" at {st.altitude:.2f} m" if st.goal_mode == "altitude" else "")
                      + f", click adds goals: {'on' if st.click_to_goal else 'off'}")

    def _on_robot(self, snap: RobotSnapshot) -> None:
        now = time.monotonic()
        key = (snap.mode, snap.armed, snap.healthy, snap.detail, snap.messages[-1:] if snap.messages else (), snap.landed,
               snap.position_valid, snap.ready, snap.readiness, snap.warnings)
        pose_due = now - self._last_pose >= self._pose_dt
        state_due = now - self._last_state >= self._state_dt or key != self._state_key
        if not (pose_due or state_due):
            return
        if pose_due:
            self._last_pose = now
        if state_due:
            self._last_state, self._state_key = now, key
        self._put(ROBOT, (snap, pose_due, state_due), droppable=True)

    # --- writer thread ------------------------------------------------------------------------------
    def _run(self) -> None:
        flushed = time.monotonic()
        while True:
            try:
                item = self._queue.get(timeout=FLUSH_S)
            except queue.Empty:
                item = ()
            if item is None:
                break
            if self._failed is not None:
                continue
            t0 = time.thread_time()
            try:
                if item:
                    self._write_item(*item)
                    self._maybe_rotate()
                if self._writer is not None and time.monotonic() - flushed >= FLUSH_S:
                    self._writer.flush()  # end the chunk: a killed console loses at most FLUSH_S of log
                    self._stream.flush()
                    flushed = time.monotonic()
            except OSError as exc:
                self._fail(f"cannot write {self._current()}: {exc.strerror or exc}")
            except Exception as exc:  # an encoding bug must not take the console down
                what = item[0] if item else "the file"
                log.exception("recording: could not record %s", what)
                self._fail(f"could not record {what}: {exc}")
            finally:
                self.cpu_seconds += time.thread_time() - t0
        try:
            self._finish()
        except OSError as exc:
            self._fail(f"cannot finish {self._current()}: {exc.strerror or exc}")

    def _current(self) -> Path:
        return self.paths[-1] if self.paths else self.folder

    def _fail(self, why: str) -> None:
        if self._failed is not None:
            return
        self._failed = why
        log.warning("recording stopped: %s", why)
        try:
            if self._stream is not None:
                self._stream.close()
        except OSError:
            pass
        self._writer, self._stream = None, None
        self.session.notify("Recording stopped", f"{why}. The console goes on without a mission log.", "warning")

    def _open(self) -> None:
        from mcap.writer import CompressionType, Writer

        self.folder.mkdir(parents=True, exist_ok=True)
        n = len(self.paths) + 1
        for extra in range(100):  # never overwrite: another run in the same second gets another name
            base = self._base if extra == 0 else f"{self._base}.{extra}"
            path = self.folder / (f"{base}.mcap" if n == 1 else f"{base}-{n:03d}.mcap")
            try:
                self._stream = open(path, "xb")  # noqa: SIM115 (closed by _finish / _fail)
                break
            except FileExistsError:
                continue
        else:
            raise FileExistsError(f"{self.folder}: too many recordings named {self._base}*")
        self._base = base
        self.paths.append(path)
        chunk = max(4096, min(1 << 20, self.max_bytes // 4))  # data reach the file chunk by chunk: rotate on time
        self._writer = Writer(self._stream, chunk_size=chunk, compression=CompressionType.LZ4)
        self._writer.start(profile="", library="morphonavi (mcap + foxglove-sdk schemas)")
        self._channels = {}
        log.info("recording the session to %s", path)

    def _channel(self, topic: str) -> int:
        cid = self._channels.get(topic)
        if cid is None:
            if topic in rs.FOXGLOVE_TYPES:
                schema = rs.FOXGLOVE_TYPES[topic].get_schema()
                sid = self._writer.register_schema(schema.name, schema.encoding, bytes(schema.data))
                cid = self._writer.register_channel(topic, "protobuf", sid)
            else:
                sid = self._writer.register_schema(rs.JSON_TOPICS[topic], "jsonschema", schema_bytes(topic))
                cid = self._writer.register_channel(topic, "json", sid)
            self._channels[topic] = cid
        return cid

    def _emit(self, topic: str, ns: int, data: bytes, live: bool = True) -> None:
        if live and self.live is not None:
            self.live.log(topic, ns, data)
        if self._writer is None:
            self._open()
        self._writer.add_message(self._channel(topic), log_time=ns, data=data, publish_time=ns)
        self.counts[topic] = self.counts.get(topic, 0) + 1
        if topic in _STATE_TOPICS:
            self._latest[topic] = (ns, data)

    def _encode(self, topic: str, ns: int, msg: Any) -> None:
        self._emit(topic, ns, msg.encode() if topic in rs.FOXGLOVE_TYPES else rs.json_bytes(msg))

    def _write_item(self, topic: str, ns: int, payload: Any) -> None:  # noqa: C901 (one branch per topic)
        if topic == ROBOT:
            snap, pose_due, state_due = payload
            if pose_due and snap.position_status != "unknown":  # no pose known: not drawn as one (the state says so)
                pose, tf = rs.robot_messages(snap)
                self._encode(rs.POSE, ns, pose)
                self._encode(rs.TF, ns, tf)
            if state_due:
                self._encode(rs.ROBOT_STATE, ns, rs.robot_json(snap))
        elif topic == rs.SESSION_INFO:
            self._encode(rs.SESSION_INFO, ns, payload)
        elif topic == SCENE:
            self._encode(rs.SCENE_JSON, ns, scene_to_dict(payload))
            proxies = self._proxy_models()
            self._encode(rs.MAP, ns, rs.map_update(payload, ns, proxies.color, proxies.glb, self._map_ids))
            self._map_ids = tuple(o.id for o in payload.objects)
            self._encode(rs.LOG, ns, rs.log_message(ns, f"map: {len(payload.objects)} objects", name="map"))
        elif topic == GRID:
            self._encode(rs.GRID, ns, rs.grid_update(payload, ns))
        elif topic in (ROUTE, MISSION):
            route, mission = payload
            if topic == ROUTE:
                self._encode(rs.ROUTE_JSON, ns, rs.route_json(route))
            else:
                self._encode(rs.MISSION_JSON, ns, {"mission": None if mission is None else mission.to_dict()})
                if mission is not None:
                    self._encode(rs.LOG, ns, rs.log_message(ns, f"mission {mission.id} built: {mission.summary()}", name="operator"))
            self._encode(rs.PATHS, ns, rs.paths_update(route, mission, ns))
        elif topic == CAPTURE:
            self._encode(rs.CAPTURE_META, ns, rs.capture_meta(payload))
            for t, msg in rs.capture_messages(payload):
                self._encode(t, ns, msg)
            self._encode(rs.LOG, ns, rs.log_message(ns, f"capture {payload.id}: {len(payload.detections)} detections "
                                                    f"({payload.backend})", name="operator"))
        elif topic == KNOWN:  # the grid itself (compact JSON form) and what it holds
            space, summary = payload
            self._encode(rs.KNOWN_SPACE, ns, {
                "known_space": None if space is None else space.to_dict(), "free": summary.free,
                "occupied": summary.occupied, "unknown": summary.unknown, "unlabelled": summary.unlabelled,
                "plan_unknown": summary.policy})
        elif topic == RUN:
            self._encode(rs.PROGRESS, ns, rs.run_json(payload))
            self._encode(rs.LOG, ns, rs.log_message(ns, f"mission {payload.state}: {payload.message}", name="mission"))
        elif topic == JOB:
            level = "error" if payload.error else "info"
            self._encode(rs.LOG, ns, rs.log_message(ns, f"{payload.name}: {payload.error or payload.message}", level, "job"))
        elif topic == NOTICE:
            self._encode(rs.LOG, ns, rs.notice_log(ns, payload if isinstance(payload, Notice) else Notice("", str(payload))))
        elif topic == rs.LOG:
            self._encode(rs.LOG, ns, rs.log_message(ns, str(payload), name="operator"))
        elif topic == AGENT:  # console.mcp: the event as JSON, and a log line replay lists
            self._encode(rs.AGENT_EVENTS, ns, payload)
            self._encode(rs.LOG, ns, rs.log_message(ns, str(payload.get("text", "")), payload.get("level", "info"), "agent"))
        elif topic == SEARCH:  # console.session.search_report: a step, or the end (it has "found")
            end = "found" in payload
            self._encode(rs.SEARCH_RESULT if end else rs.SEARCH_STEP, ns, payload)
            text = f"ended: {payload.get('reason', '')}" if end else str(payload.get("text", ""))
            self._encode(rs.LOG, ns, rs.log_message(ns, f"search: {text}", name="search"))

    def _proxy_models(self) -> Any:
        if self._proxies is None:
            from console.views.objects_view import ProxyModels

            self._proxies = ProxyModels()
        return self._proxies

    def _maybe_rotate(self) -> None:
        if self._stream is None or self._stream.tell() < self.max_bytes:
            return
        self._finish()
        self._open()
        now = max(ns for ns, _ in self._latest.values())
        for topic in _STATE_TOPICS:  # the new part opens on its own: the current state first, stamped now
            if topic in self._latest:
                self._emit(topic, now, self._latest[topic][1], live=False)

    def _finish(self) -> None:
        if self._writer is not None:
            writer, stream = self._writer, self._stream
            self._writer = self._stream = None
            try:
                writer.finish()
                stream.flush()
                os.fsync(stream.fileno())
            finally:
                stream.close()


def start_recording(session: Any, folder: str | Path | None = None, foxglove_port: int | None = None,
                    **options: Any) -> Recorder:
    """Start a :class:`Recorder` on ``session`` (stop it with its ``close``).

    ``foxglove_port``: also serve the topics live over the Foxglove WebSocket protocol on
    127.0.0.1 (:mod:`console.recording.recording_live`); ``OSError`` if the port is taken.
    """
    live = None
    if foxglove_port is not None:
        from console.recording.recording_live import LiveView

        live = LiveView(foxglove_port)
    return Recorder(session, folder, live=live, **options).start()
