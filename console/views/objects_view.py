"""Mapped objects in the 3D view: one labelled proxy mesh per object, selection, delete and move.

Each object is drawn with its catalog proxy model (a unit-cube GLB, y-up as glTF says: X = width,
Y = up, Z = length along the heading), scaled by ``[w, h, l]`` along those axes, turned into the z-up world
and by its yaw about +z, and placed at its box centre (world frame [m]). Labels without a catalog model, or a missing catalog,
fall back to a plain box. Clicking an object (or choosing it in the list) selects it: its details
appear in the panel, where it can be moved (typed centre and yaw, or dragged with a gizmo that slides
it on its support and turns it about +z), pinned or unpinned (Pin / Unpin: captures never move a pinned
object; the label follows its state) or deleted.
"""

from __future__ import annotations

import colorsys
import hashlib
import html
import logging
import math
import threading
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any, Callable, Sequence

import viser

from pipeline.rotation import quat_wxyz_yaw, yaw_gltf_quat_wxyz, yaw_quat_wxyz
from pipeline.scene import SceneObject

from console.views import confirm
from console.views.client_notice import tell
from console.views.object_history import history_lines
from console.views.object_labels import ClientLabels, LabelSpot
from console.views.picking import SELECT_MODIFIER, click_intent
from console.views.pose_fields import PoseFields
from console.session.session import SCENE, SELECTION, Session, SessionError
from console.wording import natural_sorted, plural

log = logging.getLogger(__name__)

NONE_CHOICE = "(none)"
SELECTION_RGB = (0, 200, 255)
DROP_TOLERANCE_M = 1e-3  # a gizmo released closer than this to where it was grabbed did not move [m]
DROP_TOLERANCE_RAD = 1e-3  # ... nor turn [rad]
Vec3 = tuple[float, float, float]


yaw_wxyz = yaw_quat_wxyz  # viser's scene nodes take (w, x, y, z): pipeline.rotation says the orders
wxyz_yaw = quat_wxyz_yaw


def label_color(label: str) -> tuple[int, int, int]:
    """A stable, pleasant colour for a label without a catalog colour."""
    h = int(hashlib.sha1(label.encode()).hexdigest()[:6], 16) / 0xFFFFFF
    r, g, b = colorsys.hls_to_rgb(h, 0.55, 0.45)
    return (int(r * 255), int(g * 255), int(b * 255))


def _node_key(object_id: str) -> str:
    """A scene-tree-safe name for an object id."""
    safe = "".join(c if c.isalnum() or c in "-_" else "_" for c in object_id)
    return f"{safe}_{hashlib.sha1(object_id.encode()).hexdigest()[:6]}"


def label_groups(objects: Sequence[SceneObject], reach: float = 0.8) -> list[tuple[str, Vec3, list[str]]]:
    """One label per cluster of same-label objects (e.g. a stack of boxes): ``(text, position, ids)``.

    Objects of one label are clustered when their centres lie within ``reach`` [m] of each other
    (horizontally, chaining); the label sits above the cluster's tallest top (world frame [m]).
    """
    out: list[tuple[str, Vec3, list[str]]] = []
    by_label: dict[str, list[SceneObject]] = {}
    for o in objects:
        by_label.setdefault(o.label, []).append(o)
    for label, objs in by_label.items():
        left = list(range(len(objs)))
        while left:
            cluster = [left.pop(0)]
            grew = True
            while grew:
                grew = False
                for j in list(left):
                    if any(math.dist(objs[j].position[:2], objs[k].position[:2]) <= reach for k in cluster):
                        cluster.append(j)
                        left.remove(j)
                        grew = True
            members = [objs[k] for k in cluster]
            x = sum(m.position[0] for m in members) / len(members)
            y = sum(m.position[1] for m in members) / len(members)
            top = max(m.position[2] + m.size[1] / 2 for m in members)
            text = label.replace("_", " ") + (f" ×{len(members)}" if len(members) > 1 else "")
            out.append((text, (x, y, top + 0.08), [m.id for m in members]))
    return out


class ProxyModels:
    """Proxy meshes and colours per label, from the catalog when it is available."""

    def __init__(self) -> None:
        self._glb: dict[Path, bytes | None] = {}
        self.catalog: Any = None
        self.problem: str | None = None
        try:
            from pipeline.catalog import Catalog

            self.catalog = Catalog.load()
        except Exception as exc:  # missing module, files or a malformed catalog: draw boxes
            self.problem = str(exc)
            log.warning("object catalog unavailable, drawing plain boxes: %s", exc)

    def entry(self, label: str) -> Any:
        if self.catalog is None:
            return None
        try:
            return self.catalog.lookup(label)
        except Exception:
            return None

    def color(self, label: str) -> tuple[int, int, int]:
        e = self.entry(label)
        return tuple(e.color) if e is not None else label_color(label)  # type: ignore[return-value]

    def glb(self, label: str) -> bytes | None:
        """GLB bytes of the label's proxy model (fallback model for unknown labels), or ``None``."""
        e = self.entry(label)
        path: Path | None = None
        if e is not None:
            path = e.model_path
        elif self.catalog is not None:
            try:
                from assets import FALLBACK_MODEL, PROXY_DIR

                path = PROXY_DIR / FALLBACK_MODEL
            except ImportError:
                path = None
        if path is None:
            return None
        if path not in self._glb:
            try:
                self._glb[path] = path.read_bytes()
            except OSError as exc:
                log.warning("proxy model %s unreadable: %s", path, exc)
                self._glb[path] = None
        return self._glb[path]


def describe(obj: SceneObject) -> str:
    """Markdown (HTML-escaped) with everything known about an object."""
    e = html.escape
    s = obj.source
    w, h, l = obj.size
    lines = [
        f"**{e(obj.label)}** <small>`{e(obj.id)}`</small>",
        "",
        "| | |",
        "|---|---|",
        f"| score | {obj.score:.2f} |",
        f"| centre (world) | {obj.position[0]:.2f}, {obj.position[1]:.2f}, {obj.position[2]:.2f} m |",
        f"| size w×h×l | {w:.2f} × {h:.2f} × {l:.2f} m{'' if obj.size_known else ' (measured)'} |",
        f"| yaw | {math.degrees(obj.yaw):.0f}° |",
        f"| estimate | {e(s.method)} |",
        f"| source capture | {e(s.capture) if s.capture else 'none (manual)'} |",
    ]
    names = {"ground_contact_bound": "ground contact (maybe hidden: at most)"}
    for key in ("geometric", "ground_contact", "ground_contact_bound", "depth", "fused"):
        if key in s.distances:
            v = s.distances[key]
            lines.append(f"| distance, {names.get(key, key.replace('_', ' '))} | {'—' if v is None else f'{v:.2f} m'} |")
    if obj.sigma is not None:  # the mapper's fused 1-sigma along the camera ray (issue 11)
        lines.append(f"| sigma along the ray | {obj.sigma:.2f} m{' (cut: ' + ', '.join(obj.cut) + ')' if obj.cut else ''} |")
    if s.bbox is not None:
        lines.append(f"| box in photo | {', '.join(f'{v:.0f}' for v in s.bbox)} px |")
    lines += history_lines(obj)  # pin, fusion flags, observations (console/views/object_history.py)
    return "\n".join(lines)


class ObjectsView:
    """Proxy meshes + labels for the scene's objects, and the selected object's panel.

    Args:
        server: The viser server.
        session: The state it draws and edits.
        on_node_click: Called with the clicking client's id when an object is clicked, so a
            click on an object is not also taken as a goal on the floor behind it.
        layers: A GUI folder to put the label toggle in (the grid view's layer folder).
    """

    def __init__(self, server: viser.ViserServer, session: Session,
                 on_node_click: Callable[[int], None] | None = None, layers: Any = None) -> None:
        self._server = server
        self._session = session
        self._models = ProxyModels()
        self._lock = threading.RLock()
        self._drawn: dict[str, tuple[SceneObject, list[Any]]] = {}
        self._on_node_click = on_node_click
        hint = ("Labels above the objects, as many as fit without overlapping (the selected object's first, "
                "then the nearest); zoom in for more")
        if layers is not None:
            with layers:
                self._show_labels = server.gui.add_checkbox("Object labels", True, hint=hint)
        else:
            self._show_labels = server.gui.add_checkbox("Object labels", True, hint=hint)
        self.labels = ClientLabels(server, lambda: getattr(self._session.selected, "id", None), self._robot_label)
        """The object labels of every tab, decluttered per tab (:mod:`console.views.object_labels`)."""
        self._show_labels.on_update(lambda _e: self.labels.set_enabled(bool(self._show_labels.value)))
        self._summary = server.gui.add_markdown("")
        self._chooser = server.gui.add_dropdown("Select object", (NONE_CHOICE,), hint="Or click an object in the 3D view")
        self._chooser.on_update(self._on_choose)
        # its label, state and click belong to console.views.redo_view.RedoView (Undo and Redo together)
        self._undo = server.gui.add_button("Undo", icon=viser.Icon.ARROW_BACK_UP, color="gray", disabled=True,
                                           hint="Undo the last spawn, move, delete, capture or load")
        with server.gui.add_folder("Selected object", visible=False) as folder:
            self._folder = folder
            self._details = server.gui.add_markdown("")
            self._pose = PoseFields(server.gui)  # text fields checked here: a browser's number input drops junk
            move = server.gui.add_button("Move", icon=viser.Icon.ARROWS_MOVE, hint="Put the object at the centre and yaw above")
            self._pin = server.gui.add_button("Pin", icon=viser.Icon.PINNED, color="gray")  # Pin / Unpin: its state
            delete = server.gui.add_button("Delete", color="red", icon=viser.Icon.TRASH)
            close = server.gui.add_button("Deselect", color="gray")
        move.on_click(self._on_move)
        self._pin.on_click(self._on_pin)
        delete.on_click(self._on_delete)
        close.on_click(lambda _e: self._session.select(None))
        self._selection_box: Any = None
        self._drops = ThreadPoolExecutor(max_workers=1, thread_name_prefix="gizmo-drop")
        self._gizmo: Any = None
        self._gizmo_for: tuple[str, Vec3, float] | None = None  # (id, centre, yaw) the gizmo was placed at
        session.subscribe(self._on_event)
        self.redraw()

    # --- drawing --------------------------------------------------------------------------------
    def _on_event(self, topic: str, _payload: Any) -> None:
        if topic == SCENE:
            self.redraw()
        elif topic == SELECTION:
            self._show_selection()
            self.labels.refresh_all()  # the selected object's label first

    def _add(self, obj: SceneObject) -> list[Any]:
        key = _node_key(obj.id)
        l_w_h = (obj.size[2], obj.size[0], obj.size[1])
        wxyz = yaw_wxyz(obj.yaw)
        glb = self._models.glb(obj.label)
        name = f"/objects/{key}"
        if glb is not None:
            # the GLB is y-up (glTF): turned into the z-up scene and scaled by [w, h, l] along its own axes
            mesh = self._server.scene.add_glb(name, glb, scale=tuple(obj.size), wxyz=yaw_gltf_quat_wxyz(obj.yaw),
                                              position=obj.position)
        else:
            mesh = self._server.scene.add_box(name, color=self._models.color(obj.label), dimensions=l_w_h,
                                              wxyz=wxyz, position=obj.position, opacity=0.95)
        oid = obj.id

        async def clicked(event: Any) -> None:
            # async: runs on the event loop before the scene-wide click, so it can claim it. In goal
            # mode a plain click is not ours: the scene-wide click makes it a goal through the object
            if click_intent(self._session.settings.click_to_goal, event.modifier, on_object=True) != "select":
                return
            if self._on_node_click is not None:
                self._on_node_click(event.client_id)
            threading.Thread(target=self._select_quietly, args=(oid,), daemon=True).start()

        mesh.on_click(clicked)
        mesh.on_click(modifier=SELECT_MODIFIER)(clicked)
        return [mesh]

    def _select_quietly(self, object_id: str) -> None:
        try:
            self._session.select(object_id)
        except SessionError:
            pass  # deleted meanwhile

    def redraw(self) -> None:
        """Bring the drawn meshes in line with the session's scene (only changed objects)."""
        with self._lock:  # read inside the lock: the last redraw always draws the latest scene
            scene = self._session.scene
            current = {o.id: o for o in scene.objects}
            for oid in list(self._drawn):
                if oid not in current or current[oid] != self._drawn[oid][0]:
                    for h in self._drawn.pop(oid)[1]:
                        h.remove()
            for oid, obj in current.items():
                if oid not in self._drawn:
                    self._drawn[oid] = (obj, self._add(obj))
            self.labels.set_spots([LabelSpot(text, pos, tuple(ids)) for text, pos, ids in label_groups(scene.objects)])
            ws = self._session.workspace
            outside = [o for o in scene.objects if not ws.contains(o.position)]
            self._summary.content = (
                f"<small>{plural(len(scene.objects), 'object')}"
                + (f" · <b style='color:#b35900'>{len(outside)} outside the workspace</b> (the planner ignores them)"
                   if outside else "") + "</small>") if scene.objects else ""
            options = (NONE_CHOICE,) + tuple(natural_sorted(current))
            if tuple(self._chooser.options) != options:
                self._chooser.options = options
        self._show_selection()

    def _robot_label(self) -> list[tuple[str, tuple[float, float, float]]]:
        """The robot's label (text and anchor, world [m]) that object labels leave free."""
        robot = self._session.robot
        if robot is None:
            return []
        x, y, z = (float(v) for v in robot.pose.translation)
        return [("robot · walking", (x, y, z + 0.55))]

    def _show_selection(self) -> None:
        with self._lock:
            obj = self._session.selected
            if self._selection_box is not None:
                self._selection_box.remove()
                self._selection_box = None
            self._place_gizmo(obj)
            if obj is None:
                self._folder.visible = False
                if self._chooser.value != NONE_CHOICE:
                    self._chooser.value = NONE_CHOICE  # Deselect (or a deletion) clears the list too
                return
            w, h, l = obj.size
            # a see-through glow box around the object, with its own bright outline as a child
            self._selection_box = self._server.scene.add_box(
                "/selection", color=SELECTION_RGB, dimensions=(l + 0.1, w + 0.1, h + 0.1), opacity=0.35,
                wxyz=yaw_wxyz(obj.yaw), position=obj.position, cast_shadow=False, receive_shadow=False,
            )
            self._server.scene.add_box(
                "/selection/outline", color=SELECTION_RGB, dimensions=(l + 0.12, w + 0.12, h + 0.12), wireframe=True,
                cast_shadow=False, receive_shadow=False,
            )
            self._details.content = describe(obj)
            self._show_pin(obj)
            self._pose.show(obj.position, obj.yaw)
            self._folder.visible = True
            if self._chooser.value != obj.id:
                self._chooser.value = obj.id

    def _place_gizmo(self, obj: SceneObject | None) -> None:
        """Put the drag gizmo on the selected object (only x / y slides and the turn about +z)."""
        at = None if obj is None else (obj.id, obj.position, obj.yaw)
        if at == self._gizmo_for:
            return  # unchanged: keep it (re-creating it would cut a drag in another tab)
        if self._gizmo is not None:
            self._gizmo.remove()
            self._gizmo = None
        self._gizmo_for = at
        if obj is None:
            return
        self._gizmo = self._server.scene.add_transform_controls(
            "/selection_gizmo", scale=0.4 + 0.6 * max(obj.size), active_axes=(True, True, False),
            depth_test=False, position=obj.position, wxyz=yaw_wxyz(obj.yaw),
        )
        oid = obj.id

        async def dragged(event: Any) -> None:
            # async keeps the phases in order; the move itself (grid rebuild) runs off the event loop,
            # one drop after the other in the order they were made
            if event.target is not self._gizmo:
                return  # a late event of a gizmo already replaced
            pose = (tuple(float(v) for v in event.target.position), wxyz_yaw(event.target.wxyz))
            box = self._selection_box
            if event.phase == "update" and box is not None:
                box.position, box.wxyz = pose[0], yaw_wxyz(pose[1])
            elif event.phase == "end":
                self._drops.submit(self._drop_and_tell, oid, pose[0][:2], pose[1], event.client)

        self._gizmo.on_update(dragged)

    def gizmo_pose(self) -> tuple[Vec3, float] | None:
        """Centre (world [m]) and yaw [rad] of the drag gizmo, ``None`` when nothing is selected."""
        with self._lock:
            g = self._gizmo
            return None if g is None else (tuple(float(v) for v in g.position), wxyz_yaw(g.wxyz))  # type: ignore[return-value]

    def drop(self, object_id: str, xy: Sequence[float], yaw: float) -> list[str] | None:
        """Finish a gizmo drag: the object keeps its height and takes the new ``xy`` [m] and ``yaw`` [rad].

        Returns the move's notes, or ``None`` when the pose did not change (a click on the gizmo:
        nothing is rebuilt, the route and mission stay).

        Raises:
            SessionError: The object is gone or the place is refused; the gizmo goes back to the object.
        """
        try:
            try:
                obj = self._session.scene.object(object_id)
            except KeyError:
                raise SessionError(f"no object {object_id!r} in the map (was it deleted in another tab?)") from None
            turn = math.remainder(float(yaw) - obj.yaw, math.tau)
            if math.dist(obj.position[:2], xy[:2]) < DROP_TOLERANCE_M and abs(turn) < DROP_TOLERANCE_RAD:
                return None
            return self._session.move_object(object_id, (float(xy[0]), float(xy[1]), obj.position[2]), yaw)
        except SessionError:
            with self._lock:
                self._gizmo_for = None  # re-place it where the object still is
            self._show_selection()
            raise

    def _drop_and_tell(self, object_id: str, xy: Sequence[float], yaw: float, client: Any) -> None:
        try:
            notes = self.drop(object_id, xy, yaw)
        except SessionError as exc:
            tell(client, "Cannot move", str(exc), "red")
            return
        if notes is not None:
            tell(client, "Moved", "; ".join(notes) or "grid rebuilt")

    # --- operator actions -----------------------------------------------------------------------
    def _on_choose(self, event: Any) -> None:
        if event.client is None:
            return  # set by the server itself (mirroring a selection)
        value = self._chooser.value
        current = self._session.selected
        if value == NONE_CHOICE:
            if current is not None:
                self._session.select(None)
            return
        if current is not None and current.id == value:
            return
        try:
            self._session.select(value)
        except SessionError as exc:
            tell(event.client, "Cannot select", str(exc), "red")

    def _on_move(self, event: Any) -> None:
        obj = self._session.selected
        if obj is None:
            tell(event.client, "Nothing selected", "click an object first (Shift-click in goal mode)", "yellow")
            return
        try:  # every field checked before anything moves: junk in one refuses the whole move, named
            centre, yaw = self._pose.read(self._session.workspace)
            notes = self._session.move_object(obj.id, centre, yaw)
        except SessionError as exc:
            self._show_selection()  # any refusal: the fields show the object's real pose again
            tell(event.client, "Cannot move", str(exc), "red")
            return
        tell(event.client, f"Moved {obj.label}", "; ".join(notes) or "grid rebuilt", color="blue")

    def _show_pin(self, obj: SceneObject) -> None:
        """The Pin / Unpin button follows the selected object's state (one button, its label the action)."""
        label, hint = (("Unpin", "Let captures correct its position again (Undo pins it back)") if obj.is_pinned else
                       ("Pin", "Keep it where it is: captures that see it never move it"))
        if self._pin.label != label:
            self._pin.label, self._pin.icon = label, viser.Icon.PINNED_OFF if obj.is_pinned else viser.Icon.PINNED
        if self._pin.hint != hint:
            self._pin.hint = hint

    def _on_pin(self, event: Any) -> None:
        obj = self._session.selected
        if obj is None:
            tell(event.client, "Nothing selected", "click an object first (Shift-click in goal mode)", "yellow")
            return
        verb, said = (("unpin", "captures may correct its position again") if obj.is_pinned else
                      ("pin", "captures never move it"))
        try:
            notes = self._session.set_pinned(obj.id, verb == "pin")
        except SessionError as exc:
            tell(event.client, f"Cannot {verb}", str(exc), "red")
            return
        tell(event.client, f"{verb.capitalize()}ned {obj.id}", "; ".join([said] + notes), "blue")

    def _on_delete(self, event: Any) -> None:
        obj = self._session.selected
        if obj is None:
            tell(event.client, "Nothing selected", "click an object first (Shift-click in goal mode)", "yellow")
            return

        def delete() -> None:
            try:
                notes = self._session.delete_object(obj.id)
            except SessionError as exc:
                tell(event.client, "Cannot delete", str(exc), "red")
                return
            tell(event.client, f"Deleted {obj.label}", "; ".join(notes) or "grid rebuilt", color="blue")

        confirm.ask(event.client, f"Delete {obj.id}?",
                    f"{obj.label} {obj.id} leaves the map and the planning grid (Undo brings it back).",
                    "Delete object", delete)

    def colors(self, label: str) -> tuple[int, int, int]:
        """Display colour of a label (the catalog's, else a stable hashed one)."""
        return self._models.color(label)

    def highlighted(self) -> str | None:
        """Id of the object drawn highlighted (``None``: no highlight), for tests."""
        with self._lock:
            obj = self._session.selected
            return obj.id if obj is not None and self._selection_box is not None else None

    def chooser_value(self) -> str:
        """What the "Select object" list shows."""
        return str(self._chooser.value)

    def drawn_ids(self) -> list[str]:
        """Ids of the objects currently drawn (for tests)."""
        with self._lock:
            return sorted(self._drawn)
