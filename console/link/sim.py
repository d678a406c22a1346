"""The built-in simulated robot: kinematic, time-based, with a rendered camera.

The robot lives in a hidden ground-truth world (default: the paper's room, see
:mod:`console.link.world`) that the operator only learns about by mapping its photos. It walks,
takes off, flies and lands at configurable speeds and rates, in simulated time that can run
faster than the wall clock (``time_scale``). It rehearses like a real robot: a segment is never
refused up front because of a hidden object; the robot moves until its body would touch one
(:mod:`~console.link.sim_contact`), or a wall or the ceiling of its ``room``, and stops there,
failing the segment with "contact with an unmapped obstacle ahead at (x, y, z)" (never the object's
name, class or extent); a landing that meets an object's top face touches down on it (or stops there,
"contact below", when the face is too small to stand on). Its battery failsafes (critical: land;
empty: come down and disarm) are in :mod:`~console.link.sim_battery`. It never leaves
the workspace (the safety net; checked up front). Its camera renders the hidden world from
the robot's camera pose (RGB + ground-truth depth and instance masks), or serves real photos from
a ``--captures`` folder.

Frames: world (z up) [m]; yaw about +z [rad]; the camera mount is in the robot body frame
(x forward, y left, z up). States are published at ``SimConfig.rate`` Hz (>= 20).

This module is :class:`SimRobot` (the link: connection, clock, faults, state stream, commands and
the running of phases); its settings are in :mod:`~console.link.sim_config` (re-exported here),
the segment -> phases plan in :mod:`~console.link.sim_motion` and the capture of renders / folder
photos in :mod:`~console.link.sim_camera`.
"""

from __future__ import annotations

import logging
import math
import threading
import time
from dataclasses import replace
from pathlib import Path
from typing import Sequence

import numpy as np

from pipeline.camera.geometry import CameraMount, Intrinsics, Pose, camera_pose_in_world
from pipeline.scene import Scene
from planner.mission import MissionSegment

from console.link.base import CaptureResult, LinkError, Mode, RobotLink, RobotState, RunStatus, SegmentRun
from console.link.captures import CapturesFolder
from console.link.sim_battery import SimBattery
from console.link.render import SceneRenderer
from console.link.sim_camera import folder_capture, render_capture
from console.link.sim_config import DEFAULT_INTRINSICS, DEFAULT_MOUNT, SimConfig
from console.link.sim_contact import BodyContact, contact_below_text, contact_text
from console.link.sim_motion import Phase, path_length, plan_segment, verb, wrap_angle
from console.link.world import DEFAULT_START, ROOM_MAX, ROOM_MIN, paper_room

log = logging.getLogger(__name__)

MESSAGES_KEPT = 5  # status messages carried by each state sample
_STEP = 0.05  # [m] longest straight move checked against the occupancy at once


class SimRobot(SimBattery, RobotLink):
    """A simulated aerial-ground robot in a hidden world.

    Args:
        world: The hidden ground-truth scene (world frame); default :func:`paper_room`.
        start: ``world <- robot`` start pose (upright; only x, y, z and yaw are used).
        config: Speeds, rates and time scale.
        intrinsics: The camera's intrinsics (renders have this size).
        mount: The camera on the robot (robot body frame).
        captures: A folder of real photos to serve instead of renders (``--captures``).
        room: Room shell around the world ``(min, max)`` [m]: drawn in the renders, and its walls and
            ceiling stop the body like an object (``None``: no shell, no walls).
        min_visible_pixels: Objects covering fewer pixels are left out of the ground truth's
            visible list (slivers behind other objects); their mask pixels stay in ``instances``.
        manual_clock: Do not run a clock thread: time only advances through :meth:`step`
            (deterministic tests, or a caller that owns the clock). States are published per step.
    """

    def __init__(self, world: Scene | None = None, start: Pose = DEFAULT_START,
                 config: SimConfig = SimConfig(), intrinsics: Intrinsics = DEFAULT_INTRINSICS,
                 mount: CameraMount = DEFAULT_MOUNT, captures: str | Path | CapturesFolder | None = None,
                 room: tuple[Sequence[float], Sequence[float]] | None = (ROOM_MIN, ROOM_MAX),
                 min_visible_pixels: int = 50, manual_clock: bool = False) -> None:
        super().__init__()
        self.world = paper_room() if world is None else world
        self.config = config
        self.intrinsics = intrinsics
        self.mount = mount
        self.room = room
        # a folder of photos, or any photo source with next() -> FolderPhoto (a live camera)
        self.captures = (captures if captures is None or hasattr(captures, "next")
                         else CapturesFolder(captures))
        self._contact = BodyContact(self.world.objects, config.body_radius, config.body_height, room)
        x, y, z = (float(v) for v in start.translation)
        self._pos = np.array([x, y, max(z, config.workspace.floor)])
        self._yaw = start.yaw
        self._vel = np.zeros(3)
        self._check_free(self._pos, "the start")
        self._floor = config.workspace.floor
        self._landed = bool(self._pos[2] <= self._floor + 1e-6)
        self._armed = not self._landed
        self._battery = 1.0
        self._sim_time = 0.0
        self._run: SegmentRun | None = None
        self._phases: list[Phase] = []
        self._progress_total = 0.0
        self._progress_done = 0.0
        self._link_down_until = -1.0
        self._link_lost_at = 0.0
        self._self_landing = False
        self._battery_landing = False  # the battery failsafe acted (once per flight)
        self._frozen: RobotState | None = None
        self._messages: list[tuple[int, str]] = []  # (number, "SEVERITY: text"), newest last
        self._n_messages = 0
        self._lock = threading.RLock()
        self._render_lock = threading.Lock()
        self._renderer: SceneRenderer | None = None
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self._shots = 0
        self.manual_clock = manual_clock
        self.min_visible_pixels = int(min_visible_pixels)
        self._manual_connected = False

    # --- connection ------------------------------------------------------------------------------
    @property
    def description(self) -> str:
        cam = f"photos from {self.captures.folder}" if self.captures else "rendered camera"
        return f"simulated robot (hidden world, {cam})"

    @property
    def connected(self) -> bool:
        if self.manual_clock:
            return self._manual_connected
        return self._thread is not None and self._thread.is_alive()

    def connect(self, timeout: float = 10.0) -> None:
        if self.connected:
            return
        if self.manual_clock:
            self._manual_connected = True
            self._stream.publish(self._state())
            return
        self._stop.clear()
        self._thread = threading.Thread(target=self._loop, name="sim-robot", daemon=True)
        self._thread.start()
        deadline = time.monotonic() + timeout
        while self.latest_state() is None:
            if time.monotonic() > deadline:
                raise LinkError("the simulated robot did not start")
            time.sleep(0.002)

    def close(self) -> None:
        self._manual_connected = False
        self._stop.set()
        t = self._thread
        if t is not None and t.is_alive():  # a close racing a background connect: not started yet
            t.join(timeout=2.0)
        with self._lock:
            if self._run is not None:
                self._run.finish(RunStatus.ABORTED, "link closed")
                self._run = None
            self._phases = []

    @property
    def sim_time(self) -> float:
        """Simulated time since the start [s]."""
        with self._lock:
            return self._sim_time

    # --- faults ----------------------------------------------------------------------------------
    def drop_link(self, duration: float) -> None:
        """Simulate a radio outage of ``duration`` simulated seconds: the state stream freezes
        (``link_ok`` False, ``link_age`` growing in simulated seconds), commands fail, and after
        ``config.link_loss_hold`` the robot holds by itself."""
        with self._lock:
            if self._link_up():
                self._link_lost_at = self._sim_time
            self._link_down_until = self._sim_time + float(duration)

    def _link_up(self) -> bool:
        return self._sim_time >= self._link_down_until

    def _require_link(self) -> None:
        if not self.connected:
            raise LinkError("the simulated robot is not connected")
        with self._lock:
            if not self._link_up():
                raise LinkError(f"no link to the robot (outage for another "
                                f"{self._link_down_until - self._sim_time:.1f} s)")

    # --- main loop -------------------------------------------------------------------------------
    def _loop(self) -> None:
        period = 1.0 / self.config.rate
        last = time.monotonic()
        self._stream.publish(self._state())
        while not self._stop.is_set():
            now = time.monotonic()
            dt = (now - last) * self.config.time_scale
            last = now
            with self._lock:
                self._step(dt)
                state = self._state()
            self._stream.publish(state)
            self._stop.wait(max(0.0, period - (time.monotonic() - now)))

    def step(self, dt: float) -> None:
        """Advance the simulation by ``dt`` simulated seconds (the clock thread calls this; with
        ``manual_clock`` the caller does, and each call publishes a state)."""
        if dt < 0 or not math.isfinite(dt):
            raise ValueError(f"step: dt must be a finite number >= 0 s, got {dt}")
        self._step(dt)
        if self.manual_clock and self._manual_connected:
            with self._lock:
                state = self._state()
            self._stream.publish(state)

    def run_for(self, seconds: float, dt: float = 0.02) -> None:
        """Manual clock: advance ``seconds`` of simulated time in steps of ``dt``."""
        n = max(1, int(round(seconds / dt)))
        for _ in range(n):
            self.step(seconds / n)

    def _step(self, dt: float) -> None:
        with self._lock:
            before = self._pos.copy()
            self._sim_time += dt
            left = dt
            guard = 0
            while left > 1e-12 and self._phases and guard < 1000:
                left = self._advance(self._phases[0], left)
                guard += 1
            if not self._phases and self._run is not None:
                self._finish(RunStatus.DONE)
            outage = self._sim_time - self._link_lost_at if not self._link_up() else -1.0
            if self._run is not None and outage >= self.config.link_loss_hold:
                self._stop_motion(RunStatus.HELD, f"link lost for {outage:.1f} s: the robot holds")
            if outage < 0:
                self._self_landing = False
            elif outage >= self.config.link_loss_land and not self._landed and not self._phases \
                    and not self._self_landing:
                self._self_landing = True  # once per outage (a blocked descent is not retried)
                log.info("simulated robot: link lost for %.1f s, landing by itself", outage)
                self._say("CRITICAL", f"link lost for {outage:.0f} s: landing by itself")
                self._phases = self._landing_phases(Mode.LANDING)
            self._vel = (self._pos - before) / dt if dt > 0 else np.zeros(3)
            mode = self._mode()
            drain = (self.config.drain_fly if not self._landed or mode is Mode.TAKING_OFF
                     else self.config.drain_walk if mode is Mode.WALKING else self.config.drain_idle)
            self._battery = max(0.0, self._battery - drain * dt)
            self._battery_failsafe()

    def _mode(self) -> Mode:
        if self._phases:
            return self._phases[0].mode
        return Mode.IDLE if self._landed else Mode.HOLDING

    def _state(self) -> RobotState:
        now = time.time()
        if not self._link_up():
            if self._frozen is None:
                self._frozen = self._live_state(now)
            left = self._link_down_until - self._sim_time
            return replace(self._frozen, link_ok=False, link_age=self._sim_time - self._link_lost_at,
                           health=f"no link ({left:.1f} s of outage left)")
        self._frozen = None
        return self._live_state(now)

    def _live_state(self, now: float) -> RobotState:
        p, v = self._pos, self._vel
        return RobotState(
            time=now, position=(float(p[0]), float(p[1]), float(p[2])), yaw=float(self._yaw),
            velocity=(float(v[0]), float(v[1]), float(v[2])), mode=self._mode(), armed=self._armed,
            landed=self._landed, battery=self._battery, link_ok=True, link_age=0.0, health="ok",
            autopilot_mode="SIM", messages=tuple(self._messages))

    def _say(self, severity: str, text: str) -> None:
        """Add a status message (as an autopilot's STATUSTEXT) to the state stream."""
        self._n_messages += 1
        self._messages = (self._messages + [(self._n_messages, f"{severity}: {text}")])[-MESSAGES_KEPT:]

    # --- motion ----------------------------------------------------------------------------------
    def _blocker(self, p: np.ndarray) -> str | None:
        """Why the point ``p`` is not allowed (outside the workspace: the safety net), or ``None``.
        Hidden objects are not checked here: the robot finds them by touching them."""
        if self.config.workspace.cell_of(p) is None:
            return f"({p[0]:.2f}, {p[1]:.2f}, {p[2]:.2f}) is outside the workspace (the safety net)"
        return None

    def _check_free(self, p: np.ndarray, what: str) -> None:
        why = self._blocker(p)
        inside = BodyContact(self.world.objects, 1e-3, 1e-3)  # a start against an object is fine: it can move away
        if why is None and inside.touches(p):
            why = f"({p[0]:.2f}, {p[1]:.2f}, {p[2]:.2f}) is inside an object of the world"
        if why is not None:
            raise LinkError(f"{what} is not free: {why}")

    def _advance(self, ph: Phase, dt: float) -> float:
        """Run ``ph`` for up to ``dt`` s; returns the unused time (phase popped when done)."""
        if ph.waypoint is not None and self._run is not None:
            self._run.update(self._progress(), ph.waypoint)
        if ph.kind in ("spool", "settle"):
            used = min(dt, ph.duration)
            ph.duration -= used
            if ph.duration <= 1e-12:
                self._end_phase(ph)
            return dt - used
        if ph.kind == "turn":
            assert ph.yaw is not None
            err = wrap_angle(ph.yaw - self._yaw)
            need = abs(err) / self.config.yaw_rate
            if need <= dt:
                self._yaw = ph.yaw
                self._phases.pop(0)
                return dt - need
            self._yaw = wrap_angle(self._yaw + math.copysign(self.config.yaw_rate * dt, err))
            return 0.0
        # straight motion: move, climb, descend
        if ph.kind == "descend":
            self._meet_top(ph)
        assert ph.target is not None
        target = np.array(ph.target, dtype=np.float64)
        walking = ph.kind == "move" and ph.mode is Mode.WALKING
        if walking:  # a walk moves in plan; its height follows the ground under the body
            target[2] = self._pos[2]
        delta = target - self._pos
        dist = float(np.linalg.norm(delta))
        step = min(dist, ph.speed * dt)
        if dist > 1e-9:
            n = max(1, int(math.ceil(step / _STEP)))
            origin = self._pos.copy()
            reaches = dist - step <= 1e-9
            for i in range(1, n + 1):
                # the last point of a step that reaches the target is the target itself: rounding put a
                # landing 1e-17 m under the floor, outside the workspace (seen on a loaded machine)
                p = target.copy() if reaches and i == n else origin + delta * (step * i / n / dist)
                if walking:  # steps down any drop, up a ledge of at most STEP_UP (sim_contact)
                    p[2] = self._contact.ground_under((p[0], p[1], self._pos[2]), self._floor)
                elif p[2] > self._pos[2] + 1e-6:  # rising: off the floor or the top it stood on
                    self._landed = False
                why = self._blocker(p)
                touch = self._contact.blocked(self._pos, p) if why is None else None
                if touch is not None:
                    why = contact_text(touch)
                if why is not None:
                    self._fail(f"{verb(ph)} stopped: {why}")
                    return 0.0
                self._progress_done += float(np.linalg.norm(p - self._pos))
                self._pos = p
        if dist - step <= 1e-9:
            if not walking:  # a walk already stands at its target, at the ground's height
                self._pos = target
            self._end_phase(ph)
            return dt - (dist / ph.speed if ph.speed > 0 else 0.0)
        return 0.0

    def _meet_top(self, ph: Phase) -> None:
        """A descent that meets an object's top face under the body ends on it: a touchdown when the
        body can stand on it (or the empty battery's forced descent), else a stop there with the reason."""
        assert ph.target is not None
        td = self._contact.top_below(self._pos, ph.target[2])
        if td is None:
            return
        ph.target = (ph.target[0], ph.target[1], td.height)
        if td.why and ph.forced:
            self._say("WARNING", f"came down on a surface it cannot stand on: {td.why}")
        elif td.why:
            ph.stop = contact_below_text(td.point, td.why)

    def _end_phase(self, ph: Phase) -> None:
        self._phases.pop(0)
        if ph.kind == "spool":
            self._armed = True
        elif ph.kind == "descend" and ph.stop:
            self._fail(f"{verb(ph)} stopped: {ph.stop}")
            return
        elif ph.kind == "descend":
            self._landed = True  # on the floor or on a top face it stands on
        elif ph.kind == "settle":
            self._armed = False
        if self._run is not None:
            self._run.update(self._progress())

    def _progress(self) -> float:
        return self._progress_done / self._progress_total if self._progress_total > 0 else 0.0

    def _finish(self, status: RunStatus, error: str | None = None, say: bool = True) -> None:
        if self._run is not None:
            self._run.finish(status, error)
            if error:
                log.info("segment %s: %s", status.value, error)
                if say:  # the robot's own reasons (not the operator's hold / abort)
                    self._say("ERROR" if status is RunStatus.FAILED else "WARNING", error)
        self._run = None
        self._phases = []

    def _fail(self, error: str) -> None:
        if self._run is None and self._phases:
            self._say("ERROR", error)  # the robot's own manoeuvre (a failsafe landing): said, not lost
        self._finish(RunStatus.FAILED, error)

    # --- commands --------------------------------------------------------------------------------
    def _current_run(self) -> SegmentRun | None:
        return self._run

    def run_segment(self, segment: MissionSegment) -> SegmentRun:
        self._require_link()
        with self._lock:
            self._refuse_while_running()
            run = SegmentRun(segment)
            try:
                if (empty := self._battery_refusal()) is not None:
                    raise LinkError(empty)
                phases = plan_segment(segment, self._pos, self._yaw, self._landed, self._floor, self.config,
                                      self._blocker)
            except LinkError as exc:
                run.finish(RunStatus.FAILED, str(exc))
                self._say("ERROR", f"{segment.kind.value} refused: {exc}")
                return run
            self._run = run
            self._phases = phases
            self._progress_done = 0.0
            self._progress_total = path_length(self._pos, phases)
            if not phases:
                self._finish(RunStatus.DONE)
            return run

    def hold(self) -> None:
        self._require_link()
        with self._lock:
            self._stop_motion(RunStatus.HELD, "held by the operator", say=False)
            self._vel = np.zeros(3)
            state = self._state()
        self._stream.publish(state)  # the stream shows the stop at once, not a tick later

    def abort(self) -> None:
        self._require_link()
        with self._lock:
            self._stop_motion(RunStatus.ABORTED, "aborted by the operator", say=False)
            self._vel = np.zeros(3)
            state = self._state()
        self._stream.publish(state)

    def disarm(self) -> None:
        self._require_link()
        with self._lock:
            if not self._landed:
                raise LinkError(f"cannot disarm in the air ({self._pos[2]:.2f} m): land first")
            if self._run is not None and not self._run.done:
                raise LinkError(f"cannot disarm: a {self._run.segment.kind.value} segment is running")
            self._armed = False
            state = self._state()
        self._stream.publish(state)

    def _stop_motion(self, status: RunStatus, why: str, say: bool = True) -> None:
        if self._phases and self._phases[0].forced:  # the empty battery's descent: nothing stops it
            keep = self._phases
            self._finish(status, why, say)
            self._phases = keep
            return
        if self._phases and self._phases[0].kind == "spool":
            self._armed = False  # never lifted off
        if self._landed and self._phases and self._phases[0].kind == "settle":
            self._armed = False
        self._finish(status, why, say)

    # --- camera ----------------------------------------------------------------------------------
    def capture(self) -> CaptureResult:
        self._require_link()
        with self._lock:
            robot = Pose.from_xyz_yaw(*map(float, self._pos), yaw=float(self._yaw))
        self._shots += 1
        if self.captures is not None:
            return folder_capture(self.captures.next(), robot, self.mount)
        camera = camera_pose_in_world(robot, self.mount)
        with self._render_lock:
            if self._renderer is None:
                self._renderer = SceneRenderer(self.world, self.room)
            r = self._renderer.render(camera, self.intrinsics)
        return render_capture(r, self.world, self.intrinsics, camera, robot, self.mount, f"render-{self._shots:04d}",
                              self.min_visible_pixels)


__all__ = ["SimRobot", "SimConfig", "DEFAULT_INTRINSICS", "DEFAULT_MOUNT"]
