"""Goals and paths: click to add a goal, the candidate (red), registered (green) and mission paths.

A click in the 3D view becomes a ray; its hit with the floor (or with the chosen altitude's grid
layer) is the goal, and the candidate path from the last registered node appears at once. In goal
mode the click goes through objects (their own click handler stands aside); objects are selected
in select mode or with Shift held. A goal can also be typed (x, y, z) and the 3D view put in a top
view. The panel holds the click mode, goal mode and Register / Discard / Undo / Clear. Goals above
the floor get a drop line to it. In a top view an altitude click is the floor point under the cursor
at the goal height, and the Goal x / y / z fields follow every click. The built mission is drawn by segment type (walk / take-off / fly
/ land) with a legend. World frame, z up [m].
"""

from __future__ import annotations

import html
import logging
import math
import threading
import time
from typing import Any, Callable

import numpy as np
import viser

from planner.mission import Mission, SegmentKind

from console.session import operator_state as rules
from console.views.client_notice import tell
from console.views.object_labels import LabelSpot, board_for
from console.views.picking import SELECT_MODIFIER, click_intent, drop_lines, looks_down, top_view, typed_goal
from console.session.session import MISSION, ROUTE, RUN, SETTINGS, Session, SessionError
from console.wording import kind_text, plural

log = logging.getLogger(__name__)

CANDIDATE_RGB = (214, 39, 40)
REGISTERED_RGB = (40, 160, 70)
START_RGB = (40, 40, 48)
KIND_RGB: dict[SegmentKind, tuple[int, int, int]] = {
    SegmentKind.WALK: (0, 150, 136),
    SegmentKind.TAKEOFF: (255, 140, 0),
    SegmentKind.FLY: (142, 68, 173),
    SegmentKind.LAND: (233, 30, 99),
    SegmentKind.TURN: (30, 136, 229),
}
LIFT = 0.025  # draw floor paths this far above the floor [m], clear of the floor grid
NODE_CLICK_WINDOW = 0.5  # a scene click this soon after an object click belongs to the object [s]
CLICK_CHOICES = {"add goal": True, "select object": False}  # the "Click" dropdown -> goal mode on/off
DROP_RGB = (60, 60, 72)


def polyline_segments(points: np.ndarray, lift: float = 0.0) -> np.ndarray:
    """Consecutive points (K x 3) -> line segments (K-1 x 2 x 3), raised by ``lift`` [m]."""
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3).copy()
    p[:, 2] += lift
    if len(p) < 2:
        return np.zeros((0, 2, 3))
    return np.stack([p[:-1], p[1:]], axis=1)


def legend_html() -> str:
    """The path colour legend."""
    def chip(rgb: tuple[int, int, int], text: str) -> str:
        return (f"<span style='display:inline-block;width:0.8em;height:0.8em;border-radius:2px;"
                f"background:rgb{rgb};margin:0 0.3em 0 0.6em;vertical-align:-0.05em'></span>{text}")
    return ("<small>" + chip(CANDIDATE_RGB, "candidate") + chip(REGISTERED_RGB, "registered") + "<br>"
            + "".join(chip(KIND_RGB[k], kind_text(k)) for k in SegmentKind) + "</small>")


class PathsView:
    """Goal picking, route controls and path drawing.

    Args:
        server: The viser server.
        session: The state it draws and edits.
    """

    def __init__(self, server: viser.ViserServer, session: Session, *, read_only: bool = False) -> None:
        self._server = server
        self.read_only = bool(read_only)  # replay: the route is shown, never edited
        self._session = session
        self._lock = threading.RLock()
        self._node_clicks: dict[int, float] = {}
        self._handles: dict[str, Any] = {}
        s = session.settings
        gui = server.gui
        self._click = gui.add_dropdown(
            "Click", tuple(CLICK_CHOICES), initial_value=_click_choice(s.click_to_goal),
            hint="add goal: a click plans a candidate to the floor (or altitude) point under the cursor, "
                 f"through any object there · select object: a click selects the object · {SELECT_MODIFIER.capitalize()}"
                 "-click always selects")
        self._mode = gui.add_dropdown("Goal on", ("ground", "altitude"), initial_value=s.goal_mode,
                                      hint="ground: goals on the floor; altitude: goals in the air at the height below")
        ws = session.workspace
        self._alt = gui.add_number("Altitude [m]", s.altitude, min=ws.resolution, max=ws.max[2] - ws.floor - ws.resolution / 2,
                                   step=0.25, hint="Goal height above the floor in altitude mode [m]")
        # text fields, not a number vector: the browser drops what is not a number and would keep the
        # previous value without a word; here every typed text reaches the check and is named if bad
        self._typed = tuple(gui.add_text(f"Goal {n} [m]", f"{v:.2f}", hint=f"World frame [m]; {n} of the goal"
                                         + (" (its height: 0 = on the floor)" if n == "z" else ""))
                            for n, v in zip("xyz", session.route_snapshot().start))
        add = gui.add_button("Add goal", icon=viser.Icon.MAP_PIN, hint="Plan a candidate to the typed point",
                             disabled=self.read_only)
        view = gui.add_button_group("View", ("Top view", "Default view"),
                                    hint="Top view: look straight down on the whole workspace (easy goal clicks)")
        self._route_md = gui.add_markdown("")
        self._edit = {
            "Register": gui.add_button("Register", color="green", icon=viser.Icon.CHECK,
                                       hint="Keep the red candidate: it turns green; the next goal starts from its end"),
            "Discard": gui.add_button("Discard", icon=viser.Icon.X, hint="Drop the red candidate"),
            "Undo": gui.add_button("Undo", icon=viser.Icon.ARROW_BACK_UP, hint="Remove the last green segment"),
            "Clear": gui.add_button("Clear", icon=viser.Icon.TRASH, hint="Remove every path and the mission"),
        }
        gui.add_markdown(legend_html())

        self._alt.disabled = s.goal_mode != "altitude"
        self._click.on_update(self._on_click_toggle)
        add.on_click(self._on_typed_goal)
        view.on_click(lambda e: self.set_view(e.client, str(e.target.value)))
        self._mode.on_update(self._on_mode)
        self._alt.on_update(self._on_mode)
        actions = {"Register": (self._session.register, "Registered"), "Discard": (self._session.discard, None),
                   "Undo": (self._session.undo, "Undone"), "Clear": (self._session.clear_route, None)}
        for name, handle in self._edit.items():
            handle.on_click(lambda e, a=actions[name]: self._act(e, *a))
        server.scene.on_click()(self._on_scene_click)
        session.subscribe(self._on_event)
        self.redraw_route()
        self.redraw_mission()

    # --- clicks -----------------------------------------------------------------------------------
    def note_node_click(self, client_id: int) -> None:
        """An object was clicked: the scene-wide click that follows is not a goal."""
        self._node_clicks[client_id] = time.monotonic()

    async def _on_scene_click(self, event: Any) -> None:
        # async: runs on the event loop after any object's own click handler; registered for plain
        # clicks only (viser filters modifiers), so Shift-clicks never make goals
        t = self._node_clicks.pop(event.client_id, None)
        if t is not None and time.monotonic() - t < NODE_CLICK_WINDOW:
            return  # an object claimed this click (select mode)
        if self.read_only or click_intent(self._session.settings.click_to_goal, None, on_object=False) != "goal":
            return
        threading.Thread(target=self.goal_from_click, args=(event.client, event.ray_origin, event.ray_direction),
                         daemon=True).start()

    def goal_from_click(self, client: Any, origin: Any, direction: Any) -> bool:
        """Plan a candidate to where the ray picks a goal (in ``client``'s top view: the floor point
        under the cursor, at the goal height); the Goal fields show the point. Tells ``client`` if it fails."""
        cam = getattr(client, "camera", None)
        try:
            top_down = cam is not None and looks_down(tuple(cam.position), tuple(cam.look_at))
        except (AttributeError, TypeError, ValueError):  # a camera not reported yet: a view from the side
            top_down = False
        try:
            goal = self._session.goal_from_ray(origin, direction, top_down=top_down)
        except SessionError as exc:
            tell(client, "No goal there", str(exc), "yellow", 7.0)
            return False
        self.show_goal_fields(goal)
        planning(client, goal)
        res = self._session.add_goal(goal)
        if not res.ok:
            tell(client, "Goal not reachable", res.message, "yellow", 8.0)
            return False
        tell(client, "Candidate path",
                   f"to ({goal[0]:.2f}, {goal[1]:.2f}, {goal[2]:.2f}) m: {res.message}. Register to keep it.", "blue", 4.0)
        return True

    def _on_typed_goal(self, event: Any) -> None:
        threading.Thread(target=self.goal_from_values, args=(event.client, self.typed_values()), daemon=True).start()

    def show_goal_fields(self, goal: Any) -> None:
        """Put a clicked goal (world [m]) into the Goal x / y / z fields (2 decimals, as typed)."""
        for handle, v in zip(self._typed, goal):
            text = f"{float(v):.2f}"
            if str(handle.value) != text:
                handle.value = text

    @property
    def goal_fields(self) -> tuple[Any, ...]:
        """The Goal x / y / z text fields (viser handles), for a view that follows the typed goal."""
        return self._typed

    def typed_values(self) -> tuple[str, str, str]:
        """The goal's x, y, z fields as typed (text; checked by :func:`typed_goal`)."""
        return tuple(str(h.value) for h in self._typed)  # type: ignore[return-value]

    def goal_from_values(self, client: Any, values: Any) -> bool:
        """Plan a candidate to a typed ``(x, y, z)`` goal (world [m]); tell ``client`` if it fails."""
        try:
            goal = typed_goal(values, self._session.workspace)
        except SessionError as exc:
            tell(client, "No goal there", str(exc), "yellow", 7.0)
            return False
        planning(client, goal)
        res = self._session.add_goal(goal)
        if not res.ok:
            tell(client, "Goal not reachable", res.message, "yellow", 8.0)
            return False
        tell(client, "Candidate path", f"to ({goal[0]:.2f}, {goal[1]:.2f}, {goal[2]:.2f}) m: {res.message}. "
             "Register to keep it.", "blue", 4.0)
        return True

    def set_view(self, client: Any, which: str) -> None:
        """Put ``client``'s 3D view in the top view (straight down) or back to the default view."""
        if client is None:
            return
        cam = client.camera
        if which == "Top view":
            position, look_at, up = top_view(self._session.workspace, float(cam.fov), float(cam.aspect))
        else:
            init = self._server.initial_camera
            position, look_at, up = tuple(init.position), tuple(init.look_at), tuple(init.up)
        with client.atomic():
            cam.up_direction = up
            cam.position = position
            cam.look_at = look_at

    def _act(self, event: Any, action: Any, title: str | None) -> None:
        try:
            msg = action()
        except SessionError as exc:
            tell(event.client, "Not possible", str(exc), "yellow", 7.0)
            return
        if title and isinstance(msg, str):
            tell(event.client, title, msg, "green", 3.0)

    def _on_click_toggle(self, event: Any) -> None:
        if event.client is not None:
            self._session.set_click_to_goal(CLICK_CHOICES.get(str(self._click.value), True))

    def _on_mode(self, event: Any) -> None:
        if event.client is None:
            return
        try:
            self._session.set_goal_mode(str(self._mode.value), float(self._alt.value))
        except SessionError as exc:
            tell(event.client, "Invalid goal altitude", str(exc), "red", 7.0)
            self._sync_settings()

    # --- drawing -----------------------------------------------------------------------------------
    def _on_event(self, topic: str, _payload: Any) -> None:
        if topic == ROUTE:
            self.redraw_route()
        elif topic == MISSION:
            self.redraw_mission()
        elif topic == SETTINGS:
            self._sync_settings()
        elif topic == RUN:  # the mission state rules the route buttons (console.session.mission_rules)
            with self._lock:  # read inside the lock: a route read before a newer redraw must not undo it
                self._sync_edits(self._session.route_snapshot())

    def _sync_edits(self, r: Any) -> None:
        edits = rules.route_edits(r.candidate is not None, len(r.registered), self.read_only, self._session.run.state)
        for name, handle in self._edit.items():
            if handle.disabled != (not edits[name.lower()]):
                handle.disabled = not edits[name.lower()]

    def _sync_settings(self) -> None:
        s = self._session.settings
        self._click.value = _click_choice(s.click_to_goal)
        self._mode.value = s.goal_mode
        self._alt.value = s.altitude
        self._alt.disabled = s.goal_mode != "altitude"

    def _put(self, key: str, make: Callable[[], Any] | None) -> None:
        """Replace the node ``key`` with ``make()`` (or just remove it when ``make`` is None).

        The old handle is removed first: viser names nodes by path, so removing it after adding a
        node of the same name would remove the new one.
        """
        old = self._handles.pop(key, None)
        if old is not None:
            old.remove()
        if make is not None:
            self._handles[key] = make()

    def _lines(self, key: str, segments: np.ndarray, rgb: tuple[int, int, int], thickness: float) -> None:
        if len(segments) == 0:
            self._put(key, None)
            return
        self._put(key, lambda: self._server.scene.add_line_segments(f"/paths/{key}", segments, rgb,
                                                                    thickness=thickness))

    def redraw_route(self) -> None:
        """Start marker, registered segments and goals, candidate and its goal."""
        sc = self._server.scene
        with self._lock:  # read inside the lock: the last redraw always draws the latest route
            r = self._session.route_snapshot()
            self._sync_edits(r)
            self._put("start", lambda: sc.add_cylinder(
                "/paths/start", radius=0.09, height=0.02, color=START_RGB,
                position=(r.start[0], r.start[1], r.start[2] + 0.012), cast_shadow=False))
            reg = (np.concatenate([polyline_segments(p, LIFT) for p in r.registered], axis=0)
                   if r.registered else np.zeros((0, 2, 3)))
            self._lines("registered", reg, REGISTERED_RGB, 0.04)
            goals = np.array(r.goals).reshape(-1, 3)
            self._put("goals", None if not len(goals) else lambda: sc.add_batched_meshes_simple(
                "/paths/goals", *_sphere(0.07), batched_wxyzs=np.tile([1.0, 0, 0, 0], (len(goals), 1)),
                batched_positions=goals + [0, 0, LIFT], batched_colors=REGISTERED_RGB, lod="off", cast_shadow=False))
            cand = polyline_segments(r.candidate, LIFT) if r.candidate is not None else np.zeros((0, 2, 3))
            self._lines("candidate", cand, CANDIDATE_RGB, 0.045)
            g = r.candidate_goal
            floor = self._session.workspace.floor
            drops = drop_lines(list(r.goals) + ([g] if g is not None else []), floor)
            self._lines("drops", drops, DROP_RGB, 0.022)
            self._put("candidate_goal", None if g is None else lambda: sc.add_icosphere(
                "/paths/candidate_goal", radius=0.08, color=CANDIDATE_RGB, position=(g[0], g[1], g[2] + LIFT),
                cast_shadow=False))
            self._route_md.content = self._route_text(r)
            board = board_for(self._server)
            if board is not None:  # labels leave the start and goal markers free
                board.set_markers("route", [r.start, *r.goals] + ([g] if g is not None else []))

    @staticmethod
    def _route_text(r: Any) -> str:
        def length(p: np.ndarray) -> float:
            return float(np.linalg.norm(np.diff(p, axis=0), axis=1).sum()) if len(p) > 1 else 0.0
        off_floor = abs(float(r.start[2])) >= 0.005  # in the air: the route starts at its height
        parts = [f"Start ({r.start[0]:.2f}, {r.start[1]:.2f}" + (f", {r.start[2]:.2f}) m" if off_floor else ") m")]
        if r.registered:
            total = sum(length(p) for p in r.registered)
            parts.append(f"<b style='color:rgb{REGISTERED_RGB}'>{plural(len(r.registered), 'registered segment')}</b>, {total:.2f} m")
        if r.candidate is not None and r.candidate_goal is not None:
            g = r.candidate_goal
            parts.append(f"<b style='color:rgb{CANDIDATE_RGB}'>candidate</b> {length(r.candidate):.2f} m "
                         f"to ({g[0]:.2f}, {g[1]:.2f}, {g[2]:.2f})")
        elif not r.registered:
            parts.append("click the floor (or type a goal) to add a goal")
        return "<small>" + " · ".join(html.escape(p, quote=False) if "<" not in p else p for p in parts) + "</small>"

    def redraw_mission(self) -> None:
        """The mission's segments coloured by type, with take-off and landing spot labels."""
        sc = self._server.scene
        with self._lock:
            mission: Mission | None = self._session.mission
            segments = mission.segments if mission is not None else ()
            for kind in SegmentKind:
                parts = [polyline_segments(np.array(s.waypoints), LIFT + 0.015) for s in segments if s.kind is kind]
                arr = np.concatenate(parts, axis=0) if parts else np.zeros((0, 2, 3))
                self._lines(f"mission_{kind.value}", arr, KIND_RGB[kind], 0.06)
            for key in [k for k in self._handles if k.startswith("spot_")]:
                self._put(key, None)
            spots = spot_labels(segments)
            board = board_for(self._server)
            if board is not None:  # per tab, decluttered with the objects' labels, clear of the robot's
                board.set_layer("paths", spots)
                return
            for i, s in enumerate(spots):
                self._put(f"spot_{i}", lambda i=i, s=s: sc.add_label(
                    f"/paths/spot_{i}", s.text, position=s.position, anchor=s.anchor, font_screen_scale=s.font_scale))

    def drawn(self) -> list[str]:
        """Keys of the path nodes currently drawn (for tests)."""
        with self._lock:
            return sorted(self._handles)


SPOT_MERGE_M = 0.3
"""Take-off and landing spots closer than this [m] share one label ("1. take-off · 5. land")."""


def spot_labels(segments: Any) -> list[LabelSpot]:
    """The mission's take-off and landing spot labels ("2. take-off", "4. land"; world [m], hung below the
    spot), spots closer than :data:`SPOT_MERGE_M` sharing one label."""
    out: list[tuple[list[str], tuple[float, float, float]]] = []
    for i, s in enumerate(segments):
        if s.kind not in (SegmentKind.TAKEOFF, SegmentKind.LAND):
            continue
        x, y, z = (float(v) for v in s.spot)
        text = f"{i + 1}. {'take-off' if s.kind is SegmentKind.TAKEOFF else 'land'}"
        near = next((o for o in out if math.dist(o[1], (x, y, z + 0.05)) < SPOT_MERGE_M), None)
        if near is not None:
            near[0].append(text)
        else:
            out.append(([text], (x, y, z + 0.05)))
    return [LabelSpot(" · ".join(texts), p, (), "top-center", 0.75) for texts, p in out]


def planning(client: Any, goal: Any) -> None:
    """Say at once, in ``client``'s tab, that a goal (world [m]) is being planned: the first plan after a
    start can wait for the planner's kernels (:mod:`console.session.planner_warmup`), and a click must never
    look ignored. The answer (candidate or refusal) replaces this notice (same subject)."""
    tell(client, "Planning", f"a path to ({goal[0]:.2f}, {goal[1]:.2f}, {goal[2]:.2f}) m…", "blue", 30.0,
         about="goal")


def _click_choice(click_to_goal: bool) -> str:
    return next(k for k, v in CLICK_CHOICES.items() if v == bool(click_to_goal))


def _sphere(radius: float) -> tuple[np.ndarray, np.ndarray]:
    import trimesh

    m = trimesh.creation.icosphere(subdivisions=2, radius=radius)
    return np.asarray(m.vertices), np.asarray(m.faces)
