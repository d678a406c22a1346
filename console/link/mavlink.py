"""MAVLink link to an ArduPilot (Copter conventions) vehicle, with pymavlink: the RobotLink itself.

The link is split by concern:

- :mod:`~console.link.mavlink_transport`: connection strings, the pymavlink connection, GCS
  heartbeat, ``.tlog`` recording, stream upkeep (checked SET_MESSAGE_INTERVAL with the
  REQUEST_DATA_STREAM fallback, re-requested while a stream does not flow), EKF origin and
  failsafe parameters;
- :mod:`~console.link.mavlink_telemetry`: vehicle identity by (system, component) and autopilot
  type, validation of every field used (invalid messages dropped and counted), stream ages,
  reboot / reconnect detection;
- :mod:`~console.link.mavlink_commands`: COMMAND_LONG / COMMAND_ACK handshakes, NACK reasons,
  modes, arming, take-off, speeds, position / velocity targets;
- :mod:`~console.link.mavlink_segments`: the execution of one mission segment (walk, take-off,
  flight, landing) on the segment thread;
- this module: :class:`MavlinkLink` (the :class:`~console.link.base.RobotLink`): connection,
  state stream, segment runs (start, land here, hold / abort and the stop) and captures.

Segments, in ArduPilot Copter terms: walking = ground-motion targets (:class:`GroundMotion`);
take-off = wait (bounded) until the vehicle is ready, GUIDED, arm, ``MAV_CMD_NAV_TAKEOFF``;
flight = the configured speeds (``MAV_CMD_DO_CHANGE_SPEED``), then ``SET_POSITION_TARGET_LOCAL_NED``
re-sent until within tolerance; landing = above the spot, *stopped* there, then LAND until
``EXTENDED_SYS_STATE`` says on ground. A hold is BRAKE in the air (a target where the robot is on
the ground) and the run is reported HELD once the vehicle is still. Nothing is computed from an
invalid or stale position: segment execution waits (the mission manager's failsafe decides).

Mode authority (:mod:`~console.link.mavlink_authority`): once the vehicle switches to a mode the
console did not command, the running segment fails naming the mode and the vehicle's reason, hold /
abort send nothing, and no segment starts until the operator calls :meth:`MavlinkLink.take_control`.
"""

from __future__ import annotations

import logging
import math
import threading
import time
from pathlib import Path
from typing import Any, Callable

import numpy as np

from pipeline.camera.geometry import CameraMount, Intrinsics, camera_pose_in_world
from planner.mission import MissionSegment, SegmentKind

from console.link.base import CaptureResult, LinkError, LinkTimeout, RobotLink, RobotState, RunStatus, SegmentRun
from console.link.captures import CapturesFolder
from console.link.mavlink_authority import VehicleInControl
from console.link.mavlink_commands import (POSITION_ONLY_MASK, POSITION_YAW_MASK, VELOCITY_ONLY_MASK, Commander, Stopped,
                               copter_modes)
from console.link.mavlink_config import GroundMotion, MavlinkConfig
from console.link.mavlink_segments import STILL_DWELL, SegmentExecutor
from console.link.mavlink_state import make_state
from console.link.mavlink_telemetry import LANDED_LANDING, LANDED_ON_GROUND, Telemetry
from console.link.mavlink_transport import MavTransport, StreamKeeper, parse_connection
from console.link.ned import NedFrame

log = logging.getLogger(__name__)

Vec3 = tuple[float, float, float]


class MavlinkLink(RobotLink):
    """A robot reached over MAVLink (ArduPilot Copter firmware).

    Args:
        url: pymavlink connection string (see :mod:`~console.link.mavlink_transport`).
        config: Frames, command set, speeds and time-outs.
        captures: Photos to serve as the robot's camera (``--captures DIR``).
        camera: Alternatively, a callable returning ``(RGB image, Intrinsics)`` from the robot's
            camera; photos then carry source ``mavlink`` and the pose reported over MAVLink.
        mount: Camera on the robot (robot body frame), for the camera pose of captures.
        tlog: Folder (or ``.tlog`` path) where the session's MAVLink traffic is recorded.
    """

    def __init__(self, url: str, config: MavlinkConfig = MavlinkConfig(),
                 captures: str | Path | CapturesFolder | None = None,
                 camera: Callable[[], tuple[np.ndarray, Intrinsics]] | None = None,
                 mount: CameraMount = CameraMount(), tlog: str | Path | None = None) -> None:
        super().__init__()
        self.url = url
        self.device, self.baud = parse_connection(url)
        self.config = config
        self.captures = (captures if isinstance(captures, CapturesFolder) or captures is None
                         else CapturesFolder(captures))
        self.camera = camera
        self.mount = mount
        self._counters: dict[str, int] = {"retries": 0, "nacks": 0}
        self.telemetry = Telemetry(config.source_system, config.heartbeat_timeout, config.autopilot_component,
                                   config.max_range, config.max_speed, on_epoch=self._on_epoch,
                                   vehicle_max_speed=config.vehicle_max_speed,
                                   source_component=config.source_component)
        self.transport = MavTransport(url, config.source_system, config.source_component, self.telemetry.handle,
                                      tlog, on_reconnect=self.telemetry.new_epoch,
                                      silence=self.telemetry.silence,
                                      gate_after=min(config.heartbeat_timeout, config.pose_timeout),
                                      signing_key=config.signing_key, on_timesync=self._timesync_sent)
        self.telemetry.signing_key_set = config.signing_key is not None
        self.commander = Commander(self.transport, self.telemetry, config.ned, self._target, config.ack_timeout,
                                   config.retries, config.command_max_age, config.nack_window, self._counters)
        self.streams = StreamKeeper(config.message_rate, self.telemetry, self.transport, self.commander.command,
                                    self._target, stale_after=config.pose_timeout)
        self.segments = SegmentExecutor(config, self.telemetry, self.commander)
        self.segments.speed_guard.stop = self._stop_here
        self._state_thread: threading.Thread | None = None
        self._run: SegmentRun | None = None
        self._run_cancel = threading.Event()
        self._run_thread: threading.Thread | None = None
        self._run_lock = threading.Lock()

    # --- connection ------------------------------------------------------------------------------
    @property
    def stats(self) -> dict[str, int]:
        """Counters: ``sent``, ``received``, ``retries``, ``nacks``, ``invalid`` (dropped messages)."""
        with self.telemetry.lock:
            invalid = sum(self.telemetry.v.invalid.values())
        return {"sent": self.transport.sent, "received": self.telemetry.received, "invalid": invalid,
                **self._counters}

    @property
    def description(self) -> str:
        v = self.telemetry.v
        return f"MAVLink {self.url}" + (f" (vehicle system {v.system} component {v.component})"
                                        if v.system is not None else "")

    @property
    def connected(self) -> bool:
        return self.transport.is_open

    @property
    def local_port(self) -> int | None:
        return self.transport.local_port

    @property
    def tlog(self) -> Path | None:
        """Where this session's MAVLink traffic is recorded, or ``None``."""
        return self.transport.tlog

    def components(self) -> list[str]:
        """Every (system, component) heard, ``"1/1 type 2 autopilot 3 (vehicle)"``."""
        with self.telemetry.lock:
            v = self.telemetry.v
            return [f"{s}/{c} type {t} autopilot {a}" + (" (vehicle)" if (s, c) == (v.system, v.component) else "")
                    for (s, c), (t, a, _) in sorted(v.components.items())]

    def open(self) -> None:
        """Open the connection and start the threads without waiting for the vehicle."""
        if self.transport.conn is not None:
            return
        self.transport.open()
        self.streams.start()
        self._state_thread = threading.Thread(target=self._state_loop, name="mav-state", daemon=True)
        self._state_thread.start()

    def connect(self, timeout: float = 10.0) -> None:
        """Open the connection and wait for the vehicle's first heartbeat."""
        self.open()
        if not self.wait_heartbeat(timeout):
            self.close()
            raise LinkTimeout(
                f"no heartbeat from a vehicle on {self.url} within {timeout:.0f} s "
                "(is the autopilot / SITL sending to this address?)")
        self.transport.heartbeat_now()
        self.streams.renew()

    def wait_heartbeat(self, timeout: float) -> bool:
        with self.telemetry.lock:
            return self.telemetry.lock.wait_for(lambda: self.telemetry.v.system is not None, timeout)

    def close(self) -> None:
        self._cancel_run(RunStatus.ABORTED, "link closed")
        self.transport.close()
        self.streams.join()
        if self._state_thread is not None and self._state_thread.is_alive():  # may not be started yet
            self._state_thread.join(timeout=2.0)
            self._state_thread = None

    def _timesync_sent(self, ts1: int) -> None:
        with self.telemetry.lock:
            sent = self.telemetry.timesync_sent
            sent[ts1] = time.monotonic()
            for k in list(sent)[:-20]:
                del sent[k]

    # --- mode authority --------------------------------------------------------------------------
    @property
    def vehicle_control(self) -> str:
        """``""`` while the console may command the vehicle, else ``vehicle took control: mode ...``."""
        with self.telemetry.lock:
            return self.telemetry.authority.describe()

    def take_control(self) -> None:
        """The operator takes control again after the vehicle chose its own mode: the next segment may
        switch it to GUIDED. Nothing is sent here."""
        with self.telemetry.lock:
            self.telemetry.authority.take_control()
        self.telemetry.clear_warning("authority")

    def release_control(self) -> None:
        """The console no longer claims the vehicle (mission over): its mode changes are its own."""
        with self.telemetry.lock:
            self.telemetry.authority.release()

    def _on_epoch(self, reason: str) -> None:
        """A reboot / reconnect: ask for the streams, origin and parameters again."""
        self.streams.renew()
        self.transport.heartbeat_now()

    def _target(self) -> tuple[int, int]:
        with self.telemetry.lock:
            v = self.telemetry.v
            if v.system is None:
                raise LinkError("no vehicle heard yet on " + self.url)
            return v.system, v.component

    # --- state -----------------------------------------------------------------------------------
    def _state_loop(self) -> None:
        period = 1.0 / self.config.state_rate
        while not self.transport.stop.wait(period):
            try:
                st = self._make_state()
            except Exception:
                log.exception("state sample failed")
                continue
            if st is not None:
                self._stream.publish(st)

    def heartbeat_age(self) -> float:
        """Seconds since the vehicle's last heartbeat (``inf`` before the first)."""
        return self.telemetry.heartbeat_age()

    def link_age_now(self) -> float:
        """Live: the longer of the heartbeat silence and, once a position was known, its age [s]."""
        hb = self.telemetry.heartbeat_age()
        pose = self.telemetry.pose_age()
        return max(hb, pose) if math.isfinite(pose) else hb

    def state_now(self) -> RobotState | None:
        """A state built from the telemetry as it is now (``None`` before the vehicle is heard): the
        stored sample is up to a sampler period old, more on a loaded machine."""
        return self._make_state()

    def fresh_state(self, since: float, timeout: float) -> RobotState | None:
        """A state built only from telemetry received after ``since`` (monotonic [s]): a heartbeat, a
        valid position and (if the vehicle sends it) EXTENDED_SYS_STATE; ``None`` if that does not come
        within ``timeout`` [s]. What is said after a link returns is built from this, never from the
        samples of before."""
        tel = self.telemetry

        def fresh() -> bool:
            v = tel.v
            ext = v.stream_time.get("EXTENDED_SYS_STATE")
            return v.last_heartbeat > since and v.pos_time > since and (ext is None or ext > since)

        with tel.lock:
            if not tel.lock.wait_for(fresh, timeout):
                return None
        return self._make_state()

    def _current_run(self) -> SegmentRun | None:
        return self._run

    def _make_state(self) -> RobotState | None:
        run = self._run
        kind = run.segment.kind if run is not None and not run.done else None
        return make_state(self.telemetry, self.config, kind, self.commander.mode_names)

    # --- commands (see Commander) ----------------------------------------------------------------
    def command(self, command: int, params: tuple[float, ...], what: str, **kw: Any) -> None:
        """Send a COMMAND_LONG and wait for its ACK (:meth:`Commander.command`)."""
        self.commander.command(command, params, what, **kw)

    def vehicle_mode(self) -> str | None:
        return self.commander.vehicle_mode()

    def set_mode(self, name: str, cancel: threading.Event | None = None) -> None:
        self.commander.set_mode(name, cancel)

    def arm(self, cancel: threading.Event | None = None) -> None:
        self.commander.arm(cancel)

    def disarm(self) -> None:
        """Disarm the motors (MAV_CMD_COMPONENT_ARM_DISARM, param1 0); only on the ground and with no
        segment running; nothing to do when already disarmed."""
        if not self.connected:
            raise LinkError("the MAVLink link is not connected")
        if self.segments.airborne():
            raise LinkError("cannot disarm: the vehicle is in the air (land first)")
        run = self._run
        if run is not None and not run.done:
            raise LinkError(f"cannot disarm: a {run.segment.kind.value} segment is running")
        if not self.commander.armed():
            return
        self.commander.disarm()

    def send_position_target(self, world: Vec3, yaw: float | None = None, component: int | None = None) -> None:
        self.commander.send_position_target(world, yaw, component)

    def send_velocity_target(self, v_world: Vec3, yaw: float | None = None, component: int | None = None) -> None:
        self.commander.send_velocity_target(v_world, yaw, component)

    # --- segments --------------------------------------------------------------------------------
    def run_segment(self, segment: MissionSegment) -> SegmentRun:
        if not self.connected:
            raise LinkError("the MAVLink link is not connected")
        for w in segment.waypoints:
            if not all(math.isfinite(float(c)) for c in w):
                raise LinkError(f"{segment.kind.value} segment: waypoint {w} is not finite")
        taken = self.vehicle_control
        if taken:
            raise VehicleInControl(f"{taken}: take control first")
        with self._run_lock:
            self._refuse_while_running()
            run = SegmentRun(segment)
            cancel = threading.Event()
            self._run, self._run_cancel = run, cancel
            t = threading.Thread(target=self.segments.execute, args=(run, cancel), name="mav-segment", daemon=True)
            self._run_thread = t
            t.start()
        return run

    def land_here(self, floor: float = 0.0) -> SegmentRun:
        """Land where the vehicle is now: straight to LAND (no flight to a remembered spot)."""
        if not self.connected:
            raise LinkError("the MAVLink link is not connected")
        taken = self.vehicle_control
        if taken:  # the vehicle flies its own mode (RTL, LAND ...): the console does not interfere
            raise VehicleInControl(f"{taken}: the console does not land it")
        here = self.segments.pos()
        if here is None:
            st = self.latest_state()
            here = np.asarray(st.position if st is not None else self.config.ned.origin, dtype=np.float64)
        seg = MissionSegment(SegmentKind.LAND, ((float(here[0]), float(here[1]), max(float(here[2]), floor)),
                                                (float(here[0]), float(here[1]), floor)))
        with self._run_lock:
            self._refuse_while_running()
            run = SegmentRun(seg)
            cancel = threading.Event()
            self._run, self._run_cancel = run, cancel

            def go() -> None:
                try:
                    if self.segments.airborne():
                        self.segments.land(run, cancel)
                    run.finish(RunStatus.DONE)
                except Stopped:
                    pass
                except LinkError as exc:
                    run.finish(RunStatus.FAILED, str(exc))

            self._run_thread = threading.Thread(target=go, name="mav-land-here", daemon=True)
            self._run_thread.start()
        return run

    # --- hold / abort ----------------------------------------------------------------------------
    def _cancel_run(self, status: RunStatus, why: str) -> SegmentRun | None:
        """Stop the executing thread; the run is finished by the caller (or here when closing)."""
        with self._run_lock:
            run, cancel, thread = self._run, self._run_cancel, self._run_thread
        if run is None or run.done:
            return None
        cancel.set()
        if thread is not None and thread is not threading.current_thread():
            thread.join(timeout=self.config.ack_timeout + 1.0)
        if status is RunStatus.ABORTED and why == "link closed":
            run.finish(status, why)
        return run

    def hold(self) -> None:
        """Stop: BRAKE (``hold_mode``) in the air, a target at the current spot on the ground; the
        running segment finishes HELD once the vehicle is still (or ``settle_timeout`` passed)."""
        self._stop_and_finish(RunStatus.HELD, "held by the operator")

    def abort(self) -> None:
        self._stop_and_finish(RunStatus.ABORTED, "aborted by the operator")

    def _stop_and_finish(self, status: RunStatus, why: str) -> None:
        run = self._cancel_run(status, why)
        taken = self.vehicle_control
        if taken:  # nothing is sent: the vehicle flies its own mode
            if run is not None:
                run.finish(status, f"{why}: nothing sent, {taken}")
            return
        try:
            self._stop_here()
            note = self._settle()
        except LinkError as exc:
            if run is not None:
                run.finish(status, f"{why}; stop command failed: {exc}")
            raise
        if run is not None:
            run.finish(status, why + (f" ({note})" if note else ""))

    def _settle(self) -> str:
        """Wait until the vehicle is still; returns ``""`` or why that is not confirmed."""
        cfg = self.config
        deadline = time.monotonic() + cfg.settle_timeout
        while time.monotonic() < deadline:
            if self.telemetry.heartbeat_age() > cfg.heartbeat_timeout or self.segments.pos() is None:
                return "stop not confirmed: no valid telemetry"
            if self.segments.speed() < cfg.still_speed:
                return ""
            time.sleep(0.02)
        return f"still moving at {self.segments.speed():.2f} m/s after {cfg.settle_timeout:.0f} s"

    def _stop_here(self) -> None:
        if not self.connected:
            raise LinkError("the MAVLink link is not connected")
        if self.segments.airborne():
            self.set_mode(self.config.hold_mode)
            return
        g = self.config.ground
        here = self.segments.pos()
        if g.command == "velocity" or here is None:  # no valid position: stop without one
            self.send_velocity_target((0.0, 0.0, 0.0), None, g.target_component)
        else:
            self.send_position_target((float(here[0]), float(here[1]), float(self.config.floor)), None,
                                      g.target_component)

    # --- camera ----------------------------------------------------------------------------------
    def capture(self) -> CaptureResult:
        st = self.latest_state()
        if st is None:
            raise LinkError("no state from the vehicle yet: cannot place a photo")
        if self.camera is None and self.captures is None:
            raise LinkError("this MAVLink link has no camera: start the console with --captures DIR "
                            "to use photos from a folder")
        if not st.position_valid:
            raise LinkError(f"the vehicle's position is not known ({st.health}): cannot place a photo")
        robot = st.pose
        cam = camera_pose_in_world(robot, self.mount)
        if self.camera is not None:
            image, intr = self.camera()
            return CaptureResult(image, intr, cam, robot, self.mount, time.time(), "mavlink", "camera")
        assert self.captures is not None
        p = self.captures.next()
        return CaptureResult(p.image, p.intrinsics, cam, robot, self.mount, time.time(), "captures-folder",
                             p.name, p.ground_truth)


__all__ = ["MavlinkLink", "MavlinkConfig", "GroundMotion", "NedFrame", "parse_connection", "copter_modes",
           "POSITION_ONLY_MASK", "POSITION_YAW_MASK", "VELOCITY_ONLY_MASK", "LANDED_ON_GROUND", "LANDED_LANDING",
           "STILL_DWELL"]
