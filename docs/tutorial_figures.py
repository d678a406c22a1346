"""Follow the tutorial (docs/tutorial.md) in headless Chromium and print every figure it quotes.

Starts the console as ``morphonavi console --fresh`` does (the simulated robot in the paper's room, real
time, ground-truth perception, a fresh session in a temporary folder), opens it in Debian's Chromium
through Playwright at 1440 x 900, presses the buttons each tutorial step names, and at each step prints
what the page says (the line under Capture & map, the known-space line, the notices, the robot line, the
mission table) and saves the screenshot ``docs/tutorial-N-*.png`` (into ``--out``).

Every step waits on the console's state, never on time; a step that does not happen in its deadline
stops the run naming it. Needs ``/usr/bin/chromium`` and the ``playwright`` package (``make test``
installs both).

Usage::

    .venv/bin/python docs/tutorial_figures.py [--out docs] [--text /tmp/tutorial.txt]
"""

from __future__ import annotations

import argparse
import re
import sys
import tempfile
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from console.app import ConsoleApp, ConsoleConfig  # noqa: E402
from console.session.mapping_job import JOB_NAME  # noqa: E402
from tests.console.e2e.e2e_helpers import button, click_until, wait_for  # noqa: E402
from tests.console.e2e.test_console_e2e import BROWSER_ARGS, CHROMIUM, VIEWPORT  # noqa: E402

NOTES = ".mantine-Notification-root"


class Tour:
    """The console, the page, and what each step printed."""

    def __init__(self, app: ConsoleApp, page: Any, out: Path, log: list[str]) -> None:
        self.app, self.s, self.page, self.out, self.log = app, app.session, page, out, log

    def say(self, what: str, text: Any) -> None:
        line = f"{what}: {text}"
        print(line, flush=True)
        self.log.append(line)

    def body(self, step: str) -> None:
        """The whole page's text, for the log (what the user reads)."""
        self.log.append(f"----- page text after {step} -----\n{self.page.inner_text('body')}\n-----")

    def notices(self) -> list[str]:
        """The notices on the page now, read in one go (one may slide out between two reads)."""
        texts = self.page.evaluate(f"() => [...document.querySelectorAll('{NOTES}')].map(n => n.innerText)")
        return [str(t).replace("\n", " | ") for t in texts]

    def close_notices(self) -> None:
        for b in self.page.locator(f"{NOTES} button.mantine-Notification-closeButton").all():
            try:
                b.click(timeout=5_000)
            except Exception:  # gone meanwhile
                pass

    def shot(self, name: str) -> None:
        grid = self.app.views["grid"]
        wait_for(lambda: grid.drawn_counts().get("occupied", 1) > 0, "the grid drawn")
        for _ in range(3):  # a few frames drawn after the last change (a loaded page draws slowly)
            self.page.evaluate("() => new Promise(r => requestAnimationFrame(() => requestAnimationFrame(r)))")
        self.page.screenshot(path=str(self.out / name))
        self.say("screenshot", self.out / name)

    def type_goal(self, x: float, y: float, z: float) -> None:
        for axis, value in zip("xyz", (x, y, z)):
            field = self.page.get_by_label(f"Goal {axis} [m]", exact=True)
            field.fill(f"{value:g}")
            wait_for(lambda: field.input_value() == f"{value:g}", f"Goal {axis} typed")
        wait_for(lambda: [float(v) for v in self.app.views["paths"].typed_values()] == [x, y, z], "the fields on the server")

    def capture(self, what: str) -> None:
        """Press Capture & map until a new capture is mapped."""
        s = self.s
        before = s.capture.id if s.capture is not None else None
        click_until(button(self.page, "Capture & map"), lambda: s.job.running or (
            s.capture is not None and s.capture.id != before), what)
        wait_for(lambda: s.capture is not None and s.capture.id != before and s.job.name == JOB_NAME
                 and not s.job.running, f"{what}: mapped", 600)


def run(out: Path, text: Path | None) -> int:
    from playwright.sync_api import sync_playwright

    from console.session.topics import NOTICE, RUN

    tmp = Path(tempfile.mkdtemp(prefix="tutorial-"))
    app = ConsoleApp(ConsoleConfig(robot="sim", session_dir=tmp / "session", scene_dir=tmp / "scenes", port=0,
                                   fresh=True))
    app.start()
    log: list[str] = []
    pw = sync_playwright().start()
    ctx = pw.chromium.launch_persistent_context(str(tmp / "chromium"), executable_path=str(CHROMIUM), headless=True,
                                                args=BROWSER_ARGS, viewport=VIEWPORT)
    try:
        page = ctx.new_page()
        page.goto(app.url)
        t = Tour(app, page, out, log)
        s = t.s
        job_msgs: list[str] = []
        notes: list[str] = []
        states: list[str] = []

        def on(topic: str, p: Any) -> None:
            if topic == "job":
                job_msgs.append(f"{p.name}: {p.message}")
            elif topic == NOTICE:
                notes.append(f"{p.title} | {p.body}")
                t.say("notice", f"{p.title} | {p.body}")
            elif topic == RUN:
                states.append(p.state)

        s.subscribe(on)
        page.get_by_role("button", name="Capture & map").wait_for(timeout=120_000)
        wait_for(lambda: len(app.server.get_clients()) >= 1 and s.robot is not None, "the page and the robot")
        # --- 1. start ----------------------------------------------------------------------------------------
        page.get_by_text("No capture yet").first.wait_for(timeout=120_000)
        page.get_by_text("battery").first.wait_for(timeout=120_000)
        t.body("start")
        t.shot("tutorial-1-start.png")
        t.say("known space", app.views["known_space"].summary.content)
        t.say("before any capture, goal (2.5, 1.5, 0)", s.add_goal((2.5, 1.5, 0.0)).message)
        # --- 2. capture & map --------------------------------------------------------------------------------
        t.capture("Capture & map")
        t.say("capture line", s.job.message)
        wait_for(lambda: "% seen" in app.views["known_space"].summary.content, "the known-space line")
        t.say("known space", app.views["known_space"].summary.content)
        page.get_by_text(s.job.message[:30]).first.wait_for(timeout=120_000)
        t.close_notices()
        t.body("capture")
        t.shot("tutorial-2-capture.png")
        # --- 3. look around ----------------------------------------------------------------------------------
        click_until(button(page, "Look around"), lambda: s.job.name == "Look around", "Look around")
        wait_for(lambda: s.job.name == "Look around" and not s.job.running and app.look is not None
                 and not app.look.running, "Look around done", 1200)
        t.say("look around progress", [m for m in job_msgs if "heading 3/6" in m][:2])
        t.say("look around end", s.job.message)
        t.say("known space", app.views["known_space"].summary.content)
        t.say("objects", len(s.scene.objects))
        page.get_by_text("done: 6 headings captured").first.wait_for(timeout=120_000)
        t.close_notices()
        t.body("look around")
        t.shot("tutorial-3-look.png")
        # --- 4. the floor behind the boxes: refused ----------------------------------------------------------
        t.close_notices()
        t.type_goal(2.5, 5.3, 0.0)
        click_until(button(page, "Add goal"), lambda: any("reachable" in x or "not seen" in x for x in t.notices()),
                    "the refusal")
        page.locator(NOTES, has_text="not seen").first.wait_for(timeout=120_000)
        t.say("refusal (page)", t.notices())
        t.say("refusal (session)", s.add_goal((2.5, 5.3, 0.0)).message)
        t.shot("tutorial-4-refused.png")
        # --- 5. plan over the boxes --------------------------------------------------------------------------
        t.say("air behind the wall, closed rule", s.add_goal((2.5, 5.5, 1.875)).message)
        t.close_notices()
        click_until(lambda: page.get_by_text("Plan into unknown space").first, lambda: s.plan_unknown == "allow",
                    "Plan into unknown space")
        wait_for(lambda: "planning into unknown space" in app.views["known_space"].summary.content,
                 "the known-space line to say so")
        t.say("known space", app.views["known_space"].summary.content)
        t.type_goal(2.5, 5.5, 1.875)
        click_until(button(page, "Add goal"), lambda: s.route_snapshot().candidate_goal is not None, "the candidate")
        page.get_by_text(re.compile(r"candidate \d")).first.wait_for(timeout=120_000)  # the line, not the legend
        t.body("add goal (2.5, 5.5, 1.875)")
        click_until(button(page, "Register"), lambda: len(s.route_snapshot().registered) == 1, "Register")
        click_until(button(page, "Build mission"), lambda: s.mission is not None, "Build mission")
        for seg in s.mission.segments:
            t.say("segment", f"{seg.kind.value} {tuple(round(float(v), 2) for v in seg.waypoints[0])} -> "
                  f"{tuple(round(float(v), 2) for v in seg.waypoints[-1])}")
        wait_for(lambda: page.get_by_role("button", name="Execute", exact=True).is_enabled(), "Execute enabled")
        t.close_notices()
        t.body("build mission")
        t.shot("tutorial-5-mission.png")
        # --- 6. execute ---------------------------------------------------------------------------------------
        del states[:]
        click_until(button(page, "Execute"), lambda: "running" in states or s.run.state == "running", "Execute")
        wait_for(lambda: "running" in states and s.run.state in ("done", "paused", "aborted", "failed"),
                 "the mission to end", 900)
        t.say("run", s.run.state)
        t.say("pose [m]", tuple(round(float(v), 2) for v in app.link.latest_state().position))
        t.say("notices on the page", t.notices())
        t.body("execute")
        t.close_notices()
        page.get_by_role("button", name="Land here").first.wait_for(timeout=120_000)
        t.say("Return title", page.get_by_role("button", name="Return", exact=True).get_attribute("title"))
        t.shot("tutorial-6-hover.png")
        # --- 7. look around from the air ---------------------------------------------------------------------
        ends = len([m for m in job_msgs if m.startswith("Look around: done")])
        click_until(button(page, "Look around"), lambda: s.job.name == "Look around" and s.job.running or len(
            [m for m in job_msgs if m.startswith("Look around: done")]) > ends, "Look around in the air")
        wait_for(lambda: s.job.name == "Look around" and not s.job.running and app.look is not None
                 and not app.look.running, "Look around done", 1800)
        t.say("look around end", s.job.message)
        t.say("known space", app.views["known_space"].summary.content)
        t.say("objects", len(s.scene.objects))
        t.say("Land here title", page.get_by_role("button", name="Land here", exact=True).get_attribute("title"))
        t.close_notices()
        t.body("look around in the air")
        t.shot("tutorial-7-look-air.png")
        # --- 8. go look at the floor goal, land, capture ----------------------------------------------------
        t.type_goal(2.5, 5.3, 0.0)
        for k in range(6):
            looks = app.go_look.outcome.looks if app.go_look.outcome is not None else -1
            seen = len(job_msgs)
            click_until(button(page, "Go look"), lambda: app.go_look.running or (
                app.go_look.outcome is not None and app.go_look.outcome.looks != looks), f"Go look {k + 1}")
            wait_for(lambda: not app.go_look.running, f"Go look {k + 1} to end", 1800)
            out_ = app.go_look.outcome
            steps = [m for m in job_msgs[seen:] if m.startswith("Go look: look ") or m.startswith("Go look: going")]
            t.say(f"go look {k + 1} steps", list(dict.fromkeys(steps)))
            t.say(f"go look {k + 1}", f"{out_.message} (kinds {out_.kinds}, planned {out_.planned})")
            t.say(f"go look {k + 1} pose [m]", tuple(round(float(v), 2) for v in app.link.latest_state().position))
            if out_.planned or s.job.error is not None:
                break
        click_until(button(page, "Register"), lambda: len(s.route_snapshot().registered) >= 1, "Register")
        click_until(button(page, "Build mission"), lambda: s.mission is not None, "Build mission", timeout=120)
        for seg in s.mission.segments:
            t.say("segment", f"{seg.kind.value} {tuple(round(float(v), 2) for v in seg.waypoints[0])} -> "
                  f"{tuple(round(float(v), 2) for v in seg.waypoints[-1])}")
        t.body("landing mission built")
        del states[:]
        wait_for(lambda: page.get_by_role("button", name="Execute", exact=True).is_enabled(), "Execute enabled")
        click_until(button(page, "Execute"), lambda: "running" in states or s.run.state == "running", "Execute")
        wait_for(lambda: "running" in states and s.run.state in ("done", "paused", "aborted", "failed"),
                 "the landing mission to end", 900)
        t.say("run", s.run.state)
        t.say("pose [m]", tuple(round(float(v), 2) for v in app.link.latest_state().position))
        t.capture("the last Capture & map")
        t.say("capture line", s.job.message)
        t.say("battery [%]", round(100 * float(app.link.latest_state().battery)))
        t.say("objects", f"{len(s.scene.objects)}, robot dogs {[o.id for o in s.scene.objects if o.label == 'robot_dog']}")
        t.close_notices()
        t.body("landing and capture")
        t.shot("tutorial-8-dog.png")
    finally:
        if text is not None:
            text.write_text("\n".join(log) + "\n", encoding="utf-8")
        ctx.close()
        pw.stop()
        app.stop()
    return 0


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", type=Path, default=ROOT / "docs", help="folder for the screenshots (default docs/)")
    p.add_argument("--text", type=Path, default=None, help="also write every step's page text to this file")
    args = p.parse_args(argv)
    if not CHROMIUM.exists():
        print(f"error: {CHROMIUM} is missing (make test installs it)", file=sys.stderr)
        return 2
    if not args.out.is_dir():
        print(f"error: --out {args.out}: no such folder", file=sys.stderr)
        return 2
    return run(args.out, args.text)


if __name__ == "__main__":
    sys.exit(main())
