"""Camera calibration (pipeline.camera.calibration, `morphonavi calibrate`) on boards rendered with a known camera."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from calib_render import Renderer
from pipeline.camera.calibration import Board, CalibrationError, calibrate

K = np.array([[520.0, 0.0, 318.0], [0.0, 515.0, 243.0], [0.0, 0.0, 1.0]])
DIST = np.array([-0.12, 0.05, 0.0, 0.0, 0.0])
SIZE = (640, 480)
CHESS = Board("chessboard", 9, 6, 0.03)


@pytest.fixture(scope="module")
def chess_views() -> list[tuple[str, np.ndarray]]:
    return Renderer(CHESS, K, DIST, SIZE).views(8)


def _close(intr, K: np.ndarray, rel: float = 0.01) -> None:
    for got, want in ((intr.fx, K[0, 0]), (intr.fy, K[1, 1]), (intr.cx, K[0, 2]), (intr.cy, K[1, 2])):
        assert abs(got - want) < rel * want, (got, want)


def test_chessboard_recovers_the_camera_within_1_percent(chess_views) -> None:
    cal = calibrate(chess_views, CHESS)
    _close(cal.intrinsics, K)
    assert (cal.intrinsics.width, cal.intrinsics.height) == SIZE
    assert cal.intrinsics.dist[0] == pytest.approx(DIST[0], abs=0.03)
    assert cal.rms < 0.5 and len(cal.per_view) == 8 and all(e < 0.5 for _, e in cal.per_view)
    report = cal.report()
    assert "RMS reprojection error" in report and "view00.png" in report


def test_charuco_recovers_the_camera_within_1_percent() -> None:
    board = Board("charuco", 7, 5, 0.04, 0.03, "DICT_5X5_100")
    views = Renderer(board, K, DIST, SIZE).views(8, seed=3, distance=(0.45, 0.6))
    cal = calibrate(views, board)
    _close(cal.intrinsics, K)
    assert cal.rms < 0.5


def test_too_few_views_are_refused(chess_views) -> None:
    blank = ("blank.png", np.full((480, 640, 3), 128, np.uint8))
    with pytest.raises(CalibrationError, match=r"found in 3 of 4 photos; at least 5 are needed"):
        calibrate([*chess_views[:3], blank], CHESS)


def test_boards_seen_straight_on_are_degenerate() -> None:
    r = Renderer(CHESS, K, DIST, SIZE)
    # held up facing the camera, tilted by a few degrees at most: the focal length trades off with distance
    views = [(f"flat{i}.png", r.render(Rotation.from_euler("x", a, degrees=True), np.array([dx, dy, z]) - r.centre()))
             for i, (dx, dy, z, a) in enumerate([(0, 0, 0.4, 0), (0.02, 0, 0.45, 3), (-0.02, 0.01, 0.5, -2),
                                                 (0, -0.02, 0.42, 0), (0.01, 0.02, 0.48, 4), (-0.01, -0.01, 0.55, 1)])]
    with pytest.raises(CalibrationError, match="degenerate views"):
        calibrate(views, CHESS)


def test_photos_of_different_sizes_are_refused(chess_views) -> None:
    small = ("small.png", cv2.resize(chess_views[1][1], (320, 240)))
    with pytest.raises(CalibrationError, match=r"small\.png: the photo is 320x240 px but view00\.png is 640x480"):
        calibrate([chess_views[0], small], CHESS)


@pytest.mark.parametrize(("kwargs", "match"), [
    (dict(cols=2), r"board\.cols: must be a whole number within 3\.\.100"),
    (dict(square=float("nan")), r"board\.square"),
    (dict(kind="charuco", marker=0.05, square=0.04), r"board\.marker: must be > 0 and smaller than the square"),
    (dict(kind="charuco", marker=0.02, dictionary="DICT_9X9"), r"board\.dictionary"),
])
def test_bad_boards_are_refused(kwargs: dict, match: str) -> None:
    with pytest.raises(CalibrationError, match=match):
        Board(**kwargs)


# --- the command -------------------------------------------------------------------------------------


def test_calibrate_command_writes_a_camera_toml(chess_views, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from console.cli.morphonavi import main
    from pipeline.camera.camera_file import load_camera_toml

    photos = tmp_path / "photos"
    photos.mkdir()
    for name, img in chess_views:
        cv2.imwrite(str(photos / name), img[:, :, ::-1])
    out = tmp_path / "camera.toml"
    code = main(["calibrate", str(photos), "--board", "9x6", "--square", "0.03", "--out", str(out)])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    assert "RMS reprojection error" in captured.out and "view07.png" in captured.out
    cam = load_camera_toml(out)
    _close(cam.intrinsics, K)
    assert "rms_px" in out.read_text()


@pytest.mark.parametrize(("argv", "message"), [
    (["--board", "9x6", "--square", "0.03"], "at least 5 are needed"),
    (["--board", "9by6", "--square", "0.03"], "--board: expected COLSxROWS"),
    (["--board", "9x6", "--square", "-1"], "board.square"),
])
def test_calibrate_command_refusals_write_nothing(chess_views, tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                  argv: list[str], message: str) -> None:
    from console.cli.morphonavi import main

    photos = tmp_path / "photos"
    photos.mkdir()
    for name, img in chess_views[:3]:
        cv2.imwrite(str(photos / name), img[:, :, ::-1])
    out = tmp_path / "camera.toml"
    try:
        code = main(["calibrate", str(photos), *argv, "--out", str(out)])
    except SystemExit as exc:
        code = exc.code
    assert code == 2 and message in capsys.readouterr().err and not out.exists()


def test_calibrate_command_with_a_charuco_board(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from console.cli.morphonavi import main
    from pipeline.camera.camera_file import load_camera_toml

    board = Board("charuco", 7, 5, 0.04, 0.03, "DICT_5X5_100")
    photos = tmp_path / "charuco"
    photos.mkdir()
    for name, img in Renderer(board, K, DIST, SIZE).views(7, seed=5, distance=(0.45, 0.6)):
        cv2.imwrite(str(photos / name.replace(".png", ".jpg")), img[:, :, ::-1], [cv2.IMWRITE_JPEG_QUALITY, 95])
    out = tmp_path / "camera.toml"
    code = main(["calibrate", str(photos), "--charuco", "--board", "7x5", "--square", "0.04", "--marker", "0.03",
                 "--out", str(out)])
    assert code == 0, capsys.readouterr().err
    _close(load_camera_toml(out).intrinsics, K)
    assert 'board = "charuco 7x5"' in out.read_text()
