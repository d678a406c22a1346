"""``morphonavi replay``: the console's views on a recording, read-only, with a time slider.

:class:`ReplayApp` starts a viser server with the live console's views (robot twin and status,
mission, grid, objects, paths, camera panel) drawing a :class:`~console.recording.replay_session.ReplaySession`,
and a *Replay* folder on top: time slider [s from the start], Play / Pause, speed, the log lines
up to that time. No robot link, no mapping, no saving: edits and commands are refused.
"""

from __future__ import annotations

import html
import math
import logging
import threading
import time
from pathlib import Path
from typing import Any

import viser

from console.app import BRAND_RGB, RIGHT_PANEL_PX, check_listenable
from console.views.capture_view import CaptureView
from console.views.client_notice import install_tab_rules, page_style
from console.views.grid_view import GridView
from console.views.mission_view import MissionView
from console.views.objects_view import ObjectsView
from console.views.paths_view import PathsView
from console.recording.replay import Recording
from console.recording.replay_session import ReplaySession
from console.recording.replay_search import SearchReplayView
from console.views.robot_view import RobotView

log = logging.getLogger(__name__)

SPEEDS = ("0.25", "0.5", "1", "2", "5", "10", "30")
TICK_S = 0.1  # playback step [s of wall time]


class ReplayApp:
    """A read-only console on ``recording`` (see the module docstring).

    Args:
        recording: The recording to show.
        host: Interface to listen on (127.0.0.1 by default).
        port: TCP port (0 = any free port).
    """

    def __init__(self, recording: Recording, host: str = "127.0.0.1", port: int = 8080) -> None:
        assert recording.info is not None
        self.recording = recording
        self.host, self.port = host, port
        self.session = ReplaySession(recording.info)
        self.server: viser.ViserServer | None = None
        self.views: dict[str, Any] = {}
        self._t = 0.0  # shown time [s from the start]
        self._playing = False
        self._speed = 1.0
        self._lock = threading.Lock()
        self._stopped = threading.Event()
        self._player: threading.Thread | None = None

    @property
    def url(self) -> str:
        assert self.server is not None, "start() first"
        return f"http://{self.host}:{self.server.get_port()}/"

    @property
    def time(self) -> float:
        """Shown time [s from the start of the recording]."""
        return self._t

    @property
    def playing(self) -> bool:
        return self._playing

    def start(self) -> "ReplayApp":
        check_listenable(self.host)
        self.server = server = viser.ViserServer(host=self.host, port=self.port, label="MorphoNavi replay", verbose=False)
        self._layout()
        self.seek(0.0)
        self._player = threading.Thread(target=self._play_loop, name="replay-player", daemon=True)
        self._player.start()
        log.info("replaying %s (%.1f s) at %s", self.recording.path, self.recording.duration, self.url)
        return self

    def stop(self) -> None:
        if self._stopped.is_set():
            return
        self._stopped.set()
        if self._player is not None:
            self._player.join(5.0)
        if self.server is not None:
            self.server.stop()
        self.session.close()

    def serve_forever(self) -> None:
        try:
            while not self._stopped.wait(0.5):
                pass
        except KeyboardInterrupt:
            pass
        finally:
            self.stop()

    # --- time ------------------------------------------------------------------------------------------
    def seek(self, seconds: float) -> None:
        """Show the state ``seconds`` after the start of the recording (clamped)."""
        rec = self.recording
        with self._lock:
            self._t = min(max(float(seconds), 0.0), rec.duration)
            state = rec.state_at(rec.start + int(round(self._t * 1e9)))
            self.session.show(state)
            if "search" in self.views:
                self.views["search"].show(state)
        if "slider" in self.views:
            self.views["slider"].value = round(self._t, 1)
            self._show_clock(state)

    def seek_time(self, ns: int) -> None:
        """Show the state at log time ``ns`` [ns since the epoch]."""
        self.seek((ns - self.recording.start) / 1e9)

    def play(self, speed: float | None = None) -> None:
        if speed is not None:
            if not (0 < speed <= 100):
                raise ValueError(f"speed: must be within 0..100, got {speed}")
            self._speed = float(speed)
        if self._t >= self.recording.duration:
            self.seek(0.0)
        self._playing = True
        self._show_play()

    def pause(self) -> None:
        self._playing = False
        self._show_play()

    def _play_loop(self) -> None:
        last = time.monotonic()
        while not self._stopped.wait(TICK_S):
            now = time.monotonic()
            dt, last = now - last, now
            if not self._playing:
                continue
            t = min(self._t + dt * self._speed, self.recording.duration)
            try:
                self.seek(t)
            except Exception:  # a broken message must not stop the player thread silently
                log.exception("replay: cannot show t = %.2f s", t)
                self._playing = False
            if t >= self.recording.duration:  # the end is shown: stop there
                self._playing = False
                self._show_play()

    # --- layout -------------------------------------------------------------------------------------
    def _layout(self) -> None:
        server, session, rec = self.server, self.session, self.recording
        assert server is not None
        gui = server.gui
        gui.configure_theme(show_share_button=False, brand_color=BRAND_RGB, control_width="large", show_logo=False)
        ws = session.workspace
        cx, cy = (ws.min[0] + ws.max[0]) / 2, (ws.min[1] + ws.max[1]) / 2
        server.initial_camera.position = (cx - 2.1, ws.min[1] - 2.4, 4.3)
        server.initial_camera.look_at = (cx + 0.1, cy - 1.1, 0.0)
        server.initial_camera.up = (0.0, 0.0, 1.0)
        gui.add_html(page_style(RIGHT_PANEL_PX))
        install_tab_rules(server)
        with gui.add_folder("Replay"):
            names = ", ".join(p.name for p in rec.paths)
            gui.add_markdown(f"<small>Recording <code>{html.escape(names)}</code>: "
                             f"{rec.duration:.1f} s, read-only"
                             f"{' (salvaged: ' + html.escape(rec.salvage_note) + ')' if rec.salvaged else ''}</small>")
            slider = gui.add_slider("Time [s]", 0.0, max(math.ceil(rec.duration * 10) / 10, 0.1), 0.1, 0.0,
                                    hint="Seconds from the start of the recording")
            self._play_btn = gui.add_button("Play", icon=viser.Icon.PLAYER_PLAY, color="green")
            speed = gui.add_dropdown("Speed", SPEEDS, initial_value="1", hint="Playback speed (x real time)")
            self._clock = gui.add_markdown("")
            self._log = gui.add_markdown("")
            search_line = gui.add_markdown("")
        self.views["slider"] = slider
        self.views["search"] = SearchReplayView(server, search_line)  # the search's viewpoints and paths

        @slider.on_update
        def _(event: Any) -> None:
            if event.client is not None:  # the operator dragged it (ours come with no client)
                self.seek(float(slider.value))

        @self._play_btn.on_click
        def _(_event: Any) -> None:
            self.pause() if self._playing else self.play()

        @speed.on_update
        def _(_event: Any) -> None:
            self._speed = float(speed.value)

        self.views["robot"] = RobotView(server, session, f"replay of {Path(rec.path).name}")
        with gui.add_folder("Mission"):
            self.views["mission"] = MissionView(server, session, None, read_only=True)
        with gui.add_folder("Map"):
            self.views["grid"] = GridView(server, session)
            self.views["objects"] = ObjectsView(server, session, layers=self.views["grid"].layers_folder)
        with gui.add_folder("Plan", expand_by_default=False):
            self.views["paths"] = PathsView(server, session, read_only=True)
        camera = gui.add_panel()
        with camera.add_tab("Camera", viser.Icon.CAMERA):
            self.views["capture"] = CaptureView(server, session, colors=self.views["objects"].colors, read_only=True)
        camera.dock_left()
        camera.set_width(330)
        gui.main_panel.dock_right()
        gui.main_panel.set_width(RIGHT_PANEL_PX)

    def _show_play(self) -> None:
        if hasattr(self, "_play_btn"):
            self._play_btn.label = "Pause" if self._playing else "Play"

    def _show_clock(self, state: Any) -> None:
        wall = time.strftime("%Y-%m-%d %H:%M:%S", time.gmtime(state.time / 1e9))
        self._clock.content = (f"<small><b>{self._t:.1f} s</b> of {self.recording.duration:.1f} s · {wall} UTC"
                               f"{' · playing x' + format(self._speed, 'g') if self._playing else ''}</small>")
        lines = [f"<code>{(t - self.recording.start) / 1e9:6.1f} s</code> {html.escape(' '.join(text.split())[:140])}"
                 for t, text in state.log[-6:]]
        self._log.content = "<small>" + "<br>".join(lines) + "</small>" if lines else ""
