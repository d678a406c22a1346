"""Bad command-line input: each is refused with the option or key named, exit status 2, nothing written."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest
from PIL import Image

from console.cli.morphonavi import build_parser, join_negative_values, main

CAMERA = ("[intrinsics]\nfx = 260.0\nfy = 260.0\ncx = 160.0\ncy = 120.0\nwidth = 320\nheight = 240\n"
          "[mount]\nposition = [0.1, 0.0, 1.0]\npitch_deg = 15.0\n")


def _parse(argv: list[str]):
    parser = build_parser()
    return parser.parse_args(join_negative_values(parser, argv))


@pytest.fixture
def photo(tmp_path: Path) -> Path:
    path = tmp_path / "photo.png"
    cv2.imwrite(str(path), np.full((240, 320, 3), 90, np.uint8))
    return path


def _map(tmp_path: Path, photo: Path, camera_text: str, *extra: str) -> tuple[int, Path]:
    cam = tmp_path / "camera.toml"
    cam.write_text(camera_text)
    out = tmp_path / "scene.json"
    code = main(["map", str(photo), "--camera", str(cam), "--out", str(out), "--model-dir", str(tmp_path / "none"),
                 *extra])
    return code, out


# --- camera.toml through `morphonavi map` ----------------------------------------------------------------


@pytest.mark.parametrize(("old", "new", "message"), [
    ("pitch_deg = 15.0", "pitch_deg = nan", "mount.pitch_deg: must be finite, got nan"),
    ("pitch_deg = 15.0", "pitch_deg = 1e9", "mount.pitch_deg: must be within -90..90 deg, got 1e+09"),
    ("position = [0.1, 0.0, 1.0]", "position = [1e308, 0, inf]", "mount.position[0]: must be within -10..10 m"),
    ("position = [0.1, 0.0, 1.0]", 'position = ["a", 0, 0.3]', "mount.position[0]: must be a number, got 'a'"),
    ("height = 240\n", "height = 240\ndist = [nan, 0, 0, 0]\n", "intrinsics.dist[0]: must be finite, got nan"),
    ("height = 240\n", 'height = 240\ndist = ["a", 0, 0, 0]\n', "intrinsics.dist[0]: must be a number, got 'a'"),
])
def test_map_refuses_bad_camera_values(tmp_path: Path, photo: Path, capsys: pytest.CaptureFixture[str],
                                       old: str, new: str, message: str) -> None:
    assert old in CAMERA
    code, out = _map(tmp_path, photo, CAMERA.replace(old, new))
    err = capsys.readouterr().err
    assert code == 2 and message in err and err.startswith("morphonavi map: error:")
    assert "Traceback" not in err and not out.exists()


# --- images through `morphonavi map` ----------------------------------------------------------------------


def test_map_refuses_a_corrupt_jpeg(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    rng = np.random.default_rng(2)
    img = cv2.GaussianBlur((rng.random((240, 320, 3)) * 255).astype(np.uint8), (0, 0), 3)
    data = bytearray(cv2.imencode(".jpg", img)[1].tobytes())
    for i in range(data.find(b"\xff\xda") + 200, len(data) - 2, 1000):
        data[i] ^= 0xFF
    bad = tmp_path / "bad.jpg"
    bad.write_bytes(bytes(data))
    code, out = _map(tmp_path, bad, CAMERA)
    err = capsys.readouterr().err
    assert code == 2 and "bad.jpg: corrupt JPEG data" in err and not out.exists()


def _sideways(tmp_path: Path) -> Path:
    """A phone photo stored 240 x 320 (w x h) with Orientation 6: upright it is 320 x 240."""
    exif = Image.Exif()
    exif[0x0112] = 6
    path = tmp_path / "phone.jpg"
    Image.fromarray(np.full((320, 240, 3), 90, np.uint8)).save(path, "JPEG", exif=exif)
    return path


def test_map_uses_the_upright_photo_and_says_so(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, out = _map(tmp_path, _sideways(tmp_path), CAMERA)  # CAMERA is for the upright 320 x 240 image
    captured = capsys.readouterr()
    assert "EXIF orientation 6 applied (rotated 90 deg clockwise): stored 240x320 px, used upright as 320x240 px" \
        in captured.out
    # the intrinsics fit: it goes on to the models, which are missing in this empty folder
    assert code == 2 and "intrinsics" not in captured.err and "models fetch" in captured.err
    assert not out.exists()


def test_map_refuses_intrinsics_of_the_stored_grid(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    stored = CAMERA.replace("cx = 160.0\ncy = 120.0\nwidth = 320\nheight = 240", "cx = 120.0\ncy = 160.0\nwidth = 240\nheight = 320")
    code, out = _map(tmp_path, _sideways(tmp_path), stored)
    err = capsys.readouterr().err
    assert code == 2 and "intrinsics.width x intrinsics.height" in err and "rotated?" in err and not out.exists()


# --- option values --------------------------------------------------------------------------------------


def test_negative_numbers_reach_every_option() -> None:
    args = _parse(["map", "p.jpg", "--camera", "c.toml", "--pose", "-1,2,0,90"])
    assert args.pose == "-1,2,0,90"
    args = _parse(["plan", "s.json", "--start", "-2.5,0.7,0", "--goal", "-1,-2,0", "--goal", "3,4,0",
                   "--bounds", "-5,-8,0,5,8,3"])
    assert args.start == (-2.5, 0.7, 0.0) and args.goal == [(-1.0, -2.0, 0.0), (3.0, 4.0, 0.0)]
    assert args.bounds == ((-5.0, -8.0, 0.0), (5.0, 8.0, 3.0))
    args = _parse(["console", "--ned-origin", "-2.5,0.7,0", "--north-deg", "-90"])
    assert args.ned_origin == (-2.5, 0.7, 0.0) and args.north_deg == -90.0
    assert join_negative_values(build_parser(), ["map", "--", "-1,2"]) == ["map", "--", "-1,2"]


def test_empty_pose_is_an_error_not_the_origin(tmp_path: Path, photo: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, out = _map(tmp_path, photo, CAMERA, "--pose", "")
    err = capsys.readouterr().err
    assert code == 2 and "--pose: empty value" in err and not out.exists()


@pytest.mark.parametrize(("argv", "message"), [
    (["plan", "s.json", "--start", "2.5,0.7", "--goal", "1,1,0"], "--start: expected 3 numbers 'x,y,z in metres', got 2"),
    (["plan", "s.json", "--start", "2.5,0.7,0", "--goal", "1,1,nan"], "--goal: value 3 must be finite"),
    (["plan", "s.json", "--start", "1,1,0", "--goal", "1,1,0", "--bounds", "5,8,3,0,0,0"],
     "--bounds: every minimum must be below its maximum"),
    (["console", "--ned-origin", "1,2"], "--ned-origin: expected 3 numbers"),
])
def test_bad_number_lists_name_the_option(argv: list[str], message: str, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2 and message in capsys.readouterr().err


def test_plan_out_directory_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    scene = tmp_path / "scene.json"
    scene.write_text(json.dumps({"version": 1, "objects": []}))
    code = main(["plan", str(scene), "--start", "2.5,0.7,0", "--goal", "2.5,5.7,0", "--out", str(tmp_path)])
    err = capsys.readouterr().err
    assert code == 2 and f"--out {tmp_path} is a directory" in err and "Traceback" not in err
    code = main(["plan", str(scene), "--start", "2.5,0.7,0", "--goal", "2.5,5.7,0",
                 "--out", str(tmp_path / "no" / "m.json")])
    assert code == 2 and "does not exist" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["scene.json"]


def test_deeply_nested_scene_json_is_an_error(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    scene = tmp_path / "deep.json"
    scene.write_text("[" * 100_000 + "]" * 100_000)
    out = tmp_path / "m.json"
    code = main(["plan", str(scene), "--start", "2.5,0.7,0", "--goal", "2.5,5.7,0", "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and "deep.json" in err and "Traceback" not in err and not out.exists()


# --- the model folder --------------------------------------------------------------------------------------


def test_model_folder_has_one_name_and_the_old_ones_still_work(tmp_path: Path) -> None:
    assert _parse(["console", "--model-dir", "m"]).models == Path("m")
    assert _parse(["console", "--models", "m"]).models == Path("m")
    assert _parse(["map", "p.jpg", "--camera", "c.toml", "--model-dir", "m"]).model_dir == Path("m")
    assert _parse(["bench", "d", "--model-dir", "m"]).model_dir == Path("m")
    assert _parse(["models", "--model-dir", "m", "list"]).model_dir == Path("m")
    assert _parse(["models", "--dir", "m", "list"]).model_dir == Path("m")
    assert _parse(["models", "verify", "--dir", "m"]).model_dir == Path("m")
    assert _parse(["models", "list"]).model_dir is None


def test_map_models_given_a_folder_hints_at_model_dir(tmp_path: Path, photo: Path,
                                                      capsys: pytest.CaptureFixture[str]) -> None:
    code, out = _map(tmp_path, photo, CAMERA, "--models", str(tmp_path))
    err = capsys.readouterr().err
    assert code == 2 and f"use --model-dir {tmp_path}" in err and not out.exists()


def test_models_env_pointing_at_a_file_is_an_error(tmp_path: Path, photo: Path, monkeypatch: pytest.MonkeyPatch,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    not_a_dir = tmp_path / "weights.onnx"
    not_a_dir.write_bytes(b"x")
    monkeypatch.setenv("MORPHONAVI_MODELS", str(not_a_dir))
    assert main(["models", "list"]) == 2
    assert f"MORPHONAVI_MODELS={not_a_dir}: is a file" in capsys.readouterr().err
    cam = tmp_path / "camera.toml"
    cam.write_text(CAMERA)
    out = tmp_path / "scene.json"
    assert main(["map", str(photo), "--camera", str(cam), "--out", str(out)]) == 2
    assert "MORPHONAVI_MODELS" in capsys.readouterr().err and not out.exists()
    assert main(["models", "list", "--model-dir", str(not_a_dir)]) == 2
    assert "--model-dir" in capsys.readouterr().err


def test_models_action_help_is_its_own(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["models", "list", "--help"])
    out = capsys.readouterr().out
    assert exc.value.code == 0 and out.startswith("usage: morphonavi models list")
    with pytest.raises(SystemExit):
        main(["models", "fetch", "--help"])
    assert "model or set names" in capsys.readouterr().out


def test_deeply_nested_json_in_the_watched_folder_is_reported(tmp_path: Path) -> None:
    from console.session.scene_watch import SceneWatcher

    (tmp_path / "deep.json").write_text("[" * 100_000 + "]" * 100_000)
    errors: list[tuple[str, str]] = []
    watcher = SceneWatcher(tmp_path, lambda scene, name: None, lambda name, msg: errors.append((name, msg)),
                           settle=0.0)
    assert watcher.poll() == ["deep.json"]
    assert errors and errors[0][0] == "deep.json" and "nested too deeply" in errors[0][1]


def test_bench_refuses_an_out_folder_and_a_zero_limit(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["bench", str(tmp_path), "--out", str(tmp_path)]) == 2
    assert f"--out {tmp_path} is a directory" in capsys.readouterr().err
    assert main(["bench", str(tmp_path), "--limit", "0"]) == 2
    assert "--limit: must be at least 1, got 0" in capsys.readouterr().err
    assert sorted(tmp_path.iterdir()) == []


def test_console_for_a_real_robot_refuses_models_env_pointing_at_a_file(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                                         capsys: pytest.CaptureFixture[str]) -> None:
    not_a_dir = tmp_path / "weights"
    not_a_dir.write_bytes(b"x")
    monkeypatch.setenv("MORPHONAVI_MODELS", str(not_a_dir))
    code = main(["console", "--robot", "mavlink:udpin:127.0.0.1:0", "--session", str(tmp_path / "s"), "--port", "0"])
    assert code == 2 and f"MORPHONAVI_MODELS={not_a_dir}: is a file" in capsys.readouterr().err
