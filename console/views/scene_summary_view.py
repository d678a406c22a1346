"""The scene panel: a text summary of the map (with a copy button) and "Go to" an object.

The summary is :func:`planner.scene_summary.summarize` of the scene graph built from the
session's scene and grid, seen from the robot's live pose (else from the route start, facing
+y). It is rebuilt off the UI thread after every map change (scene or grid events) and when the
robot has moved more than :data:`MOVE_REFRESH` or turned more than :data:`TURN_REFRESH` since the
last summary; many changes in a row give one rebuild. "Go to" lists the objects (label and id);
choosing one plans a candidate to the free floor cell beside it
(:func:`planner.object_goal.goal_beside`, from where the next candidate starts) through the
session's :meth:`~console.session.object_follow.ObjectFollow.go_to_object` (the goal follows the object
if mapping merges it into another). World frame, metres.
"""

from __future__ import annotations

import html
import logging
import math
import threading
from typing import Any

import viser

from planner.route import Route
from planner.scene_graph import build_scene_graph
from planner.scene_summary import nice, summarize

from console.views.client_notice import tell
from console.wording import natural_key
from console.session.session import GRID, ROBOT, SCENE, Session, SessionError

log = logging.getLogger(__name__)

PLACEHOLDER = "choose an object…"
EMPTY = "(no objects mapped yet)"
MOVE_REFRESH = 0.5
"""Robot displacement [m] that triggers a new summary."""
TURN_REFRESH = math.radians(20.0)
"""Robot turn [rad] that triggers a new summary."""


def option_label(label: str, oid: str) -> str:
    """The dropdown entry of an object: its label as words and its id."""
    return f"{nice(label)} · {oid}"


def goto_entries(objects: Any) -> dict[str, str]:
    """The Go to list, dropdown entry -> object id, by label then id in natural order (box-2 before box-10)."""
    ordered = sorted(objects, key=lambda o: (natural_key(nice(o.label)), natural_key(o.id)))
    return {option_label(o.label, o.id): o.id for o in ordered}


def summary_html(text: str) -> str:
    """The summary in a read-only text box with a button that copies it to the clipboard."""
    rows = min(8, max(3, text.count("\n") + 1))
    # feedback that tells the truth: "Copied ✓" once the clipboard took it, else how to copy by hand
    copy_js = ("var b=this,t=b.parentNode.querySelector('textarea');"
               "var say=function(m){b.textContent=m;clearTimeout(b._mn);b._mn=setTimeout(function(){b.textContent='Copy';},2500);};"
               "var old=function(){t.select();try{return document.execCommand('copy');}catch(e){return false;}};"
               "var done=function(ok){say(ok?'Copied \u2713':'Copy failed: select the text, Ctrl+C');};"
               "if(navigator.clipboard&&window.isSecureContext){navigator.clipboard.writeText(t.value)"
               ".then(function(){done(true);},function(){done(old());});}else{done(old());}")
    return (f"<div><textarea readonly rows='{rows}' style='width:100%;font:11px/1.35 monospace;resize:vertical;"
            f"white-space:pre-wrap;box-sizing:border-box'>{html.escape(text)}</textarea>"
            f"<button type='button' aria-live='polite' onclick=\"{html.escape(copy_js)}\" style='margin-top:4px'>Copy</button></div>")


class SceneSummaryView:
    """Summary panel and "Go to" object list, for every browser tab.

    Args:
        server: The viser server.
        session: The state it reads (scene, grid, robot, route) and plans through (``add_goal``).
    """

    def __init__(self, server: viser.ViserServer, session: Session) -> None:
        self._server = server
        self._session = session
        self._lock = threading.Lock()
        self._dirty = threading.Event()
        self._stop = threading.Event()
        self._ids: dict[str, str] = {}  # dropdown entry -> object id
        self._pose_used: tuple[float, float, float] | None = None  # x, y, yaw of the last summary
        self.text = ""
        self.refreshes = 0
        gui = server.gui
        self._goto = gui.add_dropdown("Go to", (EMPTY,), initial_value=EMPTY, disabled=True,
                                      hint="Plan a candidate path to the free floor beside this object")
        self._html = gui.add_html(summary_html("(no summary yet)"))
        self._goto.on_update(self._on_goto)
        session.subscribe(self._on_event)
        self._worker = threading.Thread(target=self._run, name="scene-summary", daemon=True)
        self._dirty.set()
        self._worker.start()

    def close(self) -> None:
        """Stop the background thread."""
        self._stop.set()
        self._dirty.set()

    # --- refresh --------------------------------------------------------------------------------
    def _on_event(self, topic: str, payload: Any) -> None:
        if topic in (SCENE, GRID):
            self._dirty.set()
        elif topic == ROBOT and payload is not None and self.moved_enough(payload.pose):
            self._dirty.set()

    def moved_enough(self, pose: Any) -> bool:
        """Whether the robot at ``pose`` (``world <- robot``) is far enough from the last summary's pose."""
        used = self._pose_used
        x, y, _ = pose.translation
        return used is None or math.hypot(x - used[0], y - used[1]) > MOVE_REFRESH or \
            abs(math.remainder(pose.yaw - used[2], 2 * math.pi)) > TURN_REFRESH

    def _run(self) -> None:
        while not self._stop.is_set():
            self._dirty.wait()
            if self._stop.is_set():
                return
            self._dirty.clear()
            try:
                self.refresh()
            except Exception:  # a bad map must not kill the panel
                log.exception("scene summary failed")

    def _robot_pose(self) -> tuple[float, float, float, float]:
        robot = self._session.robot
        if robot is not None:
            x, y, z = robot.pose.translation
            return (float(x), float(y), float(z), float(robot.pose.yaw))
        s = self._session.route_snapshot().start
        return (float(s[0]), float(s[1]), float(s[2]), math.pi / 2)

    def refresh(self) -> str:
        """Rebuild the summary and the object list now (runs on the caller's thread)."""
        with self._lock:
            scene, grid = self._session.scene, self._session.grid
            pose = self._robot_pose()
            self._pose_used = (pose[0], pose[1], pose[3])
            route = Route(grid, pose[:3], self._session.weights)
            graph = build_scene_graph(scene, pose, grid, route=route)
            text = summarize(graph)
            if self._stop.is_set():
                return text  # shutting down: the server may be gone
            self._html.content = summary_html(text)
            entries = goto_entries(scene.objects)
            self._ids = entries
            if entries:
                self._goto.options = (PLACEHOLDER, *entries)
                if self._goto.value not in entries:
                    self._goto.value = PLACEHOLDER
                self._goto.disabled = False
            else:
                self._goto.options = (EMPTY,)
                self._goto.value = EMPTY
                self._goto.disabled = True
            self.text = text  # last: whoever sees the new text sees the new list too
            self.refreshes += 1
            return text

    # --- go to ------------------------------------------------------------------------------------
    def _on_goto(self, event: Any) -> None:
        if event.client is None:
            return
        oid = self._ids.get(str(self._goto.value))
        if oid is None:
            return
        threading.Thread(target=self.go_to, args=(oid, event.client), daemon=True).start()
        self._goto.value = PLACEHOLDER  # ready for the next choice (the same object again, too)

    def go_to(self, object_id: str, client: Any = None) -> bool:
        """Plan a candidate to the floor beside ``object_id`` (:meth:`Session.go_to_object`: an id merged away
        meanwhile goes to the object it was merged into, and the goal follows a later merge); tell ``client``."""
        try:
            res, obj, app = self._session.go_to_object(object_id)
        except SessionError as exc:
            tell(client, "Cannot go there", str(exc), "red")
            return False
        if not res.ok:
            tell(client, "Goal not reachable", res.message, "red")
            return False
        how = {"walk": "walking", "fly": "flying over what is in the way"}.get(app.mode, app.mode)
        g = app.goal
        tell(client, f"Go to {nice(obj.label)}",
             f"candidate to ({g[0]:.2f}, {g[1]:.2f}) m beside {obj.id}, by {how}: {res.message}. Register to keep it.",
             "blue")
        return True


__all__ = ["SceneSummaryView", "option_label", "summary_html"]
