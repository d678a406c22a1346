"""Found by trying the CLI as a newcomer: bad numbers are refused naming the option, exit status 2, no traceback."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from console.cli.morphonavi import main


@pytest.fixture
def photos(tmp_path: Path) -> Path:
    folder = tmp_path / "calib"
    folder.mkdir()
    for i in range(2):  # no board on them: nothing can be calibrated
        cv2.imwrite(str(folder / f"p{i}.png"), np.full((120, 160, 3), 90 + i, np.uint8))
    return folder


@pytest.mark.parametrize("value", ["-3", "0"])
def test_calibrate_refuses_a_min_views_below_one(photos: Path, tmp_path: Path, value: str,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "camera.toml"
    code = main(["calibrate", str(photos), "--board", "9x6", "--square", "0.02", "--min-views", value, "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and "--min-views" in err and value in err and "Traceback" not in err
    assert not out.exists()


def test_calibrate_api_refuses_a_min_views_below_one() -> None:
    from pipeline.camera.calibration import Board, CalibrationError, calibrate

    with pytest.raises(CalibrationError, match="min_views"):
        calibrate([("a.png", np.zeros((120, 160, 3), np.uint8))], Board("chessboard", 9, 6, 0.02), min_views=0)


def test_calibrate_counts_photos_with_the_right_plural(photos: Path, tmp_path: Path,
                                                       capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["calibrate", str(photos / "p0.png"), "--board", "9x6", "--square", "0.02",
                 "--out", str(tmp_path / "camera.toml")])
    err = capsys.readouterr().err
    assert code == 2 and "found in 0 of 1 photo;" in err and "(s)" not in err


@pytest.mark.parametrize("value", ["2", "nan", "0", "-0.5", "inf"])
def test_bench_refuses_an_iou_outside_0_1(tmp_path: Path, value: str, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "report.json"
    code = main(["bench", str(tmp_path), "--gt-boxes", "--no-models", "--iou", value, "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and "--iou" in err and "Traceback" not in err
    assert not out.exists()


def test_replaying_the_recording_a_running_console_is_writing_says_so(tmp_path: Path,
                                                                      capsys: pytest.CaptureFixture[str]) -> None:
    """A newcomer replays the session's recording while its console still runs: not 'the console was killed'."""
    import os

    from console.session.session_lock import SessionLock

    session = tmp_path / "session"
    (session / "recordings").mkdir(parents=True)
    rec = session / "recordings" / "morphonavi-20260101-000000.mcap"
    rec.write_bytes(b"\x89MCAP0\r\n" + b"\x00" * 64)  # the magic, no footer yet: being written
    lock = SessionLock(session).acquire()
    try:
        code = main(["replay", str(rec), "--port", "0"])
        err = capsys.readouterr().err
        assert code == 2 and "Traceback" not in err
        assert "still being written" in err and f"PID {os.getpid()}" in err and "--salvage" in err, err
    finally:
        lock.release()
    code = main(["replay", str(rec), "--port", "0"])  # the console is gone: the file was left unfinished
    err = capsys.readouterr().err
    assert code == 2 and "the recording was not finished" in err and "still being written" not in err


MODELS = Path(__file__).resolve().parents[4] / "shared" / "models"


@pytest.mark.skipif(not (MODELS / "yolox_nano").is_dir(), reason=f"offline model weights not in {MODELS}")
def test_map_counts_objects_and_detections_with_the_right_plural(tmp_path: Path,
                                                                capsys: pytest.CaptureFixture[str]) -> None:
    photo = tmp_path / "blank.png"
    cv2.imwrite(str(photo), np.full((240, 320, 3), 90, np.uint8))  # nothing on it
    cam = tmp_path / "camera.toml"
    cam.write_text("[intrinsics]\nfx = 260.0\nfy = 260.0\ncx = 160.0\ncy = 120.0\nwidth = 320\nheight = 240\n")
    code = main(["map", str(photo), "--camera", str(cam), "--out", str(tmp_path / "scene.json"),
                 "--model-dir", str(MODELS)])
    out = capsys.readouterr().out
    assert code == 0 and "0 objects from 0 detections in" in out and "(s)" not in out, out


@pytest.mark.parametrize("value", ["-1", "0"])
def test_map_refuses_threads_below_one_naming_the_option(tmp_path: Path, value: str,
                                                         capsys: pytest.CaptureFixture[str]) -> None:
    photo = tmp_path / "blank.png"
    cv2.imwrite(str(photo), np.full((240, 320, 3), 90, np.uint8))
    cam = tmp_path / "camera.toml"
    cam.write_text("[intrinsics]\nfx = 260.0\nfy = 260.0\ncx = 160.0\ncy = 120.0\nwidth = 320\nheight = 240\n")
    out = tmp_path / "scene.json"
    code = main(["map", str(photo), "--camera", str(cam), "--out", str(out), "--threads", value,
                 "--model-dir", str(tmp_path / "none")])
    err = capsys.readouterr().err
    assert code == 2 and f"--threads: must be at least 1, got {value}" in err and not out.exists(), err
