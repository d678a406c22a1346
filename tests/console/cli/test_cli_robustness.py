"""A fresh user's trial of `morphonavi map` / `bench`: each kind of input it accepted silently or
reported badly is refused naming the option (exit 2, nothing overwritten) or reported on stderr."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from console.cli.morphonavi import main

SHARED = Path(__file__).resolve().parents[3].parent / "shared"
MODELS = SHARED / "models"
DEV = SHARED / "bench" / "dev"
SCANNET = DEV / "scannet" / "scene0000_00_00000.jpg"
OFFLINE = ("yolox_nano", "mobilesam", "fastdepth")

CAMERA = ("[intrinsics]\nfx = 260.0\nfy = 260.0\ncx = 160.0\ncy = 120.0\nwidth = 320\nheight = 240\n"
          "[mount]\nposition = [0.1, 0.0, 1.0]\npitch_deg = 15.0\n")

needs_models = pytest.mark.skipif(not all((MODELS / n).is_dir() for n in (*OFFLINE, "oidv4_ssd")),
                                  reason=f"real offline models (yolox_nano, mobilesam, fastdepth, oidv4_ssd) not in {MODELS}")
needs_dev = pytest.mark.skipif(not (DEV / "index.json").is_file(), reason=f"dev set not in {DEV}")


@pytest.fixture
def photo(tmp_path: Path) -> Path:
    path = tmp_path / "photo.png"
    rng = np.random.default_rng(0)
    cv2.imwrite(str(path), (rng.random((240, 320, 3)) * 255).astype(np.uint8))
    return path


def _err(capsys: pytest.CaptureFixture[str]) -> str:
    err = capsys.readouterr().err
    assert "Traceback" not in err
    return err


# --- 1. the camera-pose check runs in `map` ------------------------------------------------------------


def _scannet_camera(path: Path, height_m: float) -> Path:
    """camera.toml of the ScanNet dev photo (its K; pitch 25.37 deg from its gravity_cam) at ``height_m``."""
    data = json.loads(SCANNET.with_suffix(".json").read_text())
    (fx, _, cx), (_, fy, cy), _ = data["K"]
    path.write_text(f"[intrinsics]\nfx = {fx}\nfy = {fy}\ncx = {cx}\ncy = {cy}\nwidth = {data['width']}\n"
                    f"height = {data['height']}\n[mount]\nposition = [0.0, 0.0, {height_m}]\npitch_deg = 25.37\n")
    return path


@needs_models
@needs_dev
def test_map_warns_on_stderr_when_a_wrong_mount_height_floats_the_objects(tmp_path: Path,
                                                                         capsys: pytest.CaptureFixture[str]) -> None:
    """Mount height 4.0 m instead of 1.30 m: the tables and the chair float; a warning, exit status 0."""
    out = tmp_path / "scene.json"
    code = main(["map", str(SCANNET), "--camera", str(_scannet_camera(tmp_path / "wrong.toml", 4.0)),
                 "--out", str(out), "--model-dir", str(MODELS)])
    captured = capsys.readouterr()
    assert code == 0 and out.is_file()
    assert "objects float over the floor" in captured.err and "check the camera pose" in captured.err
    assert "mount height" in captured.err and "check the camera pose" not in captured.out
    # which models ran, on stderr like the bench header, the merge policy named
    assert "models: detector=yolox_nano+oidv4_ssd (class-aware), segmenter=mobilesam" in captured.err
    code = main(["map", str(SCANNET), "--camera", str(_scannet_camera(tmp_path / "right.toml", 1.301)),
                 "--out", str(out), "--model-dir", str(MODELS)])
    assert code == 0 and "objects float over the floor" not in capsys.readouterr().err


@needs_models
def test_map_says_when_the_ssd_of_the_offline_set_is_not_fetched(tmp_path: Path, photo: Path,
                                                                capsys: pytest.CaptureFixture[str]) -> None:
    folder = tmp_path / "models"
    folder.mkdir()
    for name in OFFLINE:  # a models folder without the SSD
        (folder / name).symlink_to(MODELS / name, target_is_directory=True)
    cam = tmp_path / "camera.toml"
    cam.write_text(CAMERA)
    code = main(["map", str(photo), "--camera", str(cam), "--out", str(tmp_path / "s.json"), "--model-dir", str(folder)])
    err = _err(capsys)
    assert code == 0
    assert "note: second detector 'oidv4_ssd' not fetched" in err and "morphonavi models fetch oidv4_ssd" in err
    assert "models: detector=yolox_nano, segmenter=mobilesam" in err


def test_merged_detector_name_says_which_merge_ran() -> None:
    from pipeline.models.ssd import MergedDetector

    class Named:
        def __init__(self, name: str) -> None:
            self.name = name

    assert MergedDetector(Named("yolox_nano"), Named("oidv4_ssd"), policy="union").name == "yolox_nano+oidv4_ssd (union)"
    aware = MergedDetector(Named("yolox_nano"), Named("oidv4_ssd"), policy="class_aware")
    assert aware.name == "yolox_nano+oidv4_ssd (class-aware)"


@needs_models
def test_the_model_sets_header_differs_for_union_and_class_aware() -> None:
    from pipeline.catalog import Catalog
    from pipeline.mapper_config import load_mapping_models

    catalog = Catalog.load()
    names = {s: load_mapping_models(s, MODELS, catalog).detector.name
             for s in ("offline", "offline+oidv4_ssd:union", "offline-oidv4_ssd")}
    assert names == {"offline": "yolox_nano+oidv4_ssd (class-aware)",
                     "offline+oidv4_ssd:union": "yolox_nano+oidv4_ssd (union)", "offline-oidv4_ssd": "yolox_nano"}


# --- 2. --out never overwrites an input --------------------------------------------------------------------


@pytest.mark.parametrize("which", ["photo", "camera", "catalog", "link to the photo"])
def test_map_refuses_an_out_that_is_one_of_its_inputs(tmp_path: Path, photo: Path, which: str,
                                                      capsys: pytest.CaptureFixture[str]) -> None:
    cam = tmp_path / "camera.toml"
    cam.write_text(CAMERA)
    catalog = tmp_path / "catalog.toml"
    catalog.write_text("# a catalog the user keeps\n")
    link = tmp_path / "link.png"
    link.symlink_to(photo)
    target = {"photo": photo, "camera": cam, "catalog": catalog, "link to the photo": link}[which]
    before = {p: p.read_bytes() for p in (photo, cam, catalog)}
    code = main(["map", str(photo), "--camera", str(cam), "--catalog", str(catalog), "--out", str(target),
                 "--model-dir", str(tmp_path / "none")])
    err = _err(capsys)
    assert code == 2 and f"--out {target}" in err and "overwrite" in err
    assert str(photo if which.startswith("link") else target) in err.split("--out", 1)[1]
    assert all(p.read_bytes() == data for p, data in before.items())


def _tiny_dataset(root: Path) -> Path:
    root.mkdir()
    cv2.imwrite(str(root / "a.png"), np.full((240, 320, 3), 90, np.uint8))
    (root / "a.json").write_text(json.dumps({"image": "a.png", "width": 320, "height": 240,
                                             "K": [[260, 0, 160], [0, 260, 120], [0, 0, 1]], "objects": []}))
    (root / "index.json").write_text(json.dumps([{"source": "synth", "json": "a.json", "image": "a.png"}]))
    return root


@pytest.mark.parametrize("name", ["index.json", "a.json", "a.png"])
def test_bench_refuses_an_out_that_is_a_file_of_the_dataset(tmp_path: Path, name: str,
                                                            capsys: pytest.CaptureFixture[str]) -> None:
    root = _tiny_dataset(tmp_path / "data")
    before = (root / name).read_bytes()
    code = main(["bench", str(root), "--gt-boxes", "--no-models", "--no-progress", "--out", str(root / name)])
    err = _err(capsys)
    assert code == 2 and f"--out {root / name}" in err and "overwrite" in err
    assert (root / name).read_bytes() == before


def test_bench_refuses_an_out_in_a_missing_folder_and_creates_none(tmp_path: Path,
                                                                  capsys: pytest.CaptureFixture[str]) -> None:
    root = _tiny_dataset(tmp_path / "data")
    out = tmp_path / "nonexistent" / "x.json"
    code = main(["bench", str(root), "--gt-boxes", "--no-models", "--no-progress", "--out", str(out)])
    err = _err(capsys)
    assert code == 2 and "--out" in err and "does not exist" in err
    assert not out.parent.exists()


# --- 3. values accepted silently ----------------------------------------------------------------------


@pytest.mark.parametrize(("models", "message"), [
    ("offline+", "no second detector named after '+'"),
    ("offline+:union", "no second detector named after '+'"),
    ("offline-", "no detector named after '-'"),
    ("offline-oidv4_ssd+oidv4_ssd", "leaves a second detector out ('-') and adds one ('+') at once"),
    ("offline+oidv4_ssd+oidv4_ssd", "at most one second detector"),
])
def test_map_refuses_a_malformed_model_set(tmp_path: Path, photo: Path, models: str, message: str,
                                           capsys: pytest.CaptureFixture[str]) -> None:
    cam = tmp_path / "camera.toml"
    cam.write_text(CAMERA)
    code = main(["map", str(photo), "--camera", str(cam), "--models", models, "--out", str(tmp_path / "s.json"),
                 "--model-dir", str(tmp_path / "none")])
    err = _err(capsys)
    assert code == 2 and f"--models {models}" in err and message in err
    assert "unknown model set" not in err and "offline+oidv4_ssd:union" in err  # the forms that work


def test_models_help_lists_every_form(capsys: pytest.CaptureFixture[str]) -> None:
    for command in ("map", "bench"):
        with pytest.raises(SystemExit):
            main([command, "--help"])
        text = " ".join(capsys.readouterr().out.split())
        for form in ("offline ", "offline-oidv4_ssd", "offline+oidv4_ssd ", "offline+oidv4_ssd:union", "default",
                     "cloud"):
            assert form in text, (command, form)


def test_bench_refuses_no_models_without_gt_boxes(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    root = _tiny_dataset(tmp_path / "data")
    out = tmp_path / "r.json"
    code = main(["bench", str(root), "--no-models", "--no-progress", "--out", str(out),
                 "--model-dir", str(tmp_path / "none")])
    err = _err(capsys)
    assert code == 2 and "--no-models" in err and "--gt-boxes" in err and not out.exists()


@pytest.mark.parametrize(("pose", "message"), [
    ("1e9,0", "--pose: x must be within -10000..10000 m, got 1e+09"),
    ("0,-2e4", "--pose: y must be within -10000..10000 m"),
    ("0,0,5000", "--pose: z must be within -1000..1000 m"),
    ("0,0,0,1e6", "--pose: yaw_deg must be within -360..360 deg"),
])
def test_map_refuses_a_pose_out_of_range(tmp_path: Path, photo: Path, pose: str, message: str,
                                         capsys: pytest.CaptureFixture[str]) -> None:
    cam = tmp_path / "camera.toml"
    cam.write_text(CAMERA)
    out = tmp_path / "s.json"
    code = main(["map", str(photo), "--camera", str(cam), "--pose", pose, "--out", str(out),
                 "--model-dir", str(tmp_path / "none")])
    err = _err(capsys)
    assert code == 2 and message in err and not out.exists()


def test_map_accepts_a_pose_in_range(tmp_path: Path, photo: Path, capsys: pytest.CaptureFixture[str]) -> None:
    cam = tmp_path / "camera.toml"
    cam.write_text(CAMERA)
    main(["map", str(photo), "--camera", str(cam), "--pose", "-9999,2,0,-350", "--out", str(tmp_path / "s.json"),
          "--model-dir", str(tmp_path / "none")])
    assert "--pose" not in _err(capsys)  # goes on to the models (missing here)


def test_map_refuses_a_fov_that_makes_the_other_axis_near_180_deg(tmp_path: Path,
                                                                  capsys: pytest.CaptureFixture[str]) -> None:
    tall = tmp_path / "tall.png"
    cv2.imwrite(str(tall), np.full((4000, 20, 3), 90, np.uint8))
    out = tmp_path / "s.json"
    code = main(["map", str(tall), "--fov", "60", "--out", str(out), "--model-dir", str(tmp_path / "none")])
    err = _err(capsys)
    assert code == 2 and "--fov 60" in err and "20x4000 px" in err and "vertical field of view" in err
    assert "170" in err and not out.exists()


def test_assumed_camera_checks_the_vertical_field_of_view_whatever_the_focal_length_came_from() -> None:
    from pipeline.camera.camera_guess import assumed_camera
    from pipeline.camera.geometry import CameraError

    with pytest.raises(CameraError, match="20x4000 px.*vertical field of view"):
        assumed_camera(20, 4000)  # the typical 65 deg lens on a strip of an image
    wide = assumed_camera(4000, 20, hfov_deg=120.0)  # wide and short: the vertical view is narrow
    assert wide.intrinsics.fx == pytest.approx(2000.0 / np.tan(np.radians(60.0)))
    assert assumed_camera(640, 480, hfov_deg=150.0).intrinsics.fx > 0  # 150 deg wide, 126 deg high: allowed


# --- 6. --source ----------------------------------------------------------------------------------------------


@needs_dev
def test_bench_names_the_sources_when_one_has_no_sample(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["bench", str(DEV), "--gt-boxes", "--no-models", "--no-progress", "--source", "waymo", "--out", ""])
    err = _err(capsys)
    assert code == 2 and "--source waymo" in err and "kitti, nuscenes, scannet, sunrgbd" in err


@needs_dev
def test_bench_source_matching_ignores_case() -> None:
    from pipeline.bench.evaluate import run_bench
    from pipeline.catalog import Catalog

    report = run_bench(DEV, None, Catalog.load(), gt_boxes=True, sources=["KITTI"], limit=1, progress=False)
    assert report.summary["images"] == 1 and list(report.summary["by_source"]) == ["kitti"]


# --- 8. images -------------------------------------------------------------------------------------------------


def test_map_names_the_file_of_a_1x1_image(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    tiny = tmp_path / "tiny.png"
    cv2.imwrite(str(tiny), np.zeros((1, 1, 3), np.uint8))
    code = main(["map", str(tiny), "--out", str(tmp_path / "s.json"), "--model-dir", str(tmp_path / "none")])
    err = _err(capsys)
    assert code == 2 and f"{tiny}: image is 1x1 px, smaller than the minimum of 8 px" in err


def test_a_truncated_png_gives_our_message_only(tmp_path: Path, photo: Path, capfd: pytest.CaptureFixture[str]) -> None:
    data = photo.read_bytes()
    bad = tmp_path / "cut.png"
    bad.write_bytes(data[: len(data) // 2])
    code = main(["map", str(bad), "--out", str(tmp_path / "s.json"), "--model-dir", str(tmp_path / "none")])
    err = capfd.readouterr().err  # the process's stderr, where libpng writes its own line
    assert code == 2 and f"{bad}: truncated PNG" in err
    assert "libpng" not in err and err.count("\n") == 1


def test_a_16_bit_png_of_8_bit_values_is_used_as_8_bit_with_a_warning(tmp_path: Path, photo: Path,
                                                                      capsys: pytest.CaptureFixture[str]) -> None:
    from pipeline.camera.image_io import read_image

    bgr = cv2.imread(str(photo))
    low = tmp_path / "low16.png"
    cv2.imwrite(str(low), bgr.astype(np.uint16))
    loaded = read_image(low)
    assert np.array_equal(loaded.image, bgr[:, :, ::-1])  # not black (x / 257)
    assert len(loaded.warnings) == 1 and "8-bit data stored in 16 bits" in loaded.warnings[0]
    full = tmp_path / "full16.png"
    cv2.imwrite(str(full), bgr.astype(np.uint16) * 257)  # a real 16-bit image: 0..65535
    loaded = read_image(full)
    assert np.array_equal(loaded.image, bgr[:, :, ::-1]) and not loaded.warnings
    main(["map", str(low), "--out", str(tmp_path / "s.json"), "--model-dir", str(tmp_path / "none")])
    assert f"warning: {low}: a 16-bit image whose values all lie within 0..255" in _err(capsys)


def test_rgba_is_composited_on_white_and_an_all_transparent_alpha_is_ignored_with_a_warning(tmp_path: Path) -> None:
    from pipeline.camera.image_io import read_image

    bgra = np.zeros((16, 16, 4), np.uint8)
    bgra[..., 0], bgra[..., 1], bgra[..., 2] = 10, 20, 30  # RGB (30, 20, 10)
    bgra[:8, :, 3] = 255
    half = tmp_path / "half.png"
    cv2.imwrite(str(half), bgra)
    loaded = read_image(half)
    assert (loaded.image[:8] == (30, 20, 10)).all() and (loaded.image[8:] == 255).all() and not loaded.warnings
    bgra[..., 3] = 0
    clear = tmp_path / "clear.png"
    cv2.imwrite(str(clear), bgra)
    loaded = read_image(clear)
    assert (loaded.image == (30, 20, 10)).all()
    assert len(loaded.warnings) == 1 and "alpha channel is 0 everywhere" in loaded.warnings[0]


def test_a_huge_png_is_refused_from_its_header_before_decoding(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import pipeline.camera.image_io as image_io

    huge = tmp_path / "huge.png"
    cv2.imwrite(str(huge), np.zeros((16, 12000), np.uint8))  # 12000 px wide: over the 8000 px limit

    def no_decode(*args: object, **kwargs: object) -> None:
        raise AssertionError("decoded before the size check")

    monkeypatch.setattr(image_io.cv2, "imdecode", no_decode)
    with pytest.raises(image_io.ImageError, match=r"huge.png: image is 12000x16 px, larger than the limit of 8000"):
        image_io.read_image(huge)
