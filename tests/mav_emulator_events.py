"""Things an ArduCopter vehicle does by itself, and link faults, for the emulator
(:class:`~mav_emulator.ArduCopterEmulator` mixes this in).

Read from the firmware (ArduPilot/ardupilot), never copied:

- ``ArduCopter/events.cpp``: a failsafe (battery, GCS, EKF, fence ...) switches the mode by itself
  (``set_mode_RTL_or_land_with_pause``: RTL if it can, else LAND) and warns the ground station with a
  STATUSTEXT; a second ground station or the pilot's mode switch change the mode the same way, without
  asking the console;
- ``libraries/AP_BattMonitor``: the low-battery text (``Battery 1 is low 10.40V used 4200 mAh``);
- ``libraries/GCS_MAVLink/GCS_Signing.cpp``: with a signing key set, unsigned (or wrongly signed)
  messages are ignored, except a few radio messages; no COMMAND_ACK comes back for them;
- ``libraries/GCS_MAVLink/GCS_Common.cpp`` (``handle_timesync``): a TIMESYNC with ``tc1 == 0`` is
  answered with the vehicle's clock in ``tc1`` and the request's ``ts1`` echoed.

Link faults modelled here: packet loss keeps the sequence counting (a lost packet leaves a gap in
MAVLink ``seq``, as on a radio), duplicated packets (two telemetry links, the second ``duplicate_delay``
late: exact copies, same ``seq``) and EKF position resets (a step in LOCAL_POSITION_NED with the
EKF_STATUS_REPORT flags of a reset / glitch).
"""

from __future__ import annotations

import hashlib
import time
from typing import Any

from pymavlink import mavutil

from mav_emulator_commands import NEEDS_POSITION
from mav_emulator_physics import RETURNING

mav = mavutil.mavlink

EKF_GPS_GLITCH = 32768
"""EKF_STATUS_REPORT flag ``EKF_GPS_GLITCH``."""


def signing_key(passphrase: str) -> bytes:
    """The 32-byte MAVLink 2 signing key of a passphrase (SHA-256, as MAVProxy's ``signing setup``)."""
    return hashlib.sha256(passphrase.encode()).digest()


def use_mavlink2() -> None:
    """Switch pymavlink to MAVLink 2 (signing needs it; ArduPilot speaks it by default)."""
    import os

    if os.environ.get("MAVLINK20") != "1":
        os.environ["MAVLINK20"] = "1"
        mavutil.set_dialect("ardupilotmega")


class VehicleEvents:
    """The vehicle's own decisions and the link faults (state lives in the emulator)."""

    mode: str
    armed: bool
    lock: Any
    record: Any
    conn: Any
    pos: list[float]
    battery: float
    params: dict[str, float]

    # --- the vehicle decides ---------------------------------------------------------------------
    def battery_failsafe(self, action: str = "RTL") -> None:
        """Low battery: the STATUSTEXT, then RTL (or LAND) chosen by the vehicle (events.cpp)."""
        with self.lock:
            self.battery = 9.0
            self.say("Battery 1 is low 10.40V used 4200 mAh", mav.MAV_SEVERITY_CRITICAL)
            if self.armed and self.landed_state != mav.MAV_LANDED_STATE_ON_GROUND:
                self._enter_mode(action, by="battery failsafe")

    def gcs_failsafe(self, action: str = "RTL") -> None:
        """The vehicle's own GCS failsafe (FS_GCS_ENABLE): RTL or LAND after its heartbeat timeout."""
        with self.lock:
            self.say("GCS Failsafe", mav.MAV_SEVERITY_CRITICAL)
            self._enter_mode(action, by="gcs failsafe")

    def _gcs_heartbeat(self, msg: Any) -> None:
        """GCS_Mavlink.cpp: only heartbeats from system SYSID_MYGCS count for the GCS failsafe."""
        if msg.get_srcSystem() == int(self.params.get("SYSID_MYGCS", 255)):
            self.gcs_last_seen = time.monotonic()

    def _failsafe_gcs_check(self, now: float) -> None:
        """events.cpp failsafe_gcs_check (with ``gcs_failsafe_auto``): enabled, a GCS seen once, silent for
        FS_GCS_TIMEOUT -> the failsafe (armed and flying: RTL; FS_GCS_ENABLE 5: LAND); heard again -> cleared,
        the mode stays the failsafe's."""
        if not self.gcs_failsafe_auto or not self.params.get("FS_GCS_ENABLE") or self.gcs_last_seen == 0.0:
            return
        late = now - self.gcs_last_seen > self.params.get("FS_GCS_TIMEOUT", 5.0)
        if late and not self.failsafe_gcs:
            self.failsafe_gcs = True
            if self.armed and self.landed_state != mav.MAV_LANDED_STATE_ON_GROUND:
                self.gcs_failsafe("LAND" if self.params.get("FS_GCS_ENABLE") == 5 else "RTL")
        elif not late and self.failsafe_gcs:
            self.failsafe_gcs = False
            self.say("GCS Failsafe Cleared", mav.MAV_SEVERITY_CRITICAL)

    def ekf_variance_bad(self) -> None:
        """The EKF's variances rise (EKF_STATUS_REPORT bad, the position no longer trusted: modes needing it
        refused); ekf_check.cpp acts only after EKF_CHECK_ITERATIONS_MAX checks (:meth:`ekf_failsafe`)."""
        with self.lock:
            self.ekf_fault_until = time.monotonic() + 3600.0
            self.position_bad = True

    def ekf_failsafe(self) -> None:
        """ekf_check.cpp: variances over FS_EKF_THRESH for long enough: "EKF variance" (CRITICAL), then
        failsafe_ekf_event: armed in a mode that needs a position (or FS_EKF_ACTION 3), LAND (FS_EKF_ACTION
        1, 3) or ALT_HOLD (2)."""
        with self.lock:
            self.ekf_variance_bad()
            self.say("EKF variance", mav.MAV_SEVERITY_CRITICAL)
            action = int(self.params.get("FS_EKF_ACTION", 1))
            if self.armed and (self.mode in NEEDS_POSITION or action == 3):
                self._enter_mode("ALT_HOLD" if action == 2 else "LAND", by="ekf failsafe")

    def fence_breach(self) -> None:
        """A fence breach with FENCE_ACTION brake: BRAKE, with its STATUSTEXT."""
        with self.lock:
            self.say("Fence Breached", mav.MAV_SEVERITY_CRITICAL)
            self._enter_mode("BRAKE", by="fence")

    def other_gcs_set_mode(self, name: str) -> None:
        """A second ground station (or the pilot's mode switch) sets a mode: no STATUSTEXT."""
        with self.lock:
            self._enter_mode(name, by="other gcs")

    def ekf_reset(self, north: float = 0.0, east: float = 4.0, glitch: bool = True) -> None:
        """An EKF position reset: the estimate steps by (north, east) [m] between two samples; with
        ``glitch`` EKF_STATUS_REPORT carries the GPS-glitch flag and high variances for 2 s."""
        with self.lock:
            self.pos[0] += north
            self.pos[1] += east
            if self.target is not None:
                self.target[0] += north
                self.target[1] += east
            if glitch:
                self.ekf_fault_until = time.monotonic() + 2.0
                self.say("GPS Glitch", mav.MAV_SEVERITY_CRITICAL)

    # --- link faults -----------------------------------------------------------------------------
    def _setup_signing(self) -> None:
        """GCS_Signing.cpp: sign what we send, ignore unsigned messages (but RADIO_STATUS)."""
        if self.signing_passphrase is None:
            return
        radio = {mav.MAVLINK_MSG_ID_RADIO_STATUS}

        def allow(_mav: Any, msg_id: int) -> bool:
            if msg_id in radio:
                return True
            self.record.unsigned_ignored += 1
            return False

        self.conn.setup_signing(signing_key(self.signing_passphrase), sign_outgoing=True,
                                allow_unsigned_callback=allow)

    def _timesync(self, msg: Any) -> None:
        if int(msg.tc1) == 0:
            self._send("timesync_send", int(time.monotonic_ns() - self._boot_ns), int(msg.ts1))

    def _duplicate(self, buf: bytes) -> None:
        if self.duplicate_delay > 0:
            self._dups.append((time.monotonic() + self.duplicate_delay, bytes(buf)))

    def _send_duplicates(self) -> None:
        now = time.monotonic()
        while self._dups and self._dups[0][0] <= now:
            _, buf = self._dups.pop(0)
            if not self._silent():
                self.conn.write(buf)
                self.record.duplicated += 1


__all__ = ["VehicleEvents", "signing_key", "use_mavlink2", "EKF_GPS_GLITCH", "RETURNING"]
