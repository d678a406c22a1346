"""Benchmark: the CPU the MCAP mission log adds to a running console, robot state at 50 Hz.

Run from the repository root::

    .venv/bin/python bench/recording_overhead.py              # 3 rounds of 2 x 20 s
    .venv/bin/python bench/recording_overhead.py --seconds 10 --rounds 2

In one process, each round starts the real console (viser server, every view, the simulated robot
publishing its state at 50 Hz) once without and once with recording (the order alternates between
rounds), maps the room once (so the map, grid and views hold a real scene), then measures the
process CPU time (user + system, every thread) over a window of ``--seconds`` while the robot state
streams and the robot walks back and forth. Prints the CPU per window, the robot states received,
the messages recorded, the ratio of CPU per robot state with / without recording (median over
the rounds) and the recorder's own CPU (its listener and writer thread, measured with thread CPU clocks).
Exits with status 1 when the recorder's own CPU is 5 % or more of the console's. The A/B ratio is
printed too, but on a shared, loaded machine its noise (about +-10 % between windows) is larger
than the effect; the thread CPU clocks measure the recorder alone.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import threading
import time
from pathlib import Path

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from console.app import ConsoleApp, ConsoleConfig, wait_until  # noqa: E402
from console.link.sim import SimConfig, SimRobot  # noqa: E402
from console.session.topics import ROBOT  # noqa: E402
from planner.mission import MissionSegment, SegmentKind  # noqa: E402

LIMIT = 0.05  # extra CPU allowed with recording (fraction of the CPU without)


def _cpu() -> float:
    t = os.times()
    return t.user + t.system


def one_window(folder: Path, record: bool, seconds: float) -> dict[str, float]:
    """Console on the 50 Hz simulated robot; CPU [s] over ``seconds`` of state streaming and walking."""
    robot = SimRobot(config=SimConfig(rate=50.0, walk_speed=0.3))
    app = ConsoleApp(ConsoleConfig(session_dir=folder / "session", scene_dir=folder / "scenes", port=0, fresh=True,
                                   record=record), link=robot)
    app.start()
    states = [0]
    try:
        session = app.session
        assert session is not None and app.mapping is not None
        session.subscribe(lambda t, _p: states.__setitem__(0, states[0] + 1) if t == ROBOT else None)
        if not wait_until(lambda: session.robot is not None, 30):
            raise SystemExit("the simulated robot never reported")
        app.mapping.start()
        if not wait_until(lambda: not session.job.running and session.job.fraction == 1.0, 120):
            raise SystemExit(f"mapping did not finish: {session.job}")
        stop = threading.Event()

        def pace() -> None:  # walk 0.4 m forward and back, again and again: the pose changes all the time
            legs = [((2.5, 0.7, 0.0), (2.5, 1.1, 0.0)), ((2.5, 1.1, 0.0), (2.5, 0.7, 0.0))]
            i = 0
            while not stop.is_set():
                run = robot.run_segment(MissionSegment(SegmentKind.WALK, legs[i % 2]))
                while not run.done and not stop.wait(0.05):
                    pass
                i += 1

        walker = threading.Thread(target=pace, daemon=True)
        walker.start()
        time.sleep(1.0)  # settle: the walk under way, the views drawn
        own0 = app.recorder.cpu_seconds if getattr(app, "recorder", None) is not None else 0.0
        n0, c0, w0 = states[0], _cpu(), time.monotonic()
        time.sleep(seconds)
        cpu, wall, n = _cpu() - c0, time.monotonic() - w0, states[0] - n0
        stop.set()
        walker.join(5)
        rec = getattr(app, "recorder", None)
        recorded = sum(rec.counts.values()) if rec is not None else 0
        own = rec.cpu_seconds - own0 if rec is not None else 0.0
    finally:
        app.stop()
    return {"cpu": cpu, "wall": wall, "states": n, "recorded": recorded, "own": own}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=20.0, help="measured window per run [s] (default 20)")
    ap.add_argument("--rounds", type=int, default=3, help="rounds of (without, with) recording (default 3)")
    args = ap.parse_args()
    if not (args.seconds > 0 and args.rounds > 0):
        ap.error("--seconds and --rounds must be positive")
    ratios: list[float] = []
    owns: list[float] = []
    with tempfile.TemporaryDirectory(prefix="rec-bench-") as tmp:
        for r in range(args.rounds):
            order = (False, True) if r % 2 == 0 else (True, False)
            res = {}
            for record in order:
                res[record] = one_window(Path(tmp) / f"r{r}-{int(record)}", record, args.seconds)
                x = res[record]
                print(f"round {r + 1} {'with   ' if record else 'without'} recording: CPU {x['cpu']:.2f} s over "
                      f"{x['wall']:.1f} s ({100 * x['cpu'] / x['wall']:.1f} % of a core), "
                      f"{x['states'] / x['wall']:.0f} robot states/s, {x['recorded']:.0f} messages recorded", flush=True)
            # CPU per robot state: a loaded machine runs the simulator slower in one window than in another
            on, off = (res[k]["cpu"] / max(res[k]["states"], 1) for k in (True, False))
            ratios.append(on / off)
            owns.append(res[True]["own"] / (res[True]["cpu"] - res[True]["own"]))
            print(f"round {r + 1}: CPU per robot state with / without recording = {ratios[-1]:.3f}; the recorder's "
                  f"own CPU (listener + writer thread) = {100 * owns[-1]:.2f} % of the rest", flush=True)
    med = statistics.median(ratios)
    print(f"median CPU ratio with / without recording over {args.rounds} rounds: {med:.3f} "
          f"({100 * (med - 1):+.1f} %; limit +{100 * LIMIT:.0f} %); the recorder's own CPU: "
          f"{100 * statistics.median(owns):.2f} % (median)")
    return 0 if statistics.median(owns) < LIMIT else 1


if __name__ == "__main__":
    sys.exit(main())
