"""pipeline.image_io.load_image on generated files of every awkward kind."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from pipeline.image_io import MAX_SIDE, ImageError, load_image


def _write(path: Path, array: np.ndarray) -> Path:
    assert cv2.imwrite(str(path), array)
    return path


def test_colour_png_comes_back_rgb(tmp_path: Path) -> None:
    bgr = np.zeros((4, 6, 3), np.uint8)
    bgr[..., 2] = 200  # red in BGR
    img = load_image(_write(tmp_path / "red.png", bgr))
    assert img.shape == (4, 6, 3) and img.dtype == np.uint8 and img.flags.c_contiguous
    assert img[0, 0].tolist() == [200, 0, 0]


def test_bytes_and_pathlike(tmp_path: Path) -> None:
    path = _write(tmp_path / "a.jpg", np.full((8, 8, 3), 128, np.uint8))
    from_bytes = load_image(path.read_bytes())
    assert np.array_equal(from_bytes, load_image(str(path)))


def test_grayscale_becomes_rgb(tmp_path: Path) -> None:
    gray = np.arange(12, dtype=np.uint8).reshape(3, 4) * 20
    img = load_image(_write(tmp_path / "g.png", gray))
    assert img.shape == (3, 4, 3)
    assert np.array_equal(img[..., 0], gray) and np.array_equal(img[..., 2], gray)


def test_16_bit_is_scaled_to_8_bit(tmp_path: Path) -> None:
    deep = np.array([[0, 257, 32896, 65535]], np.uint16)
    img = load_image(_write(tmp_path / "d.png", deep))
    assert img[0, :, 0].tolist() == [0, 1, 128, 255]
    colour = np.zeros((2, 2, 3), np.uint16)
    colour[..., 0] = 65535  # blue in BGR
    assert load_image(_write(tmp_path / "c16.png", colour))[0, 0].tolist() == [0, 0, 255]


def test_rgba_is_composited_on_white(tmp_path: Path) -> None:
    bgra = np.zeros((2, 3, 4), np.uint8)
    bgra[0, 0] = (0, 0, 255, 255)  # opaque red
    bgra[0, 1] = (0, 0, 255, 0)  # fully transparent red -> white
    bgra[0, 2] = (0, 0, 0, 128)  # half-transparent black -> mid grey
    img = load_image(_write(tmp_path / "rgba.png", bgra))
    assert img.shape == (2, 3, 3)
    assert img[0, 0].tolist() == [255, 0, 0]
    assert img[0, 1].tolist() == [255, 255, 255]
    assert img[0, 2].tolist() == [127, 127, 127]


def test_errors_name_the_file(tmp_path: Path) -> None:
    with pytest.raises(ImageError, match="no such file") as err:
        load_image(tmp_path / "missing.jpg")
    assert "missing.jpg" in str(err.value)
    (tmp_path / "empty.png").write_bytes(b"")
    with pytest.raises(ImageError, match=r"empty\.png: file is empty"):
        load_image(tmp_path / "empty.png")
    good = _write(tmp_path / "ok.jpg", np.zeros((50, 50, 3), np.uint8)).read_bytes()
    (tmp_path / "cut.jpg").write_bytes(b"garbage" + good[40:80])
    with pytest.raises(ImageError, match=r"cut\.jpg: not a readable image"):
        load_image(tmp_path / "cut.jpg")
    with pytest.raises(ImageError, match="is a directory"):
        load_image(tmp_path)
    with pytest.raises(ImageError, match="<bytes>: not a readable image"):
        load_image(b"\x00\x01\x02")
    with pytest.raises(ImageError, match="expected a path or bytes"):
        load_image(42)  # type: ignore[arg-type]


def test_huge_images_are_refused_with_size_and_limit(tmp_path: Path) -> None:
    wide = _write(tmp_path / "wide.png", np.zeros((2, MAX_SIDE + 1, 3), np.uint8))
    expected = rf"wide\.png: image is {MAX_SIDE + 1}x2 px, larger than the limit of {MAX_SIDE} px"
    with pytest.raises(ImageError, match=expected):
        load_image(wide)
    assert load_image(wide, max_side=MAX_SIDE + 1).shape == (2, MAX_SIDE + 1, 3)
