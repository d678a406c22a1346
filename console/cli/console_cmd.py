"""The ``morphonavi console`` subcommand: start the operator console in the browser."""

from __future__ import annotations

import argparse
import logging
import math
from pathlib import Path

from console.cli.cli_args import DEFAULT_SESSION

DEFAULT_SCENES = Path(".morphonavi/scenes")


def _port(text: str) -> int:
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a TCP port number, got {text!r}") from None
    if not 0 <= v <= 65535:
        raise argparse.ArgumentTypeError(f"port must be within 0..65535 (0 = any free port), got {v}")
    return v


def _finite(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not math.isfinite(v):
        raise argparse.ArgumentTypeError(f"expected a finite number, got {text!r}")
    return v


def _positive(text: str) -> float:
    v = _finite(text)
    if v <= 0:
        raise argparse.ArgumentTypeError(f"expected a positive number, got {text!r}")
    return v


def _resolution(text: str) -> float:
    v = _positive(text)
    if not 0.05 <= v <= 1.0:
        raise argparse.ArgumentTypeError(f"the grid cell size must be within 0.05..1 m, got {v}")
    return v


def _non_negative(text: str) -> float:
    v = _finite(text)
    if v < 0:
        raise argparse.ArgumentTypeError(f"expected a number >= 0, got {text!r}")
    return v


def _vec3(text: str) -> tuple[float, float, float]:
    from pipeline.option_values import ValueListError, parse_numbers

    try:
        v = parse_numbers(text, "--ned-origin", (3,), "x,y,z in metres")
    except ValueListError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    return (v[0], v[1], v[2])


def camera_source(args: argparse.Namespace) -> object | None:
    """The live camera of ``--camera SOURCE --camera-file camera.toml`` (opened once, kept on ``args``),
    or ``None`` without ``--camera``. Raises :class:`console.cli.errors.CliError` naming the bad option or key."""
    if getattr(args, "camera", None) is None:
        if getattr(args, "camera_file", None) is not None:
            from console.cli.errors import CliError

            raise CliError("--camera-file is for a live camera: give --camera SOURCE too")
        return None
    source = getattr(args, "_camera_source", None)
    if source is None:
        from console.cli.errors import CliError
        from pipeline.camera.geometry import CameraError

        from console.link.camera_source import CameraSourceError, open_camera_source

        if args.captures is not None:
            raise CliError("--camera and --captures: give one camera (a live source or a folder of photos)")
        if args.camera_file is not None and Path(args.camera_file).is_file():  # empty, binary, another kind
            from console.cli.input_files import check_input_file

            check_input_file(args.camera_file, "camera_toml", "--camera-file", also=("dataset_camera",))
        try:
            source = open_camera_source(args.camera, args.camera_file)
        except CameraSourceError as exc:
            raise CliError(str(exc)) from None
        except CameraError as exc:  # the camera file's: named first
            from console.cli.input_files import named_error

            raise named_error(f"--camera-file {args.camera_file}", args.camera_file, exc) from None
        args._camera_source = source
        from pipeline.camera.horizon import horizon_check

        horizon = horizon_check(source.camera.intrinsics, source.camera.mount)  # type: ignore[attr-defined]
        if horizon:
            logging.getLogger(__name__).warning("%s: %s", args.camera_file, horizon)
    return source


def photo_source(args: argparse.Namespace) -> object | None:
    """What the simulated robot serves as photos: ``--captures DIR``, the live camera, or ``None``
    (a MAVLink link takes the live camera through :func:`link_options`)."""
    if str(args.robot).startswith("mavlink:"):
        return args.captures
    return camera_source(args) or args.captures


def link_options(args: argparse.Namespace) -> dict[str, object]:
    """Keyword options for :func:`console.link.open_link` from the parsed arguments."""
    if not str(args.robot).startswith("mavlink:"):
        return {}
    from console.link.mavlink import GroundMotion, MavlinkConfig
    from console.link.ned import NedFrame

    ned = NedFrame(origin=args.ned_origin, north_yaw=math.radians(args.north_deg))
    options: dict[str, object] = {"config": MavlinkConfig(ned=ned, ground=GroundMotion(command=args.ground_command),
                                                          signing_key=args.mavlink_key),
                                  "tlog": args.session}  # the MAVLink traffic, as a .tlog in the session folder
    source = camera_source(args)
    if source is not None:
        options.update(camera=source, mount=source.camera.mount)  # type: ignore[attr-defined]
    return options


def _signing_key(text: str) -> str:
    if not text.strip():
        raise argparse.ArgumentTypeError("must not be empty (leave --mavlink-key out for no signing)")
    return text


def add_console_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:  # type: ignore[type-arg]
    """Register ``console`` on the ``morphonavi`` subcommand parsers; returns its parser."""
    p = subparsers.add_parser(
        "console",
        help="start the operator console (digital twin in the browser)",
        description="Start the operator console: the map, the planner and the robot in a browser tab. "
                    "By default the simulated robot in the paper's demo room, unmapped; open the printed "
                    "address, press 'Capture & map', click the floor to add goals.",
    )
    p.add_argument("--robot", default="sim", metavar="SPEC",
                   help="robot link: 'sim' (default, the built-in simulated robot) or "
                        "'mavlink:<connection>', e.g. mavlink:udpin:127.0.0.1:14550")
    p.add_argument("--world", type=Path, default=None, metavar="FILE",
                   help="the simulator's hidden room: a world file (scene, bounds, room, robot start; see "
                        "docs/howto/simulator.md and examples/worlds/); default the paper's room")
    p.add_argument("--scene", type=Path, default=None, metavar="DIR",
                   help=f"watched scene folder: scene JSON files dropped there are added to the map "
                        f"(default {DEFAULT_SCENES})")
    p.add_argument("--session", type=Path, default=DEFAULT_SESSION, metavar="DIR",
                   help=f"session folder: the state is saved there after every change and restored at "
                        f"start (default {DEFAULT_SESSION})")
    p.add_argument("--fresh", action="store_true", help="start from an empty map instead of restoring the session")
    p.add_argument("--no-record", dest="record", action="store_false",
                   help="do not record the session (by default every run is recorded as MCAP in <session>/recordings; "
                        "morphonavi replay FILE.mcap shows it again)")
    p.add_argument("--foxglove-ws", dest="foxglove_port", type=_port, default=None, metavar="PORT",
                   help="also serve the recorded topics live to the Foxglove app (Foxglove WebSocket protocol) on "
                        "127.0.0.1:PORT; off by default")
    agent = p.add_argument_group("language-model agents (MCP; see docs/howto/mcp.md)")
    agent.add_argument("--mcp", dest="mcp_port", type=_port, default=None, metavar="PORT",
                       help="also serve the MCP server (streamable HTTP) on 127.0.0.1:PORT/mcp; `morphonavi mcp` "
                            "attaches to any running console without it")
    agent.add_argument("--mcp-allow-actions", action="store_true",
                       help="that server offers the proposal tools (plan, propose a mission, capture); each needs "
                            "the operator's Approve in the console")
    agent.add_argument("--agent-real-vehicle", action="store_true",
                       help="allow agent proposals on a real (non-loopback) vehicle link; off by default")
    p.add_argument("--host", default="127.0.0.1",
                   help="interface to listen on (default 127.0.0.1: this machine only). Anything else lets "
                        "whoever reaches the port drive the robot: there is no login")
    p.add_argument("--port", type=_port, default=8080, help="TCP port (default 8080; the next free one if taken)")
    p.add_argument("--model-dir", "--models", dest="models", type=Path, default=None, metavar="DIR",
                   help="folder with the offline model weights (morphonavi models fetch; --models is the old "
                        "name); without it the simulated robot is mapped with ground-truth perception")
    p.add_argument("--perception", choices=("exact", "noisy"), default="exact",
                   help="the simulated robot's perception without --model-dir: 'exact' (default, the render's "
                        "ground truth) or 'noisy' (box jitter N(0, 2 px) per side, 10 %% missed detections, a "
                        "false detection in 40 %% of the photos, as bench/sim_tour.py --noise)")
    p.add_argument("--resolution", type=_resolution, default=0.25,
                   help="planning grid cell size [m], 0.05..1 (default 0.25)")
    p.add_argument("--margin", type=_non_negative, default=0.35,
                   help="robot radius: cells this close to an obstacle are dangerous [m] (default 0.35)")
    p.add_argument("--captures", type=Path, default=None, metavar="DIR",
                   help="serve real photos from DIR (the format of ../shared/bench/dev: image + JSON with K) "
                        "as the robot's camera instead of its own")
    p.add_argument("--camera", default=None, metavar="SOURCE",
                   help="a live camera as the robot's camera: rtsp://... or http://.../stream.mjpg (MJPEG), "
                        "/dev/video0 or a device number, or a video file; needs --camera-file")
    p.add_argument("--camera-file", type=Path, default=None, metavar="CAMERA.toml",
                   help="intrinsics and mount of the --camera (morphonavi calibrate writes one)")
    p.add_argument("--failsafe-after", type=_positive, default=3.0, metavar="SECONDS",
                   help="mission failsafe: hold the robot after this long without hearing it [s] (default 3)")
    p.add_argument("--failsafe-hold", type=_non_negative, default=5.0, metavar="SECONDS",
                   help="mission failsafe: land after holding this long with the link still lost [s] (default 5)")
    mav = p.add_argument_group("MAVLink robots (--robot mavlink:...)")
    mav.add_argument("--ned-origin", type=_vec3, default=(0.0, 0.0, 0.0), metavar="X,Y,Z",
                     help="world position [m] of the vehicle's local NED origin (EKF origin; default 0,0,0)")
    mav.add_argument("--north-deg", type=_finite, default=90.0, metavar="DEG",
                     help="direction of north, counter-clockwise from world +x [deg] (default 90: world +y)")
    mav.add_argument("--ground-command", choices=("position", "velocity"), default="position",
                     help="walking segments: position targets at ground height (default) or velocity targets")
    mav.add_argument("--mavlink-key", type=_signing_key, default=None, metavar="KEY",
                     help="MAVLink 2 signing: the vehicle's passphrase (SHA-256 gives the key, as MAVProxy's "
                          "'signing setup') or the 32-byte key as 64 hex digits; needed when the vehicle "
                          "requires signed messages (it ignores unsigned commands)")
    p.set_defaults(func=cmd_console)
    return p


def cmd_console(args: argparse.Namespace) -> int:
    """Run the console until Ctrl-C.

    The session folder is locked first (:class:`console.session.session_lock.SessionLock`): a second console
    on the same folder stops here, naming the PID of the one running, before anything is read.
    """
    from console.cli.errors import CliError

    from console.app import ConsoleApp, ConsoleConfig
    from console.session.session import SessionError
    from console.session.session_lock import SessionLock

    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(levelname)s %(name)s: %(message)s",
                        datefmt="%H:%M:%S")
    for noisy in ("websockets", "websockets.server", "httpx"):
        logging.getLogger(noisy).setLevel(logging.WARNING)
    if args.foxglove_port is not None and not args.record:
        raise CliError("--foxglove-ws serves what is recorded: drop --no-record")
    if args.mcp_allow_actions and args.mcp_port is None:
        raise CliError("--mcp-allow-actions is for the server --mcp PORT starts (morphonavi mcp has its own "
                       "--allow-actions)")
    if args.mcp_port is not None:
        from console.cli.mcp_cmd import need_mcp

        need_mcp("--mcp")
    world = None
    if args.world is not None:
        if str(args.robot).startswith("mavlink:"):
            raise CliError("--world is the simulator's room: drop it with --robot mavlink:... (a real robot is in its own room)")
        from console.cli.world_option import load_world_option

        world = load_world_option(args.world)
    from console.cli.console_folders import check_console_folders

    check_console_folders(args, DEFAULT_SCENES)  # files given for folders, nested folders: before anything starts
    if args.captures is not None and Path(args.captures).exists() and not Path(args.captures).is_dir():
        from console.cli.console_folders import not_a_folder

        raise CliError(not_a_folder("--captures", Path(args.captures), "give a folder of photos, each with its "
                                    "camera .json beside it", str(Path(args.captures).parent)))
    if args.captures is not None and not Path(args.captures).is_dir():
        raise CliError(f"--captures {args.captures}: no such folder")
    if args.models is not None and not Path(args.models).is_dir():
        raise CliError(f"--model-dir {args.models}: no such folder (fetch the models with: morphonavi models fetch NAME)")
    if args.perception == "noisy" and (str(args.robot).startswith("mavlink:") or args.models is not None
                                       or args.captures is not None or args.camera is not None):
        raise CliError("--perception noisy adds noise to the simulator's rendered ground truth: drop --robot "
                       "mavlink:..., --model-dir, --captures and --camera with it")
    if args.models is None and str(args.robot).startswith("mavlink:"):  # a real robot maps with the default folders
        from pipeline.option_values import check_model_dir

        check_model_dir(None)  # $MORPHONAVI_MODELS naming a file is an error, not "models missing"
    config = ConsoleConfig(
        robot=args.robot, scene_dir=args.scene if args.scene is not None else DEFAULT_SCENES,
        session_dir=args.session, host=args.host, port=args.port, models=args.models, fresh=args.fresh,
        resolution=args.resolution, margin=args.margin, captures=photo_source(args),
        failsafe_after=args.failsafe_after, failsafe_hold=args.failsafe_hold, link_options=link_options(args),
        record=args.record, foxglove_port=args.foxglove_port, mcp_port=args.mcp_port, world=world,
        mcp_allow_actions=args.mcp_allow_actions, agent_real_vehicle=args.agent_real_vehicle,
        perception=args.perception,
    )
    try:
        lock = SessionLock(args.session).acquire()
    except SessionError as exc:
        raise CliError(str(exc)) from None
    try:
        app = ConsoleApp(config)
        try:
            app.start()
        except Exception as exc:
            app.stop()
            from console.link.base import LinkError

            if isinstance(exc, SessionError):
                raise CliError(str(exc)) from None
            if isinstance(exc, (LinkError, OSError, ValueError)):
                raise CliError(f"cannot start the console: {exc}") from None
            raise
        host = getattr(app, "mcp_host", None)
        from console.cli.port_note import moved_port_line

        moved = moved_port_line(args.port, app.server.get_port())  # viser took the next free port: say so
        app.serve_forever(ready=lambda: print((f"{moved}\n" if moved else "")
                                              + f"MorphoNavi console: open {app.url} in a browser (Ctrl-C to stop)"
                                              + (f"\nMCP server for agents: {host.url}" if host is not None else ""),
                                              flush=True))
    finally:
        lock.release()
    return 0
