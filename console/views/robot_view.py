"""The robot's digital twin at its live pose, and its status line.

The twin is a low-poly aerial-ground robot (body, four arms with rotors, four legs, a camera at
the front), modelled in the robot body frame (x forward, y left, z up; origin on the floor under
the body centre) and moved to the reported ``world <- robot`` pose on every state update.

What the link says about its position is never drawn as more than it is
(:attr:`~console.session.session_types.RobotSnapshot.position_status`): a *known* pose shows the coloured
twin; a *stale* one (its stream stopped) shows a grey twin at the last valid pose labelled
``POSITION STALE``; an *unknown* one (no valid position yet: the pose is only a placeholder)
hides the twin and the status line says ``position unknown``. The status line also shows why the
vehicle is not ready to take off (position estimate, EKF, pre-arm) and the link's standing
warnings (vehicle identity, failsafe parameters, a moved EKF origin ...).
"""

from __future__ import annotations

import html
import logging
import math
import threading
import time
from typing import Any

import numpy as np
import trimesh
import viser

from console.views.client_notice import tell
from console.views.object_labels import board_for
from console.views.page_a11y import hint_spans
from console.views.robot_messages import MessageShelf
from console.session.button_rules import hover_text
from console.session.operator_state import CommandState, battery_text
from console.session.session import ROBOT, RUN, RobotSnapshot, Session, SessionError
from console.session.vehicle_commands import LABELS, VehicleCommands
from console.wording import mode_text

log = logging.getLogger(__name__)

BODY_RGB = (60, 66, 78)
ARM_RGB = (110, 118, 130)
ROTOR_RGB = (0, 170, 220)
LEG_RGB = (230, 120, 30)
CAMERA_RGB = (20, 20, 24)
STALE_RGB = (150, 150, 156)  # the whole twin while its pose is stale
MIN_INTERVAL = 0.05  # at most 20 pose updates per second [s]
LABEL_MOVE_M = 0.05  # the robot moved this far [m]: the other labels choose again around its label


def _colored(mesh: trimesh.Trimesh, rgb: tuple[int, int, int]) -> trimesh.Trimesh:
    mesh.visual.face_colors = np.tile([*rgb, 255], (len(mesh.faces), 1))
    return mesh


def robot_mesh() -> trimesh.Trimesh:
    """The twin in the robot body frame (x forward, y left, z up) [m], origin on the floor."""
    parts: list[trimesh.Trimesh] = []
    body_z = 0.30
    parts.append(_colored(trimesh.creation.box((0.34, 0.26, 0.10)), BODY_RGB))
    parts[-1].apply_translation((0.0, 0.0, body_z))
    for sx, sy in ((1, 1), (1, -1), (-1, 1), (-1, -1)):
        ang = math.atan2(sy, sx)
        tip = np.array([0.30 * math.cos(ang), 0.30 * math.sin(ang), body_z + 0.04])
        arm = _colored(trimesh.creation.box((0.30, 0.035, 0.025)), ARM_RGB)
        arm.apply_transform(trimesh.transformations.rotation_matrix(ang, (0, 0, 1)))
        arm.apply_translation(tip / 2 + (0, 0, body_z / 2 + 0.02))
        parts.append(arm)
        rotor = _colored(trimesh.creation.cylinder(radius=0.12, height=0.012, sections=24), ROTOR_RGB)
        rotor.apply_translation(tip + (0, 0, 0.03))
        parts.append(rotor)
        leg = _colored(trimesh.creation.cylinder(radius=0.018, segment=[tip * (1, 1, 0) + (0, 0, body_z),
                                                                         tip * (0.85, 0.85, 0)]), LEG_RGB)
        parts.append(leg)
        foot = _colored(trimesh.creation.icosphere(subdivisions=1, radius=0.028), LEG_RGB)
        foot.apply_translation(tip * (0.85, 0.85, 0) + (0, 0, 0.028))
        parts.append(foot)
    cam = _colored(trimesh.creation.box((0.05, 0.08, 0.06)), CAMERA_RGB)
    cam.apply_translation((0.195, 0.0, body_z))
    parts.append(cam)
    nose = _colored(trimesh.creation.cone(radius=0.04, height=0.09, sections=16), ROTOR_RGB)
    nose.apply_transform(trimesh.transformations.rotation_matrix(math.pi / 2, (0, 1, 0)))
    nose.apply_translation((0.23, 0.0, body_z + 0.07))
    parts.append(nose)
    return trimesh.util.concatenate(parts)


_ON = CommandState(True, True, "")

MESSAGES_SHOWN = 3
"""How many of the robot's latest status messages the panel shows."""
ALERT_SEVERITIES = ("EMERGENCY", "ALERT", "CRITICAL", "ERROR", "WARNING")
"""Status messages of these severities also pop up as notifications."""


def is_alert(message: str) -> bool:
    """Whether a ``"SEVERITY: text"`` status message is a warning or worse."""
    return message.split(":", 1)[0].strip().upper() in ALERT_SEVERITIES


def _message_color(message: str) -> str:
    return "#d62728" if is_alert(message) else "#666666"


def stale_mesh() -> trimesh.Trimesh:
    """The twin in grey, drawn at a stale pose (same frame as :func:`robot_mesh`)."""
    mesh = robot_mesh()
    mesh.visual.face_colors = np.tile([*STALE_RGB, 255], (len(mesh.faces), 1))
    return mesh


def _reason(detail: str, prefix: str, bracketed: bool) -> str:
    """What the link's health text says after ``prefix``: all of it, or only its closing bracket."""
    rest = detail[len(prefix):].lstrip(":").strip() if detail.startswith(prefix) else ""
    if bracketed:
        return rest[rest.index("(") + 1:-1] if "(" in rest and rest.endswith(")") else ""
    return rest


def position_text(r: RobotSnapshot) -> str:
    """The pose line of the panel (HTML): the pose, the stale pose marked, or "position unknown",
    with the link's reason (taken from its health text, which is then not repeated)."""
    x, y, z = r.pose.translation
    where = f"({x:.2f}, {y:.2f}, {z:.2f}) m, yaw {math.degrees(r.pose.yaw):.0f}°"
    status = r.position_status
    if status == "unknown":
        why = _reason(r.detail, "position unknown", False) or "no valid position from the vehicle yet"
        return f"<b style='color:#d62728'>position unknown</b>: {html.escape(why)} (twin hidden)"
    if status == "stale":
        why = _reason(r.detail, "stale", True)
        return (f"<b style='color:#d62728'>position stale</b>: no valid position for {r.pose_age:.1f} s"
                + (f" ({html.escape(why)})" if why else "")
                + f"; last valid pose {where} (grey twin)")
    return f"pose {where}"


def trust_text(r: RobotSnapshot) -> str:
    """Readiness (while not ready) and the link's standing warnings, as panel lines (HTML)."""
    out = ""
    if r.vehicle_control:  # the vehicle flies its own mode: the console sends nothing
        out += f"<br><b style='color:#d62728'>{html.escape(r.vehicle_control)}</b>"
    if not r.ready:
        out += ("<br><span style='color:#b35c00'><b>not ready to take off</b>: "
                f"{html.escape(r.readiness or 'the vehicle says so')}</span>")
    out += "".join(f"<br><span style='color:#d62728'>⚠ {html.escape(w)}</span>" for w in r.warnings)
    return out


def activity_text(r: RobotSnapshot) -> str:
    """What the robot is doing, from the vehicle's own state: its mode in plain words, except a take-off
    before the vehicle reports its motors armed, which is ``arming`` (a take-off is shown only armed)."""
    mode = mode_text(r.mode)
    return "arming" if mode == "taking off" and not r.armed else mode


def status_text(r: RobotSnapshot | None, link_name: str,
                messages: tuple[tuple[int, str], ...] | None = None) -> str:
    """One status line for the panel (HTML); ``messages`` are the robot's messages still news
    (:class:`console.views.robot_messages.MessageShelf`), by default its last few."""
    if r is None:
        return f"<small>robot <b>{html.escape(link_name)}</b>: waiting for the first state…</small>"
    status = r.position_status
    shown_detail = r.detail
    if status == "stale" and r.detail.startswith("stale:"):  # heard, but no fresh pose: counts as link loss
        health, shown_detail = "<b style='color:#d62728'>LINK LOST: position stale</b>", ""
    elif r.healthy:
        health = "<b style='color:#2a9d4b'>link ok</b>"
    else:
        health = "<b style='color:#d62728'>LINK LOST</b>"
    if status == "unknown" and r.detail.startswith("position unknown"):
        shown_detail = ""  # the pose line says it
    battery = battery_text(r)  # the charge, low / critical (console.session.operator_state)
    armed = "armed" if r.armed else "disarmed"
    age = time.time() - r.stamp
    stale = f" · <b style='color:#d62728'>{age:.0f} s old</b>" if age > 2.0 else ""
    detail = f"<br>{html.escape(shown_detail)}" if shown_detail else ""
    quality = f" · {html.escape(r.link_quality)}" if r.link_quality else ""
    said = "".join(f"<br><span style='color:{_message_color(t)}'>{html.escape(t)}</span>"
                   for _, t in (r.messages if messages is None else messages)[-MESSAGES_SHOWN:])
    return (f"<small>robot <b>{html.escape(link_name)}</b> · {health}{quality} · {html.escape(activity_text(r))} · {armed} · "
            f"{battery}{stale}<br>{position_text(r)}{detail}{trust_text(r)}{said}</small>")


class RobotView:
    """The twin in the 3D view and the robot status line in the panel.

    Args:
        server: The viser server.
        session: The state it shows.
        link_name: How the robot link is called (``sim``, ``mavlink:...``).
        commands: The vehicle commands (Hold, Land here, Return, Disarm) shown under the status
            line whenever the robot is armed or off the ground; ``None``: no buttons.
    """

    def __init__(self, server: viser.ViserServer, session: Session, link_name: str,
                 commands: VehicleCommands | None = None) -> None:
        self._server = server
        self._session = session
        self._link_name = link_name
        self._shelf = MessageShelf()  # the robot's messages while they are news (not old errors)
        self._run_state = "idle"
        self._lock = threading.Lock()
        self._last = 0.0
        self._status = server.gui.add_markdown(status_text(None, link_name))
        self._hover_note = server.gui.add_markdown("")  # hovering: the battery time left to land
        self._commands = commands
        self._buttons: dict[str, Any] = {}
        self._shown_commands: Any = None
        if commands is not None:
            icons = {"hold": viser.Icon.PLAYER_PAUSE, "land": viser.Icon.ARROW_BAR_TO_DOWN, "return": viser.Icon.HOME,
                     "disarm": viser.Icon.POWER, "control": viser.Icon.STEERING_WHEEL}
            colors = {"hold": "yellow", "land": "orange", "return": "blue", "disarm": "gray", "control": "red"}
            launch = session.operator_state().launch
            for name, label in LABELS.items():
                b = server.gui.add_button(label, color=colors[name], icon=icons[name], visible=False,
                                          hint=hover_text(name, label, _ON, launch))
                b.on_click(lambda e, n=name: self._on_command(e, n))
                self._buttons[name] = b
            self._why_not = server.gui.add_markdown("")
            self._hints = server.gui.add_html("")  # the buttons' hover text, shown by the page script (page_a11y)
        self._frame = server.scene.add_frame("/robot", show_axes=False, visible=False)
        self._twin = server.scene.add_mesh_trimesh("/robot/twin", robot_mesh())
        self._stale_twin = server.scene.add_mesh_trimesh("/robot/twin_stale", stale_mesh(), visible=False)
        self._drawn_key: tuple[Any, ...] = ()  # what the operator must see at once (no throttle) when it changes
        self._label = server.scene.add_label("/robot/label", "robot", position=(0.0, 0.0, 0.55),
                                             anchor="bottom-center", font_screen_scale=0.8)
        self._label_key: tuple[str, str, tuple[float, ...]] | None = None  # the label's text, status, place
        session.subscribe(self._on_event)
        if session.robot is not None:
            self.show(session.robot)

    def _on_event(self, topic: str, payload: Any) -> None:
        if topic == ROBOT and payload is not None:
            self.show(payload)
        if topic in (ROBOT, RUN):
            self._show_commands()
        if topic == RUN and payload is not None:
            before, self._run_state = self._run_state, getattr(payload, "state", "")
            if self._run_state == "done" and before != "done":
                self._shelf.clear()  # a later success: older robot errors are old news
                robot = self._session.robot
                if robot is not None:
                    self.show(robot, force=True)

    def _on_command(self, event: Any, name: str) -> None:
        assert self._commands is not None
        if name == "control":
            self._confirm_take_control(event)
            return
        try:
            message = self._commands.run(name)
        except SessionError as exc:
            log.info("vehicle command %s not done: %s", name, exc)
            tell(event.client, f"{LABELS[name]}: not done", str(exc), "yellow")
            return
        tell(event.client, LABELS[name], message, "blue")

    def _confirm_take_control(self, event: Any) -> None:
        """Take control asks first, in the clicking tab, saying what the vehicle does now."""
        assert self._commands is not None
        try:
            question = self._commands.take_control(confirm=False)
        except SessionError as exc:
            tell(event.client, "Take control: not done", str(exc), "yellow")
            return
        client = event.client
        with client.gui.add_modal("Take control from the vehicle?") as modal:
            client.gui.add_markdown(html.escape(question))
            yes = client.gui.add_button("Take control", color="red", icon=viser.Icon.STEERING_WHEEL)
            no = client.gui.add_button("Cancel")

        def decide(confirm: bool) -> None:
            modal.close()
            if not confirm:
                return
            try:
                message = self._commands.run("control")
            except SessionError as exc:
                tell(client, "Take control: not done", str(exc), "yellow")
                return
            tell(client, "Take control", message, "blue")

        yes.on_click(lambda _e: decide(True))
        no.on_click(lambda _e: decide(False))

    def _show_commands(self) -> None:
        """Show the vehicle commands the session's rules allow now (only when that changes)."""
        view = self._session.operator_state()
        states = view.commands
        key = (tuple(sorted((n, c.shown, c.enabled, c.reason) for n, c in states.items())), view.launch,
               view.battery_note, view.return_hint)
        with self._lock:
            if key == self._shown_commands:
                return
            self._shown_commands = key
            note = view.battery_note
            self._hover_note.content = (f"<small style='color:#b35c00'><b>{html.escape(note)}</b></small>"
                                        if note else "")
            for name, button in self._buttons.items():
                c = states[name]  # one rule per button (console.session.button_rules): the session refuses with it too
                button.visible = c.shown
                button.disabled = not c.enabled
                button.hint = hover_text(name, LABELS[name], c, view.launch, view.return_hint)
            if not self._buttons:
                return
            self._hints.content = hint_spans((b, b.hint or "") for b in self._buttons.values())
            off = sorted({c.reason for n, c in states.items() if c.shown and not c.enabled and c.reason
                          and not (n == "hold" and c.reason.endswith("nothing to hold"))})  # that one: on hover only
            self._why_not.content = "".join(f"<small style='color:#b35c00'>{html.escape(r)}</small><br>" for r in off)

    def show(self, r: RobotSnapshot, force: bool = False) -> None:
        """Move the twin to ``r.pose`` (throttled; a change of position status, link health,
        readiness, warnings or mode is drawn at once), grey it while the pose is stale, hide it while
        unknown, and refresh the status line."""
        now = time.monotonic()
        status = r.position_status
        key = (status, r.healthy, r.ready, r.readiness, r.warnings, r.mode, r.armed, r.vehicle_control)
        with self._lock:
            if not force and key == self._drawn_key and now - self._last < MIN_INTERVAL:
                return
            self._last, self._drawn_key = now, key
            if status == "unknown":
                self._frame.visible = False  # the pose is a placeholder: nothing to draw
            else:
                q = r.pose.quaternion  # x, y, z, w
                self._frame.position = r.pose.translation
                self._frame.wxyz = (q[3], q[0], q[1], q[2])
                self._twin.visible = status == "known"
                self._stale_twin.visible = status == "stale"
                self._frame.visible = True
            text = (f"robot · {activity_text(r)}" + ("" if r.healthy else " · LINK LOST")
                    + (" · POSITION STALE" if status == "stale" else ""))
            self._label.text = text
            self._labels_follow(text, status, r.pose.translation)
            self._status.content = status_text(r, self._link_name, self._shelf.current(r.messages))

    def _labels_follow(self, text: str, status: str, where: Any) -> None:
        """The robot's label moved (more than :data:`LABEL_MOVE_M`), changed its text or was hidden: the
        decluttered labels of every tab choose again, so none is drawn under it (console.views.object_labels)."""
        board = board_for(self._server)
        if board is None:
            return
        p = tuple(float(v) for v in where)
        last = self._label_key
        if (last is None or last[:2] != (text, status)
                or math.dist(last[2], p) > LABEL_MOVE_M):  # type: ignore[arg-type]
            self._label_key = (text, status, p)
            board.moved()

    @property
    def twin_shown(self) -> str:
        """Which twin is in the 3D view: ``known`` (coloured), ``stale`` (grey) or ``hidden``."""
        with self._lock:
            if not self._frame.visible:
                return "hidden"
            return "stale" if self._stale_twin.visible else "known"

    @property
    def status(self) -> str:
        """The status line as shown (HTML)."""
        with self._lock:
            return str(self._status.content)
