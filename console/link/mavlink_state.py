"""The MAVLink link's state samples: telemetry (local NED) -> :class:`~console.link.base.RobotState`
(world frame), with health, staleness, readiness and the robot's mode.

Health, most urgent first: ``no heartbeat for X s``; ``stale: no valid position for X s (why)``
(a position was known and its stream stopped or carries invalid values: ``link_ok`` False, the
mission manager treats it as link loss); ``position unknown: ...`` (none valid yet: ``position`` is
a finite placeholder and ``position_valid`` False); ``invalid telemetry dropped: FIELD: why`` (the
pose is fine, another stream was invalid in the last 2 s); ``autopilot failsafe ...``; ``ok``.
The mode is ``holding`` in the air only when the vehicle is still (below ``still_speed``).
"""

from __future__ import annotations

import math
import time

from planner.mission import SegmentKind

from console.link.base import Mode, RobotState
from console.link.mavlink_config import MavlinkConfig
from console.link.mavlink_quality import QualityFigures
from console.link.mavlink_telemetry import (LANDED_LANDING, LANDED_ON_GROUND, LANDED_TAKEOFF, LANDED_UNDEFINED,
                                STATUSTEXT_IN_STATE, Telemetry, Vehicle)

_MOVING = {SegmentKind.WALK: Mode.WALKING, SegmentKind.TAKEOFF: Mode.TAKING_OFF, SegmentKind.FLY: Mode.FLYING,
           SegmentKind.LAND: Mode.LANDING}


def landed(v: Vehicle, cfg: MavlinkConfig) -> bool:
    """Whether the vehicle stands on the ground (EXTENDED_SYS_STATE, else disarmed at floor height)."""
    if v.landed_state != LANDED_UNDEFINED:
        return v.landed_state == LANDED_ON_GROUND
    if v.pos_ned is None:
        return not v.armed
    floor_down = -cfg.ned.altitude(cfg.floor)
    return not v.armed and v.pos_ned[2] > floor_down - 0.1


def make_state(tel: Telemetry, cfg: MavlinkConfig, running: SegmentKind | None,
               mode_names: dict[int, str]) -> RobotState | None:
    """One state sample from the telemetry (world frame), ``None`` before the vehicle is heard.

    ``running`` is the kind of the segment being executed, if any."""
    ned = cfg.ned
    readiness = tel.readiness(cfg.pose_timeout)
    q = tel.quality.figures()
    poor = link_too_poor(q, cfg)
    if poor:
        readiness = "; ".join(x for x in (readiness, poor) if x)
    now = time.monotonic()
    with tel.lock:
        v = tel.v
        if v.system is None:
            return None
        age = now - v.last_heartbeat
        pose_age = now - v.pos_time
        pos = ned.to_world(v.pos_ned) if v.pos_ned is not None else ned.origin
        vel = ned.velocity_to_world(v.vel_ned)
        yaw = ned.yaw_to_world(v.yaw_ned)
        on_ground = landed(v, cfg)
        mode_name = mode_names.get(v.custom_mode, f"mode {v.custom_mode}") \
            if v.custom_mode is not None else ""
        status, armed = v.system_status, v.armed
        battery, voltage, landed_state = v.battery, v.voltage, v.landed_state
        messages = tuple((s.number, s.text) for s in v.statustext[-STATUSTEXT_IN_STATE:])
        invalid = v.last_invalid if v.last_invalid and now - v.last_invalid[0] < 2.0 else None
        invalid_total = sum(v.invalid.values())
        warnings = tuple(v.warnings.values())
        epoch = v.epoch
        control = tel.authority.describe()
        est = tel.estimator
        jump_recent = now - est.jump_time < 10.0
        estimator = "; ".join(x for x in (est.jump if jump_recent else "", est.fault) if x)
        resets, jump_m = est.resets, est.jump_m if jump_recent else 0.0
    hb_ok = age <= cfg.heartbeat_timeout
    known = math.isfinite(pose_age)
    fresh = known and pose_age <= cfg.pose_timeout
    still = fresh and math.sqrt(sum(c * c for c in vel)) < cfg.still_speed
    landing_started = landed_state == LANDED_LANDING or mode_name == cfg.land_mode
    if running is not None and (running is not SegmentKind.LAND or landing_started or on_ground):
        # a LAND run is "landing" once the vehicle lands; a TURN is ground or flight motion where it is
        mode = _MOVING.get(running) or (Mode.WALKING if on_ground else Mode.FLYING)
    elif status >= 5:  # MAV_STATE_CRITICAL / EMERGENCY: the autopilot's failsafe acts
        mode = Mode.FAILSAFE
    elif landed_state == LANDED_TAKEOFF:
        mode = Mode.TAKING_OFF
    elif landed_state == LANDED_LANDING or (mode_name == cfg.land_mode and not on_ground):
        mode = Mode.LANDING
    elif on_ground:
        mode = Mode.IDLE if still or not fresh else Mode.WALKING
    else:
        mode = Mode.HOLDING if still else Mode.FLYING
    why_invalid = f"{invalid[1]}, {invalid_total} invalid message(s) dropped" if invalid else ""
    if not hb_ok:
        health = f"no heartbeat for {age:.1f} s"
    elif known and not fresh:
        health = f"stale: no valid position for {pose_age:.1f} s" + (f" ({why_invalid})" if why_invalid else "")
    elif not known:
        health = "position unknown: " + (why_invalid or "no LOCAL_POSITION_NED yet (no position estimate?)")
    elif why_invalid:
        health = f"invalid telemetry dropped: {why_invalid}"
    elif status >= 5:
        health = "autopilot failsafe (system status CRITICAL/EMERGENCY)"
    elif estimator:
        health = f"estimator not trusted: {estimator}"
    else:
        health = "ok"
    return RobotState(time=time.time(), position=pos, yaw=yaw, velocity=vel, mode=mode, armed=armed,
                      landed=on_ground, battery=battery, battery_voltage=voltage,
                      link_ok=hb_ok and (fresh or not known), link_age=age if math.isfinite(age) else 1e9,
                      health=health, autopilot_mode=mode_name, messages=messages, position_valid=fresh,
                      pose_age=pose_age, ready=not readiness, readiness=readiness, warnings=warnings,
                      link_epoch=epoch, link_quality=q.summary(), link_loss=q.loss, link_rtt=q.rtt,
                      vehicle_control=control, estimator=estimator, estimator_resets=resets, position_jump=jump_m)


def link_too_poor(q: QualityFigures, cfg: MavlinkConfig) -> str:
    """Why the link is too poor to fly (``""`` when good enough): loss or latency over the limits."""
    why = []
    if q.loss is not None and q.loss > cfg.max_loss:
        why.append(f"{100 * q.loss:.0f} % of packets lost (limit {100 * cfg.max_loss:.0f} %)")
    if q.rtt is not None and q.rtt > cfg.max_rtt:
        why.append(f"round trip {q.rtt * 1000:.0f} ms (limit {cfg.max_rtt * 1000:.0f} ms)")
    return ("link too poor to fly: " + ", ".join(why)) if why else ""


__all__ = ["make_state", "landed", "link_too_poor"]
