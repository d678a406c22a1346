"""pipeline.camera.image_io.load_image on generated files of every awkward kind."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from pipeline.camera.image_io import MAX_SIDE, ImageError, load_image, read_image, upright_size


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


# --- the image convention: EXIF orientation applied, corrupt JPEGs refused ----------------------------


def _exif_jpeg(path: Path, rgb: np.ndarray, orientation: int, fmt: str = "JPEG") -> Path:
    from PIL import Image

    exif = Image.Exif()
    exif[0x0112] = orientation
    Image.fromarray(rgb).save(path, fmt, exif=exif, **({"quality": 95} if fmt == "JPEG" else {}))
    return path


def _marked(h: int = 530, w: int = 730) -> np.ndarray:
    """A stored image with a white block in its top-left corner and a grey one top-right."""
    rgb = np.zeros((h, w, 3), np.uint8)
    rgb[:40, :60] = 255
    rgb[:40, -60:] = 128
    return rgb


@pytest.mark.parametrize("orientation", range(1, 9))
def test_every_exif_orientation_is_applied_like_pillow(tmp_path: Path, orientation: int) -> None:
    from PIL import Image, ImageOps

    path = _exif_jpeg(tmp_path / f"o{orientation}.jpg", _marked(), orientation)
    loaded = read_image(path)
    expected = np.asarray(ImageOps.exif_transpose(Image.open(path)).convert("RGB"))
    assert loaded.image.shape == expected.shape
    assert np.array_equal(loaded.image, expected)
    assert loaded.orientation == orientation and loaded.stored_size == (730, 530)
    assert upright_size(path) == (loaded.image.shape[1], loaded.image.shape[0])
    if orientation == 1:
        assert loaded.note is None
    else:
        assert loaded.note is not None and f"EXIF orientation {orientation} applied" in loaded.note


def test_phone_photo_stored_sideways_is_used_upright_and_said_so(tmp_path: Path) -> None:
    path = _exif_jpeg(tmp_path / "phone.jpg", _marked(), 6)
    loaded = read_image(path)
    assert loaded.image.shape == (730, 530, 3)  # upright: 530 wide, 730 high
    assert load_image(path).shape == (730, 530, 3)  # every entry point goes through the same rule
    # rotated 90 deg clockwise: the stored top-left corner is now top-right
    assert loaded.image[5, -5].tolist() == pytest.approx([255, 255, 255], abs=8)
    assert loaded.note == (f"{path}: EXIF orientation 6 applied (rotated 90 deg clockwise): stored 730x530 px, "
                           "used upright as 530x730 px; the intrinsics must describe the upright image")


def test_exif_orientation_of_a_png_is_applied_too(tmp_path: Path) -> None:
    path = _exif_jpeg(tmp_path / "side.png", _marked(100, 200), 8, fmt="PNG")
    loaded = read_image(path)
    assert loaded.orientation == 8 and loaded.image.shape == (200, 100, 3)
    # turned 90 deg counter-clockwise: the stored top-left goes bottom-left, the top-right top-left
    assert loaded.image[-2, 2].tolist() == [255, 255, 255]
    assert loaded.image[2, 2].tolist() == [128, 128, 128]


def _smooth_jpeg() -> bytes:
    rng = np.random.default_rng(0)
    img = cv2.GaussianBlur((rng.random((240, 320, 3)) * 255).astype(np.uint8), (0, 0), 3)
    ok, buf = cv2.imencode(".jpg", img)
    assert ok
    return buf.tobytes()


def test_corrupt_jpeg_data_is_an_error_not_garbage(tmp_path: Path) -> None:
    data = bytearray(_smooth_jpeg())
    start = data.find(b"\xff\xda") + 200  # past the headers, inside the entropy-coded data
    for i in range(start, len(data) - 2, 1000):
        data[i] ^= 0xFF  # bytes inverted every ~1 kB
    (tmp_path / "corrupt.jpg").write_bytes(bytes(data))
    with pytest.raises(ImageError, match=r"corrupt\.jpg: corrupt JPEG data"):
        load_image(tmp_path / "corrupt.jpg")


def test_truncated_jpeg_is_an_error(tmp_path: Path) -> None:
    data = _smooth_jpeg()
    (tmp_path / "half.jpg").write_bytes(data[: len(data) // 2])
    with pytest.raises(ImageError, match=r"half\.jpg: truncated JPEG"):
        load_image(tmp_path / "half.jpg")
    assert load_image(data).shape == (240, 320, 3)  # the whole file is fine


def test_jpeg_pixels_are_the_same_as_opencvs(tmp_path: Path) -> None:
    data = _smooth_jpeg()
    bgr = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR)
    assert np.array_equal(load_image(data), bgr[:, :, ::-1])
    gray = cv2.imencode(".jpg", cv2.cvtColor(bgr, cv2.COLOR_BGR2GRAY))[1].tobytes()
    img = load_image(gray)
    assert img.shape == (240, 320, 3) and np.array_equal(img[..., 0], img[..., 2])


def test_huge_jpeg_is_refused_before_decoding(tmp_path: Path) -> None:
    from PIL import Image

    path = tmp_path / "tall.jpg"
    Image.new("RGB", (4, MAX_SIDE + 1)).save(path, "JPEG")
    with pytest.raises(ImageError, match=rf"tall\.jpg: image is 4x{MAX_SIDE + 1} px"):
        load_image(path)
