"""The ``morphonavi replay FILE.mcap`` subcommand: open the console read-only on a recording."""

from __future__ import annotations

import argparse
import logging
from pathlib import Path
from typing import Sequence


def add_replay_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:  # type: ignore[type-arg]
    """Register ``replay`` on the ``morphonavi`` subcommand parsers; returns its parser."""
    from console.cli.console_cmd import _port

    p = subparsers.add_parser(
        "replay", help="replay a recorded session (MCAP) in the console, read-only",
        description="Open the console on a recording written by `morphonavi console` (the .mcap files in "
                    "<session>/recordings): a time slider, Play / Pause and speed; the 3D view, camera panel, "
                    "map, paths and robot show the state at that time. Nothing can be edited or commanded.")
    p.add_argument("file", type=Path, nargs="+", metavar="FILE.mcap",
                   help="the recording (several: the parts of one run in order, e.g. run.mcap run-002.mcap)")
    p.add_argument("--host", default="127.0.0.1", help="interface to listen on (default 127.0.0.1)")
    p.add_argument("--port", type=_port, default=8080, help="TCP port (default 8080; 0 = any free port)")
    p.add_argument("--salvage", action="store_true",
                   help="read a recording that was not finished (the console was killed) up to where it ends, "
                        "or a damaged one chunk by chunk: replay what is readable and say what was lost")
    p.set_defaults(func=cmd_replay)
    return p


def open_replay(path: str | Path | Sequence[str | Path], host: str = "127.0.0.1", port: int = 8080,
                salvage: bool = False) -> "ReplayApp":  # type: ignore[name-defined]  # noqa: F821
    """Read ``path`` and start the read-only console on it (stop it with ``stop()``); ``salvage``: see
    :class:`console.recording.replay.Recording`.

    Raises :class:`console.cli.errors.CliError` for a missing, non-MCAP, truncated or foreign file.
    """
    from console.cli.errors import CliError

    from console.recording.replay import Recording, ReplayError
    from console.recording.replay_app import ReplayApp

    from console.cli.input_files import check_input_file

    for one in ([path] if isinstance(path, (str, Path)) else path):
        if Path(one).exists():  # a folder, empty, another MorphoNavi file: named before it is read as MCAP
            check_input_file(one, "recording")
    try:
        recording = Recording(path, salvage=salvage)
    except ReplayError as exc:
        raise CliError(str(exc)) from None
    app = ReplayApp(recording, host=host, port=port)
    try:
        app.start()
    except OSError as exc:
        app.stop()
        raise CliError(f"cannot start the replay console: {exc}") from None
    return app


def cmd_replay(args: argparse.Namespace) -> int:
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(levelname)s %(name)s: %(message)s", datefmt="%H:%M:%S")
    for noisy in ("websockets", "websockets.server", "httpx"):
        logging.getLogger(noisy).setLevel(logging.WARNING)
    app = open_replay(args.file, args.host, args.port, args.salvage)
    names = " ".join(str(f) for f in args.file)
    if app.recording.salvaged:
        print(f"{names}: salvaged: {app.recording.salvage_note}; replaying {app.recording.duration:.1f} s", flush=True)
    from console.cli.port_note import moved_port_line

    moved = moved_port_line(args.port, app.server.get_port(), "replay")  # viser took the next free port: say so
    if moved:
        print(moved, flush=True)
    print(f"MorphoNavi replay of {names}: open {app.url} in a browser (Ctrl-C to stop)", flush=True)
    app.serve_forever()
    return 0
