"""The ``morphonavi map`` and ``morphonavi bench`` subcommands (registered by ``console/cli/morphonavi.py``).

``add_map_parser(subparsers)`` and ``add_bench_parser(subparsers)`` add the subcommands with their
``func`` callbacks. Failures the user can fix (bad image, camera file, pose, prompts, missing models,
malformed dataset) print ``morphonavi <command>: error: ...`` and return status 2; nothing is written
unless mapping succeeded (the scene file is written atomically).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any, Callable

from pipeline.catalog import Catalog, CatalogError
from pipeline.mapper import MapperConfig, load_mapping_models
from pipeline.option_values import OptionError, add_model_dir_option, check_model_dir, check_pose_range

from console.cli.input_files import TypedStore

__all__ = ["add_bench_parser", "add_calibrate_parser", "add_map_parser", "cmd_bench", "cmd_calibrate", "cmd_map",
           "load_mapping_models"]


class _UserError(Exception):
    """A failure to report without a traceback."""


MIN_IMAGE_SIDE = 8
"""Smallest photo side ``map`` and ``bench`` accept [px] (the mapper's own limit, checked with the file named)."""

MODELS_HELP = ("model set: offline (YOLOX-Nano, MobileSAM, FastDepth, plus the Open Images SSD oidv4_ssd when "
               "fetched, merged class-aware; the default), offline-oidv4_ssd (without the SSD), offline+oidv4_ssd "
               "(the SSD required), offline+oidv4_ssd:union (every class of both detectors), hub (OWLv2, "
               "MobileSAM, Depth Anything V2; 'default' is its old name, still accepted) or cloud. A folder of "
               "model weights is --model-dir")


def _config(args: argparse.Namespace) -> MapperConfig:
    paper = bool(args.paper)
    return MapperConfig(
        w_geometric=args.w_geometric,
        w_depth=args.w_depth,
        placement="ray" if paper else args.placement,
        segment=args.segment,
        fusion="fixed" if paper else args.fusion,
        handle_truncation=not (paper or args.no_uncut_sides),
        fit_depth=not (paper or args.no_depth_fit),
        yaw_from_depth=False if paper else None,
        ground_contact=not getattr(args, "no_ground_contact", False),
        measure_height=not getattr(args, "no_measured_height", False),
        floor_fit=not getattr(args, "no_floor_fit", False),
    )


def _add_common(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("models and mapping")
    g.add_argument("--models", default="offline", metavar="SET", help=MODELS_HELP)
    add_model_dir_option(g)
    g.add_argument("--catalog", type=Path, default=None, help="catalog TOML (default: the packaged one)")
    g.add_argument("--threads", type=int, default=None,
                   help="onnxruntime threads per model (default: 1 for YOLOX-Nano and FastDepth, every core for the rest)")
    g.add_argument("--placement", choices=("box_fit", "ray"), default="box_fit",
                   help="box_fit: fit the 3D box to the 2D box under gravity (default); ray: the paper's f*h/h_px")
    g.add_argument("--fusion", choices=("sigma", "adaptive", "fixed"), default="sigma",
                   help="sigma: each cue (size prior, ground contact, depth) gives a distance and a sigma, fused by "
                        "inverse variance with outlier rejection (default); adaptive: weigh the depth map by its "
                        "agreement with the size priors on the image and drop depth readings that contradict them; "
                        "fixed: the --w-* weights (the paper)")
    g.add_argument("--no-ground-contact", action="store_true",
                   help="sigma fusion without ground-contact ranging (the floor under the box bottom)")
    g.add_argument("--no-floor-fit", action="store_true",
                   help="sigma fusion: do not fit the floor from the photo (no check of the given camera pose; "
                        "without a pose: a level camera and no ground contact)")
    g.add_argument("--no-measured-height", action="store_true",
                   help="keep the catalog height of floor-standing objects instead of the height their box's top "
                        "edge shows at their distance")
    g.add_argument("--w-geometric", type=float, default=0.8, help="fusion weight of the size-prior distance (0.8)")
    g.add_argument("--w-depth", type=float, default=0.2, help="fusion weight of the depth-map distance (0.2)")
    g.add_argument("--no-uncut-sides", action="store_true",
                   help="use the box height even when the image border cuts the box (the paper)")
    g.add_argument("--no-depth-fit", action="store_true",
                   help="do not fit the depth map's scale (and shift) to the known-size objects (the paper)")
    g.add_argument("--paper", action="store_true",
                   help="the paper's recipe: --placement ray --fusion fixed --no-uncut-sides --no-depth-fit, "
                        "objects facing the camera")
    g.add_argument("--segment", choices=("all", "auto", "none"), default="auto",
                   help="auto: segment only detections whose distance needs the mask (unknown size, or cut on both "
                        "axes), skipping the 1-2 s encoder otherwise (default); all: every detection; none: boxes only")


def _run(fn: Callable[[argparse.Namespace], int], command: str) -> Callable[[argparse.Namespace], int]:
    def wrapper(args: argparse.Namespace) -> int:
        from pipeline.camera.geometry import CameraError
        from pipeline.camera.image_io import ImageError
        from pipeline.mapper import MapperError
        from pipeline.models.base import ModelError
        from pipeline.scene import SceneError
        from pipeline.bench.evaluate import BenchError

        from console.cli.errors import CliError

        try:
            return fn(args)
        except (_UserError, CliError, CameraError, ImageError, MapperError, ModelError, SceneError, BenchError,
                CatalogError, OptionError, OSError) as exc:
            print(f"morphonavi {command}: error: {exc}", file=sys.stderr)
            return 2

    return wrapper


def _models(args: argparse.Namespace, catalog: Catalog) -> Any:
    """Load the model set ``--models`` from ``--model-dir`` (checked first, as is $MORPHONAVI_MODELS)."""
    from pipeline.models.registry import MODEL_SETS

    _check_threads(args)
    model_dir = check_model_dir(args.model_dir, "--model-dir")
    if args.models not in MODEL_SETS and ("/" in args.models or "\\" in args.models or Path(args.models).is_dir()):
        raise _UserError(f"--models {args.models}: --models picks a model set ({', '.join(MODEL_SETS)}); "
                         f"for a folder of model weights use --model-dir {args.models}")
    return load_mapping_models(args.models, model_dir, catalog, args.threads)


def _check_threads(args: argparse.Namespace) -> None:
    """``--threads`` at least 1 (a user's error otherwise, naming the option)."""
    if args.threads is not None and args.threads < 1:
        raise _UserError(f"--threads: must be at least 1, got {args.threads}")


def _catalog(args: argparse.Namespace) -> Catalog:
    """``--catalog`` (the packaged one without it); every refusal names ``--catalog FILE`` first."""
    if not args.catalog:
        return Catalog.load()
    from console.cli.input_files import check_input_file, named_error

    check_input_file(args.catalog, "catalog", "--catalog")
    try:
        return Catalog.load(args.catalog)
    except CatalogError as exc:
        raise named_error(f"--catalog {args.catalog}", args.catalog, exc) from None


# --- map -------------------------------------------------------------------------------------------


def _camera_file(path: Path, option: str = "--camera-file") -> Any:
    """``--camera-file`` (or its old name ``--camera``, as typed: ``option``): the camera file; a file of another
    kind is named as what it is; every refusal names ``option FILE`` first."""
    from pipeline.camera.camera_file import load_camera_toml
    from pipeline.camera.geometry import CameraError
    from pipeline.file_kind import MAX_BYTES, describe_file, read_limited, wrong_kind

    from console.cli.input_files import check_input_file, named_error

    if Path(path).is_file():
        read_limited(path, MAX_BYTES["camera_toml"], "a camera", option)  # size first
        check_input_file(path, "camera_toml", option, also=("dataset_camera",))
    try:
        return load_camera_toml(path)
    except CameraError as exc:
        kind = describe_file(path) if Path(path).is_file() else "unknown"
        if kind not in ("camera_toml", "unknown", "json"):
            raise _UserError(wrong_kind("", f"{option} {path}", kind, "camera_toml")) from None
        raise named_error(f"{option} {path}", path, exc) from None


def cmd_map(args: argparse.Namespace) -> int:
    """``morphonavi map IMAGE --camera-file CAMERA.toml [--pose x,y,z,yaw] [--prompts ...] --out scene.json``."""
    from pipeline.camera.camera_guess import assumed_camera
    from pipeline.camera.geometry import CameraConfig, Pose, parse_pose
    from pipeline.camera.image_io import read_image
    from pipeline.scene import save_scene
    from pipeline.mapper import Mapper, prompts_from_words
    from pipeline.camera.camera_guess import widen_sigmas

    if args.camera is not None and args.fov is not None:
        raise _UserError("--fov is for photos without a camera file; the camera file's intrinsics are used")
    from console.cli.input_files import check_input_file, typed_option
    from console.cli.outputs import check_output

    if Path(args.image).is_file():  # the argument first; another MorphoNavi file is named as what it is
        check_input_file(args.image, "photo")
    if args.catalog:
        check_input_file(args.catalog, "catalog", "--catalog")
    out = check_output(args.out, [("photo", args.image), ("camera file", args.camera), ("catalog", args.catalog)],
                       example="scene.json")
    _check_threads(args)  # the options before any note about the photo's camera
    catalog = _catalog(args)
    camera = _camera_file(args.camera, typed_option(args, "camera", "--camera-file")) if args.camera is not None else None
    if camera is not None:
        from pipeline.camera.horizon import horizon_check

        horizon = horizon_check(camera.intrinsics, camera.mount)  # pitch_deg = 89.9 for 8.9: every object at the feet
        if horizon:
            print(f"warning: {args.camera}: {horizon}", file=sys.stderr)
    if args.pose is not None:
        check_pose_range(args.pose, "--pose")
    pose = parse_pose(args.pose, "--pose") if args.pose is not None else Pose()
    loaded = read_image(args.image, min_side=MIN_IMAGE_SIDE)
    if loaded.note:
        print(loaded.note)
    for warning in loaded.warnings:
        print(f"warning: {warning}", file=sys.stderr)
    image = loaded.image
    assumed = None
    if camera is None:  # uncalibrated: a documented default, flagged in the output and the scene
        assumed = assumed_camera(image.shape[1], image.shape[0], hfov_deg=args.fov, focal_35mm=loaded.focal_35mm)
        camera = CameraConfig(assumed.intrinsics, mount_given=False)
        print(f"warning: {assumed.warning}")
    if not camera.mount_given:  # no [mount] / gravity_cam: fitted from the photo, never taken as level
        print("note: the camera's pitch, roll and height are not given (no [mount] in the camera file, no "
              "gravity_cam / camera_height): they are fitted from the photo's floor", file=sys.stderr)
    if args.prompts is not None:
        prompts_from_words(catalog, args.prompts)  # empty list -> error before loading models
    camera.intrinsics.check_image(image.shape[1], image.shape[0])
    models = _models(args, catalog)
    if getattr(models, "note", ""):  # e.g. the set's second detector is not fetched (as the bench says)
        print(f"note: {models.note}", file=sys.stderr)
    with Mapper(models, catalog, _config(args)) as mapper:
        result = mapper.run(image, camera.intrinsics, camera.mount, pose, prompts=args.prompts,
                            image_name=Path(args.image).name, pose_given=camera.mount_given)
    scene = result.scene
    if assumed is not None:
        import dataclasses

        flag = f"assumed from {assumed.how}, +-{assumed.rel_sigma:.0%}"
        scene = dataclasses.replace(scene, captures=tuple(
            dataclasses.replace(c, models={**dict(c.models), "intrinsics": flag}) for c in scene.captures))
        scene = widen_sigmas(scene, assumed.rel_sigma)  # every distance scales with the assumed focal length
    from pipeline.bench.evaluate import models_line
    from pipeline.camera.pose_check import floor_check

    print(models_line(dict(scene.captures[0].models)), file=sys.stderr)
    pose_warnings = floor_check(scene)  # objects under the floor / floating: a wrong camera pose (as the console)
    debug_files: list[Path] = []
    if args.debug:
        from pipeline.debug_images import write_debug_images

        debug_files = write_debug_images(result, image, args.debug)
    try:
        save_scene(scene, out)  # atomic, with the user's file mode
    except OSError as exc:
        from console.cli.outputs import write_error

        raise write_error(exc, args.out) from None
    t = scene.captures[0].timings
    n_obj, n_det = len(scene.objects), len(result.objects)
    print(f"{n_obj} object{'' if n_obj == 1 else 's'} from {n_det} detection{'' if n_det == 1 else 's'} "
          f"in {t.get('total', 0.0):.2f} s "
          f"(detect {t.get('detect', 0.0):.2f}, depth {t.get('depth', 0.0):.2f}, segment {t.get('segment', 0.0):.2f}, "
          f"distance {t.get('distance', 0.0):.2f})")
    for o in scene.objects:
        d = o.source.distances.get("fused")
        sig = "" if o.sigma is None else f" +-{o.sigma:.2f}"
        print(f"  {o.id:20s} {o.label:16s} score {o.score:.2f}  {o.source.method:9s} z {d:6.2f} m{sig}  "
              f"world ({o.position[0]:.2f}, {o.position[1]:.2f}, {o.position[2]:.2f})"
              + (f"  cut {'/'.join(o.cut)}" if o.cut else ""))
    for o in result.objects:
        if o.skipped:
            print(f"  skipped {o.detection.label} (score {o.detection.score:.2f}): {o.skipped}")
    if debug_files:
        print(f"debug images: {', '.join(str(p) for p in debug_files)}")
    print(f"scene written to {out}")
    for warning in pose_warnings:  # last, where it is seen; a warning: the exit status stays 0
        print(f"warning: check the camera pose: {warning}", file=sys.stderr)
    return 0


def add_map_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Register ``morphonavi map``."""
    p = subparsers.add_parser(
        "map", help="map one photo to a scene of 3D objects (scene JSON)",
        description="Detect, segment and place the objects of one photo; write the scene JSON (world frame).",
    )
    p.add_argument("image", help="photo (JPEG, PNG, ...)")
    p.add_argument("--camera-file", "--camera", dest="camera", type=Path, default=None, metavar="CAMERA.toml",
                   action=TypedStore,
                   help="camera file: camera.toml (intrinsics [px] for the upright image and mount; morphonavi "
                        "calibrate writes one) or a photo's camera JSON (K, width, height, gravity_cam, "
                        "camera_height: the benchmark's form). --camera is the old name (console --camera is a "
                        "live camera). Without it the intrinsics are ASSUMED (--fov, else the photo's EXIF 35 mm focal "
                        "length, else a 65 deg lens; flagged, with their uncertainty) and the mount is the default")
    p.add_argument("--fov", type=float, default=None, metavar="DEG",
                   help="without --camera-file: the lens's horizontal field of view [deg]")
    p.add_argument("--pose", default=None, help="robot pose at capture 'x,y[,z[,yaw_deg]]' (world frame, metres, degrees)")
    p.add_argument("--prompts", nargs="*", default=None, metavar="WORD",
                   help="what to look for (default: the catalog's prompts)")
    p.add_argument("--out", default="scene.json", help="scene JSON to write (default scene.json)")
    p.add_argument("--debug", type=Path, default=None, metavar="DIR",
                   help="also write pictures: detections overlay, masks, coloured depth")
    _add_common(p)
    p.set_defaults(func=_run(cmd_map, "map"))
    return p


# --- bench -----------------------------------------------------------------------------------------


def cmd_bench(args: argparse.Namespace) -> int:
    """``morphonavi bench DATASET_DIR [--gt-boxes] [--out report.json]``."""
    from pipeline.bench.evaluate import format_report, run_bench

    from console.cli.outputs import check_output, write_error

    if args.out:
        check_output(args.out, [("catalog", args.catalog), *_dataset_files(args.dataset)],
                     example="bench_report.json")
    if args.no_models and not args.gt_boxes:
        raise _UserError("--no-models: only with --gt-boxes (the dataset's 2D boxes stand in for the detector); "
                         "without it the detector is a model")
    if args.limit is not None and args.limit < 1:
        raise _UserError(f"--limit: must be at least 1, got {args.limit}")
    if not 0.0 < args.iou <= 1.0:  # also refuses nan
        raise _UserError(f"--iou: must be within 0..1 (a 2D overlap ratio, above 0), got {args.iou}")
    catalog = _catalog(args)
    models = None
    if not (args.gt_boxes and args.no_models):
        models = _models(args, catalog)
    report = run_bench(
        args.dataset, models, catalog, gt_boxes=args.gt_boxes, config=_config(args), iou_threshold=args.iou,
        limit=args.limit, sources=args.source, progress=not args.no_progress, drop_pose=args.drop_pose,
    )
    print(format_report(report))
    if args.out:
        try:
            path = report.save(Path(args.out).expanduser())
        except OSError as exc:
            raise write_error(exc, args.out) from None
        print(f"\nreport written to {path}")
    return 0


def _dataset_files(root: Path) -> list[tuple[str, Path]]:
    """The files a bench dataset is read from (``index.json``, each sample's JSON and photo) as
    ``(what, path)``; what cannot be read here is left to :func:`pipeline.bench.evaluate.load_dataset` to report."""
    import json

    files: list[tuple[str, Path]] = [("dataset index", root / "index.json")]
    try:
        index = json.loads((root / "index.json").read_text())
    except (OSError, ValueError):
        return files
    for entry in index if isinstance(index, list) else []:
        if isinstance(entry, dict):
            files += [(f"dataset {key}", root / str(entry[key])) for key in ("json", "image") if entry.get(key)]
    return files


def add_bench_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Register ``morphonavi bench``."""
    p = subparsers.add_parser(
        "bench", help="evaluate mapping on photos with ground-truth 3D objects",
        description="Run the mapping pipeline on a dataset folder (index.json + per-sample JSON, the format of "
                    "../shared/bench/dev) and print the detection ratio, the 3D centre error and the time per stage.",
    )
    p.add_argument("dataset", type=Path, help="dataset folder holding index.json")
    p.add_argument("--gt-boxes", action="store_true",
                   help="use the dataset's 2D boxes as detections (isolates the distance error)")
    p.add_argument("--no-models", action="store_true",
                   help="with --gt-boxes: run no model at all (size-prior distances only)")
    p.add_argument("--iou", type=float, default=0.5, help="minimum 2D IoU of a detection / ground-truth match (0.5)")
    p.add_argument("--limit", type=int, default=None, help="only the first N samples")
    p.add_argument("--source", action="append", default=None, help="only samples of this source (repeatable)")
    p.add_argument("--out", default="bench_report.json", help="JSON report to write (default bench_report.json; '' for none)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--drop-pose", action="store_true",
                   help="give the mapper no camera pose (gravity, height) for any photo: it finds them in the photo")
    _add_common(p)
    p.set_defaults(func=_run(cmd_bench, "bench"))
    return p


# --- calibrate -------------------------------------------------------------------------------------

PHOTO_SUFFIXES = (".jpg", ".jpeg", ".png", ".bmp", ".tif", ".tiff", ".webp")


def _board_size(text: str) -> tuple[int, int]:
    parts = text.lower().replace(" ", "").split("x")
    if len(parts) != 2 or not all(p.isdigit() for p in parts):
        raise argparse.ArgumentTypeError(f"--board: expected COLSxROWS such as 9x6, got {text!r}")
    return int(parts[0]), int(parts[1])


def _calibration_photos(paths: list[Path]) -> list[Path]:
    files: list[Path] = []
    for p in paths:
        if p.is_dir():
            files.extend(sorted(f for f in p.iterdir() if f.suffix.lower() in PHOTO_SUFFIXES))
        elif p.is_file():
            files.append(p)
        else:
            raise _UserError(f"{p}: no such file or folder")
    if not files:
        raise _UserError(f"no photos ({', '.join(PHOTO_SUFFIXES)}) in {', '.join(str(p) for p in paths)}")
    return files


def cmd_calibrate(args: argparse.Namespace) -> int:
    """``morphonavi calibrate PHOTOS... --board 9x6 --square 0.025 [--charuco ...] --out camera.toml``."""
    from pipeline.camera.calibration import Board, CalibrationError, calibrate
    from pipeline.camera.camera_file import write_camera_toml
    from pipeline.camera.image_io import read_image

    if args.min_views < 1:
        raise _UserError(f"--min-views: must be at least 1, got {args.min_views}")
    from console.cli.input_files import check_input_file
    from console.cli.outputs import InputFolder, check_output, write_error

    for photo in args.photos:  # the arguments first; another MorphoNavi file is named as what it is
        if photo.is_file():
            check_input_file(photo, "photo")
    inputs: list[Any] = [InputFolder("photo", p, PHOTO_SUFFIXES) if p.is_dir() else ("photo", p) for p in args.photos]
    out = check_output(args.out, inputs, example="camera.toml")
    if out.suffix.lower() in PHOTO_SUFFIXES:
        raise _UserError(f"--out {args.out}: a camera file is TOML text; a {out.suffix} name would pass it for a "
                         "photo: give --out a .toml name such as camera.toml")
    try:
        board = Board("charuco" if args.charuco else "chessboard", args.board[0], args.board[1], args.square,
                      args.marker if args.charuco else 0.0, args.dictionary)
    except CalibrationError as exc:
        raise _UserError(str(exc)) from None
    photos = []
    for f in _calibration_photos(args.photos):
        loaded = read_image(f, name=f.name)
        if loaded.note:
            print(loaded.note)
        for warning in loaded.warnings:
            print(f"warning: {warning}", file=sys.stderr)
        photos.append((f.name, loaded.image))
    try:
        cal = calibrate(photos, board, min_views=args.min_views)
    except CalibrationError as exc:
        raise _UserError(str(exc)) from None
    print(cal.report())
    facts = {"rms_px": round(cal.rms, 4), "views": len(cal.per_view), "board": f"{board.kind} {board.cols}x{board.rows}",
             "square_m": board.square, **{f"sigma_{k}_px": round(cal.sigmas[k], 4) for k in ("fx", "fy", "cx", "cy")
                                          if k in cal.sigmas},
             "tilt_spread_deg": round(cal.tilt_spread_deg, 1), "border_cells": cal.border_cells}
    for warning in cal.warnings:
        print(f"warning: {warning}", file=sys.stderr)
    try:
        write_camera_toml(out, cal.intrinsics, None, facts)
    except OSError as exc:
        raise write_error(exc, args.out) from None
    print(f"camera file written to {out} (add its [mount] section: where the camera sits on the robot)")
    return 0


def add_calibrate_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Register ``morphonavi calibrate``."""
    p = subparsers.add_parser(
        "calibrate", help="camera intrinsics and distortion from chessboard or ChArUco photos (writes camera.toml)",
        description="Find the board in every photo (files or folders), calibrate with OpenCV, print the RMS and "
                    "per-view reprojection errors and every parameter's standard deviation, and write camera.toml "
                    "for the upright photo size. Refuses too few views, boards that face the camera the same way in "
                    "every photo (board normals within 15 deg of each other: the focal length is then not "
                    "observable), boards seen only in the image centre (distortion not observable) and a focal "
                    "length left undetermined; warns when the corners reach few of the image's border cells.",
    )
    p.add_argument("photos", nargs="+", type=Path, help="photos of the board, or folders of them (one camera, one size)")
    p.add_argument("--board", type=_board_size, default=(9, 6), metavar="COLSxROWS",
                   help="chessboard: INNER corners (a 10 x 7 squares board is 9x6, the default); ChArUco: squares")
    p.add_argument("--square", type=float, default=0.025, help="side of one square [m] (default 0.025)")
    p.add_argument("--charuco", action="store_true", help="the board is a ChArUco board (needs --marker)")
    p.add_argument("--marker", type=float, default=0.0, help="ChArUco: side of one marker [m]")
    p.add_argument("--dictionary", default="DICT_5X5_100", help="ChArUco: ArUco dictionary (default DICT_5X5_100)")
    p.add_argument("--min-views", type=int, default=5, help="fewest photos with the board found (default 5)")
    p.add_argument("--out", default="camera.toml", help="camera file to write (default camera.toml)")
    p.set_defaults(func=_run(cmd_calibrate, "calibrate"))
    return p
