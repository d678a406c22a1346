"""The operator console: a viser server showing the digital twin, wired to the session and the robot.

:class:`ConsoleApp` builds the pieces and connects them; it holds no state of its own beyond
handles (the state is :class:`~console.session.session.Session`). Layout: the control panel on the right
(robot status, Mission, Map, Plan, Session) and a camera panel on the left (photo with detections,
depth); the 3D view shows the workspace, grid layers, objects, paths, the robot twin and the last
capture's frustum. Every browser tab shares the same scene and controls.

Safety: the server binds to 127.0.0.1 unless another host is given explicitly; any other
address is warned about, since whoever reaches the port can drive the robot.
"""

from __future__ import annotations

import html
import logging
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping

import viser

from planner.grid import Workspace

from console.hosts import LOOPBACK_NAMES, check_listenable, is_loopback  # noqa: F401  (importable from here as before)
from console.views.capture_view import CaptureView
from console.views.grid_view import GridView
from console.session.mapping_job import MappingJob, Perceiver
from console.session.model_preload import ModelPreload
from console.views.mission_view import MissionRunner, MissionView
from console.views.objects_view import ObjectsView
from console.views.paths_view import PathsView
from console.views.scene_summary_view import SceneSummaryView
from console.views.client_notice import install_tab_rules, page_style, tell
from console.views.page_a11y import install_page_a11y
from console.views.robot_view import RobotView, is_alert
from console.session.scene_watch import FrameError, NotReady, SceneWatcher, objects_to_world
from console.wording import plural
from console.session.session import JOB, NOTICE, SESSION_FILE, JobStatus, Notice, Session
from console.session.session_types import robot_snapshot

log = logging.getLogger(__name__)

BRAND_RGB = (0, 122, 204)
RIGHT_PANEL_PX = 370  # width of the right-docked control panel [px]


@dataclass
class ConsoleConfig:
    """How to start the console.

    Attributes:
        robot: Robot link spec: ``sim`` or ``mavlink:<pymavlink connection string>``.
        scene_dir: Watched scene folder (scene JSON files dropped there are spawned).
        session_dir: Session folder (saves, capture images).
        host: Interface to listen on; 127.0.0.1 unless explicitly asked otherwise.
        port: TCP port (0 = any free port).
        models: Folder with offline model weights, or ``None`` (simulator: ground truth).
        fresh: Start from an empty session instead of restoring the last one.
        resolution: Planning grid cell size [m].
        margin: Robot radius [m] (dangerous margin around obstacles).
        captures: Folder of real photos (the format of ``../shared/bench/dev``) served as the robot's
            camera instead of its own, or ``None``.
        failsafe_after: Seconds without hearing the robot before the mission failsafe holds it.
        failsafe_hold: Seconds of holding, link still lost, before the failsafe lands the robot.
        link_options: Extra keyword options for :func:`console.link.open_link` (e.g. a MAVLink
            ``config`` with the NED frame and the ground-motion command set).
        record: Record the session as MCAP in ``<session>/recordings`` (:mod:`console.recording.recording`).
        foxglove_port: Also serve the recorded topics live over the Foxglove WebSocket protocol on
            127.0.0.1 at this port (0 = any free port), or ``None`` (off).
        mcp_port: Also serve the MCP server for language-model agents (:mod:`console.mcp`) over
            streamable HTTP on 127.0.0.1 at this port (0 = any free port), or ``None`` (off).
        mcp_allow_actions: That server offers the proposal tools (each needs the operator's Approve).
        agent_real_vehicle: Allow agent proposals on a real (non-loopback) vehicle link.
        world: The simulator's world (:class:`~console.link.world_file.World` or a world file's path;
            ``None``: the paper's room): its hidden objects, bounds (the workspace), walls and start.
        perception: The simulator's perception without ``models``: ``exact`` (its ground truth) or
            ``noisy`` (box jitter, missed and false detections: :mod:`console.link.sim_perception_noise`).
    """

    robot: str = "sim"
    scene_dir: Path | None = None
    session_dir: Path = Path(".morphonavi/session")
    host: str = "127.0.0.1"
    port: int = 8080
    models: Path | None = None
    fresh: bool = False
    resolution: float = 0.25
    margin: float = 0.35
    captures: Path | None = None
    failsafe_after: float = 3.0
    failsafe_hold: float = 5.0
    link_options: Mapping[str, Any] = field(default_factory=dict)
    record: bool = True
    foxglove_port: int | None = None
    mcp_port: int | None = None
    mcp_allow_actions: bool = False
    agent_real_vehicle: bool = False
    world: Any = None
    perception: str = "exact"


class ConsoleApp:
    """The running console: server, session, robot link, views, background jobs.

    Args:
        config: Start-up options.
        link: A robot link to use instead of opening ``config.robot`` (tests).
        perceiver: A perception backend to use instead of choosing one (tests).
    """

    def __init__(self, config: ConsoleConfig, link: Any = None, perceiver: Perceiver | None = None) -> None:
        self.config = config
        self._link_override = link
        self._perceiver_override = perceiver
        self.server: viser.ViserServer | None = None
        self.session: Session | None = None
        self.link: Any = None
        self.world: Any = None  # the simulator's World (console.link.world_file), set by start()
        self.mapping: MappingJob | None = None
        self.preload: ModelPreload | None = None
        self.runner: MissionRunner | None = None
        self.watcher: SceneWatcher | None = None
        self._file_objects: dict[str, tuple[str, ...]] = {}  # watched file name -> the object ids it added
        self.views: dict[str, Any] = {}
        self._closers: list[Callable[[], None]] = []
        self._stopped = threading.Event()

    # --- start / stop ------------------------------------------------------------------------------
    @property
    def url(self) -> str:
        assert self.server is not None, "start() first"
        host = self.config.host if self.config.host not in ("0.0.0.0", "::") else "127.0.0.1"
        return f"http://{host}:{self.server.get_port()}/"

    def start(self) -> "ConsoleApp":
        """Open the link, restore the session, start the server and the background threads."""
        cfg = self.config
        check_listenable(cfg.host)
        if not is_loopback(cfg.host):
            log.warning("listening on %s: anyone who can reach this address and port can see the map and "
                        "DRIVE THE ROBOT; there is no login. Use the default 127.0.0.1 unless you must.", cfg.host)
        from console.link.world_file import World, load_world, paper_world

        world = (cfg.world if isinstance(cfg.world, World) else load_world(cfg.world) if cfg.world is not None
                 else paper_world())  # --world FILE: the simulator's hidden room, bounds and start
        self.world = world
        options = {**world.link_options(cfg.resolution), **cfg.link_options} if cfg.robot == "sim" else cfg.link_options
        self.link = self._link_override if self._link_override is not None else self._open_link(cfg.robot, cfg.captures, options)
        start = world.start.translation
        ws = world.workspace(cfg.resolution)
        self.session = session = Session(cfg.session_dir, start=start, workspace=ws, margin=cfg.margin,
                                         empty_is_unseen=True)  # a room nobody has looked at: nothing seen yet
        restored: list[str] | None = None
        if not cfg.fresh:  # a bad file is kept aside by the session; SessionError (what to do) if it cannot be
            restored = session.restore_last()
        from console.recording.recording import start_recording  # mission log (MCAP) in the session folder, closed last

        self.recorder = start_recording(session, foxglove_port=cfg.foxglove_port) if cfg.record else None
        if self.recorder is not None:
            self._closers.append(self.recorder.close)
        perceiver = self._perceiver_override or self._choose_perceiver()
        self.preload = ModelPreload(session, perceiver)  # started once the page is up: progress in the page
        from console.session.photo_pose import photo_pairing  # a live camera's frame at the pose of its time

        self.mapping = MappingJob(session, self._take_photo, perceiver, self.preload, photo_pairing(self.link))
        self.runner = self._make_runner()

        self.server = server = viser.ViserServer(host=cfg.host, port=cfg.port, label="MorphoNavi", verbose=False)
        self._closers.append(server.stop)
        self._layout(perceiver)
        session.subscribe(self._on_session_event)
        self.preload.start()  # the models load in the background; a capture before they are ready waits
        from console.session.planner_warmup import start_planner_warmup

        start_planner_warmup()  # the planner's compiled kernels loaded now: the first Add goal is planned at once
        self._connect_robot()
        if self.runner is not None and hasattr(self.runner, "close"):
            self._closers.append(self.runner.close)  # stopped before the link closes

        scene_dir = cfg.scene_dir if cfg.scene_dir is not None else session.folder.parent / "scenes"
        self.watcher = SceneWatcher(scene_dir, self._spawn_file, self._bad_file, spawn_existing=restored is None)
        self.watcher.start()
        self._closers.append(self.watcher.stop)
        from console.mcp.attach import attach_agent  # the Agent panel, `morphonavi mcp`'s door, `--mcp`

        attach_agent(self)
        log.info("MorphoNavi console at %s (robot: %s, session: %s, watched scenes: %s)",
                 self.url, cfg.robot, session.folder, self.watcher.folder)
        if restored:
            for note in restored:
                log.info("restored session: %s", note)
        return self

    def stop(self) -> None:
        """Stop threads, close the link and the server (idempotent)."""
        if self._stopped.is_set():
            return
        self._stopped.set()
        for close in reversed(self._closers):
            try:
                close()
            except Exception:
                log.exception("error while stopping")
        self._closers.clear()
        # a model being loaded cannot be interrupted, and a process that exits while onnxruntime builds a
        # session in a daemon thread aborts ('terminate called without an active exception'): let it end
        if self.preload is not None and not self.preload.join(0.0):
            log.info("waiting for the model loading to end before stopping")
            if not self.preload.join(120.0):
                log.warning("the model loading did not end within 120 s")

    def serve_forever(self, ready: Callable[[], None] | None = None) -> None:
        """Block until Ctrl-C or SIGTERM (``kill``, a service manager), then stop: the recording is finished.

        ``ready`` is called once both signals are handled (e.g. to print the URL).
        """
        import signal

        def _terminate(signum: int, frame: Any) -> None:
            raise KeyboardInterrupt

        old = None
        if threading.current_thread() is threading.main_thread():
            old = signal.signal(signal.SIGTERM, _terminate)
        try:
            if ready is not None:
                ready()
            while not self._stopped.wait(0.5):
                pass
        except KeyboardInterrupt:
            pass
        finally:
            if old is not None:
                signal.signal(signal.SIGTERM, old)
            self.stop()

    # --- robot link ---------------------------------------------------------------------------------
    @staticmethod
    def _open_link(spec: str, captures: Path | None = None, options: Mapping[str, Any] | None = None) -> Any:
        from console.link import open_link

        return open_link(spec, connect=False, captures=captures, **dict(options or {}))  # connected in the background: no vehicle, still a console

    def _connect_robot(self) -> None:
        """Connect in the background (a missing vehicle must not stop the console) and stream state."""
        link, session = self.link, self.session
        assert session is not None

        seen = [0]  # number of the newest robot message already told
        seen_lock = threading.Lock()

        def on_state(st: Any) -> None:
            if self._stopped.is_set():
                return  # a late state while shutting down: the views are gone
            messages = tuple(getattr(st, "messages", ()))
            session.set_robot(robot_snapshot(st))
            with seen_lock:  # state arrives from the link's thread and from connect()
                fresh = [text for number, text in messages if number > seen[0]]
                seen[0] = max([seen[0]] + [number for number, _ in messages])
            for text in fresh:
                if is_alert(text):
                    session.notify("Robot says", text, "warning")

        self._closers.append(link.subscribe(on_state))

        def connect() -> None:
            failures = 0
            while not self._stopped.is_set():
                try:
                    if not link.connected:
                        link.connect(timeout=10.0)
                    st = link.latest_state()
                    if st is not None:
                        on_state(st)
                    if failures:
                        session.notify("Robot link", f"connected to {self.config.robot}", "success")
                    return
                except Exception as exc:
                    failures += 1
                    if failures == 1:  # tell the operators once; keep retrying quietly
                        session.notify("Robot link", f"cannot connect to {self.config.robot}: {exc}; "
                                       "retrying every few seconds", "warning")
                    else:
                        log.info("robot link still down (%d attempts): %s", failures, exc)
                    self._stopped.wait(3.0)

        threading.Thread(target=connect, name="robot-connect", daemon=True).start()
        self._closers.append(link.close)

    def _take_photo(self) -> Any:
        if not self.link.connected:
            raise RuntimeError(f"the robot link ({self.config.robot}) is not connected")
        return self.link.capture()

    # --- pluggable backends -------------------------------------------------------------------------
    def _choose_perceiver(self) -> Perceiver:
        from console.session.mapping_job import choose_perceiver

        return choose_perceiver(self.link, self.config.models, self.config.perception)

    def _make_runner(self) -> MissionRunner | None:
        from console.views.mission_view import make_runner

        assert self.session is not None
        return make_runner(self.link, self.session, failsafe_after=self.config.failsafe_after,
                           failsafe_hold=self.config.failsafe_hold)

    # --- layout ----------------------------------------------------------------------------------------
    def _layout(self, perceiver: Perceiver) -> None:
        server, session = self.server, self.session
        assert server is not None and session is not None
        gui = server.gui
        server.gui.configure_theme(show_share_button=False, brand_color=BRAND_RGB, control_width="large",
                                   show_logo=False)
        from console.views.screen_layout import PIN_MARK, install_phone_view, install_pin_script, layout_style
        from console.views.view_fit import default_view

        ws = session.workspace  # the default view fits the whole flight volume between the panels at 1280 x 720
        position, look_at, up = default_view(ws, float(server.initial_camera.fov))
        server.initial_camera.position, server.initial_camera.look_at, server.initial_camera.up = position, look_at, up
        install_phone_view(server, ws, lambda: None if session.robot is None else tuple(session.robot.pose.translation))

        paths_holder: dict[str, PathsView] = {}
        gui.add_html(page_style(RIGHT_PANEL_PX))  # notifications bottom right; the "disconnected" banner
        gui.add_html(layout_style())  # the robot and mission block pinned; tables unwrapped; the phone's sheet
        install_pin_script(server)  # a control scrolled into view lands below the pinned block
        install_tab_rules(server)  # a tab in the background reconnects too; notices forgotten with their tab
        install_page_a11y(server)  # every field linked to its label; buttons show their hover text (console.views.page_a11y)
        from console.session.vehicle_commands import VehicleCommands

        self.commands = VehicleCommands(session, self.link, self.runner)  # also the agent's Hold / Land here / Return
        # the robot status, its buttons, the mission and its run controls: pinned at the top of the panel,
        # in sight at 1280 x 720 and up while the rest scrolls (console.views.screen_layout)
        with gui.add_folder("Robot and mission"):
            gui.add_html(PIN_MARK)
            self.views["robot"] = RobotView(server, session, self.config.robot, commands=self.commands)
            self.views["mission"] = MissionView(server, session, self.runner)
        with gui.add_folder("Map"):
            cap = gui.add_button("Capture & map", icon=viser.Icon.CAMERA, color="blue",
                                 hint="Ask the robot for a photo and its pose, detect objects and add them to the map")
            self._job_bar = gui.add_progress_bar(0.0, visible=False, animated=True)
            self._job_md = gui.add_markdown(f"<small>perception: <b>{html.escape(perceiver.label)}</b></small>")
            from console.views.notice_details import NoticeDetails  # a long notice's whole text, one click away

            self.views["notices"] = NoticeDetails(server)
            cap.on_click(self._on_capture)
            from console.session.look import LookJob  # Look around / Look at: turn in place, capture & map
            from console.views.look_view import LookView

            self.look = LookJob(session, self.link, self.mapping)
            self._closers.append(self.look.stop)
            from console.session.go_look import GoLookJob  # the suggested look towards a goal not seen yet

            self.go_look = GoLookJob(session, self.link, self.mapping, self.runner) if self.runner is not None else None
            if self.go_look is not None:
                self._closers.append(self.go_look.stop)
            self.views["look"] = LookView(server, session, self.look,
                                          lambda: tuple(paths_holder["p"].typed_values()[:2]),  # type: ignore[arg-type]
                                          go_look=self.go_look, capture=cap, mapping=self.mapping)
            from console.views.held_capture import HeldCaptureControls  # Merge / Replace / Discard a held-back capture

            self.views["held_capture"] = HeldCaptureControls(server, session, self.mapping)
            self.views["grid"] = GridView(server, session)
            from console.views.known_space_view import KnownSpaceView, UnknownToggle  # seen / unseen / unlabelled

            self.views["known_space"] = KnownSpaceView(server, session, layers=self.views["grid"].layers_folder)
            self.views["objects"] = ObjectsView(
                server, session, on_node_click=lambda cid: paths_holder["p"].note_node_click(cid) if paths_holder else None,
                layers=self.views["grid"].layers_folder)
            from console.views.redo_view import RedoView  # Redo beside the objects panel's Undo; Ctrl+(Shift+)Z

            self.views["redo"] = RedoView(server, session, getattr(self.views["objects"], "_undo", None))
        with gui.add_folder("Plan"):
            paths_holder["p"] = self.views["paths"] = PathsView(server, session)
            self.views["look"].follow_goal(paths_holder["p"].goal_fields)  # Look at goal / Go look: off at the robot
            self.views["unknown_toggle"] = UnknownToggle(server, session)
        with gui.add_folder("Find", expand_by_default=False):  # the search: viewpoints, moves, captures until found
            from console.session.search import SearchJob, target_height
            from console.views.search_view import SearchView

            self.search = SearchJob(session, self.link, self.mapping, self.runner)
            self._closers.append(self.search.stop)
            self.views["search"] = SearchView(server, session, self.search, target_height)
        with gui.add_folder("Scene summary"):
            self.views["summary"] = SceneSummaryView(server, session)
            self._closers.append(self.views["summary"].close)
        with gui.add_folder("Session", expand_by_default=bool(session.status_text()[1])):
            from console.views.session_files_view import SessionFilesView  # Save as / Load / Delete (ask first)

            self.views["session_files"] = SessionFilesView(server, session)
            self._show_session_status = self.views["session_files"].show_status
        camera = gui.add_panel()
        with camera.add_tab("Camera", viser.Icon.CAMERA):
            self.views["capture"] = CaptureView(server, session, colors=self.views["objects"].colors)
            from console.views.camera_preview import live_preview

            preview = live_preview(server, self.link, notify=session.notify)  # a live camera's preview, or None
            if preview is not None:
                self.views["camera_preview"] = preview
                self._closers.append(preview.close)
        camera.dock_left()
        camera.set_width(330)
        server.gui.main_panel.dock_right()
        server.gui.main_panel.set_width(RIGHT_PANEL_PX)

    # --- events ---------------------------------------------------------------------------------------
    def _on_capture(self, event: Any) -> None:
        assert self.mapping is not None
        look = getattr(self, "look", None)
        if look is not None and look.running:
            tell(event.client, "Busy", "a look is running: pause or stop it first", "yellow", 4.0)
            return
        if not self.mapping.start():
            tell(event.client, "Busy", "a capture is already being mapped", "yellow", 4.0)

    def _on_session_event(self, topic: str, payload: Any) -> None:
        if topic == NOTICE:
            self._broadcast(payload)
            self._show_session_status()
        elif topic == JOB:
            self._show_job(payload)

    def _broadcast(self, notice: Notice) -> None:
        if self.server is None:
            return
        color = {"error": "red", "warning": "yellow", "success": "green"}.get(notice.level, "blue")
        for client in self.server.get_clients().values():
            tell(client, notice.title, notice.body, color)  # closes by itself; newer news on its subject replaces it

    def _show_job(self, job: JobStatus) -> None:
        assert self.mapping is not None
        label = html.escape(self.mapping.perceiver.label)
        self._job_bar.visible = job.running
        self._job_bar.value = round(100 * job.fraction, 1)
        if job.running:
            text = f"{html.escape(job.name)}: {html.escape(job.message)}…"
        elif job.error:
            text = f"<b style='color:#d62728'>failed</b>: {html.escape(job.error)}"
        else:
            text = html.escape(job.message)
        self._job_md.content = f"<small>{text}<br>perception: <b>{label}</b></small>"

    def _spawn_file(self, scene: Any, name: str) -> None:
        assert self.session is not None
        robot = self.session.robot
        try:
            world = objects_to_world(scene, robot.pose if robot is not None else None, self._mount())
        except FrameError:
            if robot is None:
                raise NotReady from None  # robot-frame objects: wait for the robot's first pose
            raise
        # a file read again (rewritten, or replaced by a rename) replaces what its previous version added
        previous = self._file_objects.get(name, ())
        report = self.session.spawn(world, origin=f"file {name}", replaces=previous)
        self._file_objects[name] = tuple(report.added) + tuple(i for i in report.updated if i in previous)
        self.session.warn_objects_over_robot(f"scene file {name}")  # names an object placed over the robot
        again = f" (read again: replaces the {plural(len(previous), 'object')} it added before)" if previous else ""
        self.session.notify("Scene file spawned", f"{name}: {len(report.added)} new, {plural(len(report.updated), 'updated object')}"
                            + again + ("; " + "; ".join(report.notes) if report.notes else ""), "success")

    def _bad_file(self, name: str, message: str) -> None:
        assert self.session is not None
        self.session.notify("Scene file ignored", f"{name}: {message}", "error")

    def _mount(self) -> Any:
        from pipeline.camera.geometry import CameraMount

        mount = getattr(self.link, "mount", None)
        return mount if isinstance(mount, CameraMount) else CameraMount()


def wait_until(predicate: Callable[[], bool], timeout: float, interval: float = 0.05) -> bool:
    """Poll ``predicate`` until true or ``timeout`` [s]; returns its last value."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if predicate():
            return True
        time.sleep(interval)
    return predicate()
