"""``morphonavi models fetch oidv4_ssd``: byte ranges of an npm tarball member, checksums at every step,
the TFLite -> ONNX conversion and its decode head. Never downloads: a generated fake npm tarball is served
by a 127.0.0.1 HTTP server; the real-conversion comparison runs only on a local copy of the tarball."""

from __future__ import annotations

import base64
import dataclasses
import hashlib
import io
import json
import math
import os
import sys
import tarfile
from pathlib import Path
from typing import Iterator

import numpy as np
import pytest

from pipeline.models import registry, ssd_convert
from pipeline.models.base import ModelError, ModelMissingError
from pipeline.models.fetch import fetch
from pipeline.models.registry import CHECKSUMS_FILE, ModelFile, ModelSpec, get_spec, verify
from pipeline.models.ssd_convert import INPUT, RAW_BOXES, RAW_SCORES
from tests.pipeline.models.test_models_fetch import FileServer

N, C = 1917, 24
SHARED_SSD = Path(__file__).resolve().parents[3].parent / "shared" / "models" / "oidv4_ssd"
CACHE_ENV = "MORPHONAVI_TEST_OIDV4_CACHE"
"""A folder holding ``objectron-0.4.1675468480.tgz`` (``npm pack @mediapipe/objectron@0.4.1675468480``)."""
LABELS = ("???\n" + "".join(f"class {i}\n" for i in range(1, C))).encode()
MEMBER = "package/objectron_solution_packed_assets.data"


@pytest.fixture()
def server() -> Iterator[FileServer]:
    import threading

    srv = FileServer()
    thread = threading.Thread(target=srv.serve_forever, daemon=True)
    thread.start()
    yield srv
    srv.shutdown()
    srv.server_close()
    thread.join(timeout=30)


def raw_ssd_graph(scale_boxes: float = 3.0, scale_logits: float = 8.0) -> bytes:
    """A tiny stand-in for tflite2onnx's output: same input and output names and shapes (opset 11), the
    outputs being slices of the input (so each input gives known encodings and logits)."""
    from onnx import TensorProto, helper, numpy_helper

    def const(name: str, value: object, dtype: object = np.int64) -> object:
        return numpy_helper.from_array(np.array(value, dtype=dtype), name)

    inits = [const("shape_flat", [1, -1]), const("s0", [0]), const("s1", [N * 4]), const("s2", [N * 4 + N * C]),
             const("ax1", [1]), const("shape_boxes", [1, N, 4]), const("shape_scores", [1, N, C]),
             const("k_boxes", scale_boxes, np.float32), const("k_logits", scale_logits, np.float32)]
    node = helper.make_node
    nodes = [node("Reshape", [INPUT, "shape_flat"], ["flat"]),
             node("Slice", ["flat", "s0", "s1", "ax1"], ["enc_flat"]),
             node("Reshape", ["enc_flat", "shape_boxes"], ["enc"]),
             node("Mul", ["enc", "k_boxes"], [RAW_BOXES]),
             node("Slice", ["flat", "s1", "s2", "ax1"], ["cls_flat"]),
             node("Reshape", ["cls_flat", "shape_scores"], ["cls"]),
             node("Mul", ["cls", "k_logits"], [RAW_SCORES])]
    graph = helper.make_graph(
        nodes, "raw_ssd", [helper.make_tensor_value_info(INPUT, TensorProto.FLOAT, [1, 3, 300, 300])],
        [helper.make_tensor_value_info(RAW_BOXES, TensorProto.FLOAT, [1, N, 4]),
         helper.make_tensor_value_info(RAW_SCORES, TensorProto.FLOAT, [1, N, C])],
        list(reversed(inits)))  # out of name order, as tflite2onnx leaves them
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 11)], producer_name="tflite2onnx")
    model.ir_version = 6
    return model.SerializeToString()


def raw_outputs(x: np.ndarray, scale_boxes: float = 3.0, scale_logits: float = 8.0) -> tuple[np.ndarray, np.ndarray]:
    flat = x.reshape(-1)
    return (flat[: N * 4].reshape(1, N, 4) * scale_boxes, flat[N * 4: N * 4 + N * C].reshape(1, N, C) * scale_logits)


def run(path: Path, x: np.ndarray) -> list[np.ndarray]:
    import onnxruntime as ort

    sess = ort.InferenceSession(str(path), providers=["CPUExecutionProvider"])
    return sess.run(["boxes", "scores"], {INPUT: x})


def convert_raw(source: Path, target: Path) -> None:
    """Test converter: the extracted bytes are already a raw graph; canonical order + the real decode head."""
    import onnx

    model = ssd_convert.append_decode_head(ssd_convert.canonicalise(onnx.load(str(source))))
    onnx.checker.check_model(model)
    onnx.save(model, str(target))


PROBE: dict[str, tuple[float, ...]] = {}


def check_raw(target: Path) -> float:
    return ssd_convert.check_outputs(target, PROBE)


# -- anchors and the decode head -------------------------------------------------------------------


def test_anchors_follow_mediapipe_ssd_settings() -> None:
    a = ssd_convert.ssd_anchors()
    assert a.shape == (N, 4) and a.dtype == np.float32
    # Lowest layer: 19 x 19 cells, 3 boxes each (scale 0.1 ratio 1, scale 0.2 ratios 2 and 0.5).
    np.testing.assert_allclose(a[0], [0.5 / 19, 0.5 / 19, 0.1, 0.1], rtol=1e-6)
    np.testing.assert_allclose(a[1], [0.5 / 19, 0.5 / 19, 0.2 * math.sqrt(2), 0.2 / math.sqrt(2)], rtol=1e-6)
    np.testing.assert_allclose(a[2], [0.5 / 19, 0.5 / 19, 0.2 / math.sqrt(2), 0.2 * math.sqrt(2)], rtol=1e-6)
    np.testing.assert_allclose(a[3, :2], [1.5 / 19, 0.5 / 19], rtol=1e-6)  # x runs fastest
    np.testing.assert_allclose(a[19 * 3, :2], [0.5 / 19, 1.5 / 19], rtol=1e-6)
    # Second layer (10 x 10, stride 32): scale 0.35, ratios 1, 2, 0.5, 3, 0.3333, then sqrt(0.35 * 0.5) at ratio 1.
    second = a[1083:1083 + 6]
    np.testing.assert_allclose(second[:, :2], [[0.05, 0.05]] * 6, rtol=1e-6)
    np.testing.assert_allclose(second[3, 2:], [0.35 * math.sqrt(3), 0.35 / math.sqrt(3)], rtol=1e-6)
    np.testing.assert_allclose(second[5, 2:], [math.sqrt(0.35 * 0.5)] * 2, rtol=1e-6)
    # Layer sizes 19, 10, 5, 3, 2, 1; the last is one cell at the centre, its extra box at sqrt(0.95 * 1).
    assert 1083 + 600 + 150 + 54 + 24 + 6 == N
    np.testing.assert_allclose(a[-6:, :2], [[0.5, 0.5]] * 6)
    np.testing.assert_allclose(a[-1, 2:], [math.sqrt(0.95)] * 2, rtol=1e-6)
    np.testing.assert_allclose(a[-6, 2:], [0.95, 0.95], rtol=1e-6)


def test_numpy_decode_on_known_encodings() -> None:
    anchors = np.array([[0.5, 0.4, 0.2, 0.1]], dtype=np.float32)
    enc = np.array([[[1.0, 2.0, 0.0, 5.0]]])  # ty, tx, th, tw
    boxes, scores = ssd_convert.decode_numpy(enc, np.array([[[0.0, 2.0]]]), anchors)
    cx, cy = 0.5 + 2.0 / 10 * 0.2, 0.4 + 1.0 / 10 * 0.1
    w, h = math.e * 0.2, 0.1
    np.testing.assert_allclose(boxes[0, 0], [cx - w / 2, cy - h / 2, cx + w / 2, cy + h / 2], rtol=1e-6)
    np.testing.assert_allclose(scores[0, 0], [0.5, 1 / (1 + math.exp(-2))], rtol=1e-6)


def test_decode_head_matches_the_numpy_decode(tmp_path: Path) -> None:
    raw = tmp_path / "raw.onnx"
    raw.write_bytes(raw_ssd_graph())
    out = tmp_path / "decoded.onnx"
    convert_raw(raw, out)
    rng = np.random.default_rng(3)
    x = rng.uniform(-1, 1, (1, 3, 300, 300)).astype(np.float32)
    boxes, scores = run(out, x)
    assert boxes.shape == (1, N, 4) and scores.shape == (1, N, C)
    ref_boxes, ref_scores = ssd_convert.decode_numpy(*raw_outputs(x), ssd_convert.ssd_anchors())
    assert np.abs(boxes - ref_boxes).max() < 1e-5 * max(1.0, np.abs(ref_boxes).max())
    assert np.abs(scores - ref_scores).max() < 1e-6
    assert bool((boxes[..., 2] > boxes[..., 0]).all() and (boxes[..., 3] > boxes[..., 1]).all())


def test_decode_head_refuses_graphs_of_another_shape() -> None:
    import onnx

    model = onnx.load_from_string(raw_ssd_graph())
    with pytest.raises(ModelError, match=r"raw_outputs/box_encodings has shape \[1, 1917, 4\], expected \[1, 10, 4\]"):
        ssd_convert.append_decode_head(model, np.zeros((10, 4), np.float32))
    model.graph.output.pop()
    with pytest.raises(ModelError, match="no output 'raw_outputs/class_predictions'"):
        ssd_convert.append_decode_head(model)


def test_canonical_order_makes_conversions_byte_identical() -> None:
    import onnx

    a = onnx.load_from_string(raw_ssd_graph())
    b = onnx.load_from_string(raw_ssd_graph())
    inits = list(b.graph.initializer)[::-1]
    del b.graph.initializer[:]
    b.graph.initializer.extend(inits)
    assert a.SerializeToString() != b.SerializeToString()
    assert ssd_convert.canonicalise(a).SerializeToString() == ssd_convert.canonicalise(b).SerializeToString()


def test_missing_tflite2onnx_is_one_clear_error(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "tflite2onnx", None)  # import fails as if not installed
    target = tmp_path / "out.onnx"
    with pytest.raises(ModelError) as err:
        ssd_convert.convert_tflite(tmp_path / "x.tflite", target)
    assert str(err.value) == ("converting the TFLite model needs tflite2onnx: pip install 'morphonavi[ssd-convert]' "
                              "(from a source checkout: pip install -e '.[ssd-convert]'), which installs "
                              "tflite2onnx==0.4.1; only this one-time conversion needs it")
    assert not target.exists()


# -- fetching from a fake npm tarball -----------------------------------------------------------------


def fake_tarball(payload: bytes, labels: bytes = LABELS, tail: bytes = b"\0" * 100) -> bytes:
    """An npm-like ``.tgz`` whose packed-assets member holds ``labels`` then ``payload`` then ``tail``."""
    buf = io.BytesIO()
    with tarfile.open(fileobj=buf, mode="w:gz") as tar:
        for name, data in (("package/package.json", b'{"name": "@mediapipe/objectron"}'),
                           (MEMBER, labels + payload + tail)):
            info = tarfile.TarInfo(name)
            info.size = len(data)
            tar.addfile(info, io.BytesIO(data))
    return buf.getvalue()


def sha(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def integrity(data: bytes) -> str:
    return "sha512-" + base64.b64encode(hashlib.sha512(data).digest()).decode()


def fake_spec(url: str, tarball: bytes, payload: bytes, onnx_sha: str | None, convert: str = "raw_onnx",
              **changes: object) -> ModelSpec:
    """The real ``oidv4_ssd`` entry with the fake tarball's URL, sizes and checksums."""
    real = get_spec("oidv4_ssd")
    start = len(LABELS)
    model, labels = real.files
    model = dataclasses.replace(model, url=url, sha256=onnx_sha, size=None, archive_sha256=sha(tarball),
                                archive_integrity=integrity(tarball), archive_size=len(tarball),
                                byte_range=(start, start + len(payload)),
                                source_sha256=sha(payload), convert=convert)
    labels = dataclasses.replace(labels, url=url, sha256=sha(LABELS), size=len(LABELS), archive_sha256=sha(tarball),
                                 archive_integrity=integrity(tarball), archive_size=len(tarball),
                                 byte_range=(0, start))
    model = dataclasses.replace(model, **{k: v for k, v in changes.items() if not k.startswith("labels_")})
    labels = dataclasses.replace(labels, **{k[7:]: v for k, v in changes.items() if k.startswith("labels_")})
    return dataclasses.replace(real, files=(model, labels))


@pytest.fixture()
def fake(server: FileServer, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> dict[str, object]:
    monkeypatch.setitem(registry.CONVERTERS, "raw_onnx", (__name__, "convert_raw", "check_raw"))
    payload = raw_ssd_graph()
    tarball = fake_tarball(payload)
    server.files["/@mediapipe/objectron/-/objectron-0.4.1675468480.tgz"] = tarball
    url = server.url("/@mediapipe/objectron/-/objectron-0.4.1675468480.tgz")
    reference = tmp_path / "reference.onnx"
    src = tmp_path / "raw.onnx"
    src.write_bytes(payload)
    convert_raw(src, reference)
    return {"url": url, "tarball": tarball, "payload": payload, "onnx_sha": sha(reference.read_bytes()),
            "reference": reference}


def assert_nothing_installed(base: Path) -> None:
    assert not (base / "oidv4_ssd").exists(), sorted(p.name for p in (base / "oidv4_ssd").rglob("*"))


def test_fetch_extracts_byte_ranges_converts_and_checks(fake: dict, server: FileServer, tmp_path: Path) -> None:
    spec = fake_spec(fake["url"], fake["tarball"], fake["payload"], fake["onnx_sha"])
    messages: list[str] = []
    files = fetch(spec, tmp_path / "models", progress=False, log=messages.append)
    folder = tmp_path / "models" / "oidv4_ssd"
    assert [f.path.name for f in files] == ["oidv4_ssd.onnx", "labelmap.txt"]
    assert [f.checksum for f in files] == ["published", "published"]
    assert (folder / "labelmap.txt").read_bytes() == LABELS
    assert (folder / "oidv4_ssd.onnx").read_bytes() == Path(fake["reference"]).read_bytes()
    # No .part, no archive, no lock; the installed ONNX's sha256 is recorded (a later change is then seen).
    assert sorted(p.name for p in folder.iterdir()) == [CHECKSUMS_FILE, "labelmap.txt", "oidv4_ssd.onnx"]
    assert registry.recorded_checksums(folder) == {"oidv4_ssd.onnx": fake["onnx_sha"]}
    assert any(f"recorded sha256 {fake['onnx_sha']} in {folder / CHECKSUMS_FILE}" in m for m in messages)
    assert [p for p, _ in server.log] == ["/@mediapipe/objectron/-/objectron-0.4.1675468480.tgz"]  # one download
    assert any("converting (raw_onnx)" in m for m in messages)
    # The fetched folder loads through the registry like any model, and the detector runs.
    from pipeline.models.loader import load_model

    det = load_model("oidv4_ssd", tmp_path / "models", threads=1)
    assert det.labels[:2] == ["???", "class 1"] and len(det.labels) == C
    image = np.full((120, 160, 3), 128, np.uint8)
    dets = det.detect(image, [("thing", "class 5")])
    assert all(d.label == "class 5" and 0 <= d.box[0] < d.box[2] <= 160 for d in dets)
    # Fetching again keeps both files (checksums match) without downloading.
    again = fetch(spec, tmp_path / "models", progress=False, log=messages.append)
    assert [f.downloaded for f in again] == [False, False] and len(server.log) == 1


@pytest.mark.parametrize("change, error", [
    ({"archive_sha256": "f" * 64}, "checksum mismatch for objectron-0.4.1675468480.tgz"),
    ({"archive_integrity": integrity(b"other")}, "integrity mismatch for objectron-0.4.1675468480.tgz: sha512-"),
    ({"source_sha256": "e" * 64}, rf"checksum mismatch for {MEMBER} bytes {len(LABELS)}\.\.\d+ in objectron"),
    ({"labels_sha256": "d" * 64}, rf"checksum mismatch for {MEMBER} bytes 0\.\.{len(LABELS)} in objectron"),
    ({"byte_range": (184, 10 ** 9)}, r"has \d+ bytes: no bytes 184\.\.1000000000"),
    ({"member": "package/none.data"}, "has no member 'package/none.data'"),
])
def test_every_checksum_refusal_leaves_nothing(fake: dict, tmp_path: Path, change: dict, error: str) -> None:
    spec = fake_spec(fake["url"], fake["tarball"], fake["payload"], fake["onnx_sha"], **change)
    with pytest.raises(ModelError, match=error):
        fetch(spec, tmp_path / "models", progress=False, log=lambda m: None)
    assert_nothing_installed(tmp_path / "models")


def test_other_conversion_bytes_are_kept_only_when_outputs_match(fake: dict, tmp_path: Path,
                                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    """Another onnx version may serialise differently: the probe outputs decide, and the new sha256 is
    recorded (verify then checks against it)."""
    boxes, scores = run(Path(fake["reference"]), ssd_convert.probe_input())
    monkeypatch.setattr(sys.modules[__name__], "PROBE", ssd_convert.probe_stats(boxes, scores))
    spec = fake_spec(fake["url"], fake["tarball"], fake["payload"], "a" * 64)
    messages: list[str] = []
    model, _ = fetch(spec, tmp_path / "ok", progress=False, log=messages.append)
    assert model.checksum == "outputs match reference"
    assert any("its outputs match the reference" in m for m in messages)
    recorded = registry.recorded_checksums(tmp_path / "ok" / "oidv4_ssd")
    assert recorded == {"oidv4_ssd.onnx": fake["onnx_sha"]}
    assert registry.expected_sha256(spec, spec.files[0], tmp_path / "ok" / "oidv4_ssd") == (
        fake["onnx_sha"], "recorded at conversion")
    # A present file re-saved with other bytes but the same graph: with a record of what was fetched it is
    # "modified since it was fetched" and made again; without one (first use) its outputs decide and it is
    # recorded; a broken one is made again.
    import onnx

    path = tmp_path / "ok" / "oidv4_ssd" / "oidv4_ssd.onnx"
    resaved = onnx.load(str(path))
    resaved.producer_name = "another converter"
    onnx.save(resaved, str(path))
    again, _ = fetch(spec, tmp_path / "ok", progress=False, log=messages.append)
    assert again.downloaded and again.sha256 == fake["onnx_sha"] == sha(path.read_bytes())
    assert any("oidv4_ssd.onnx: modified since it was fetched" in m for m in messages)
    onnx.save(resaved, str(path))
    (path.parent / CHECKSUMS_FILE).unlink()
    again, _ = fetch(spec, tmp_path / "ok", progress=False, log=messages.append)
    assert (again.downloaded, again.checksum, again.sha256) == (False, "outputs match reference", sha(path.read_bytes()))
    assert registry.recorded_checksums(path.parent) == {"oidv4_ssd.onnx": sha(path.read_bytes())}
    (path.parent / CHECKSUMS_FILE).unlink()
    path.write_bytes(b"not a model")
    again, _ = fetch(spec, tmp_path / "ok", progress=False, log=messages.append)
    assert again.downloaded and path.read_bytes() != b"not a model"
    assert any("oidv4_ssd.onnx does not run" in m for m in messages)
    monkeypatch.setitem(registry.MODELS, "oidv4_ssd", spec)
    (result,) = verify(tmp_path / "ok", ["oidv4_ssd"])
    assert result.ok, result.messages
    # The reference conversion's own bytes are "published" even with a record of other bytes (which goes).
    path.write_bytes(b"not a model")
    (path.parent / CHECKSUMS_FILE).write_text(json.dumps({"oidv4_ssd.onnx": {"sha256": "b" * 64}}))
    assert not verify(tmp_path / "ok", ["oidv4_ssd"])[0].ok
    published = dataclasses.replace(spec, files=(dataclasses.replace(spec.files[0], sha256=fake["onnx_sha"]),
                                                 spec.files[1]))
    again, _ = fetch(published, tmp_path / "ok", progress=False, log=messages.append)
    assert again.downloaded and again.checksum == "published" and again.sha256 == fake["onnx_sha"]
    assert registry.recorded_checksums(path.parent) == {"oidv4_ssd.onnx": fake["onnx_sha"]}  # what it installed
    # Outputs that differ from the reference are refused, and nothing stays.
    wrong = {k: tuple(v + 1.0 for v in vals) for k, vals in PROBE.items()}
    monkeypatch.setattr(sys.modules[__name__], "PROBE", wrong)
    with pytest.raises(ModelError, match="differs from the reference conversion's .* outputs differ"):
        fetch(spec, tmp_path / "bad", progress=False, log=lambda m: None)
    assert_nothing_installed(tmp_path / "bad")


def test_missing_converter_through_fetch_and_cli(fake: dict, server: FileServer, tmp_path: Path,
                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    from pipeline.models import cli_support

    monkeypatch.setitem(sys.modules, "tflite2onnx", None)
    spec = fake_spec(fake["url"], fake["tarball"], fake["payload"], fake["onnx_sha"], convert="tflite_ssd")
    with pytest.raises(ModelError, match=r"needs tflite2onnx: pip install 'morphonavi\[ssd-convert\]'.*tflite2onnx==0\.4\.1"):
        fetch(spec, tmp_path / "models", progress=False, log=lambda m: None)
    assert_nothing_installed(tmp_path / "models")
    assert server.log == []  # found out before downloading anything
    # Once the files are there, fetching again needs no converter.
    monkeypatch.delitem(sys.modules, "tflite2onnx")
    ready = fake_spec(fake["url"], fake["tarball"], fake["payload"], fake["onnx_sha"])
    fetch(ready, tmp_path / "models", progress=False, log=lambda m: None)
    monkeypatch.setitem(sys.modules, "tflite2onnx", None)
    again = fetch(spec, tmp_path / "models", progress=False, log=lambda m: None)
    assert [f.downloaded for f in again] == [False, False]
    monkeypatch.setitem(registry.MODELS, "oidv4_ssd", spec)
    lines: list[str] = []
    assert cli_support.models_fetch(["oidv4_ssd"], tmp_path / "cli", progress=False, log=lines.append) == 1
    errors = [m for m in lines if m.startswith("error:")]
    assert errors == ["error: oidv4_ssd: converting the TFLite model needs tflite2onnx: pip install "
                      "'morphonavi[ssd-convert]' (from a source checkout: pip install -e '.[ssd-convert]'), which "
                      "installs tflite2onnx==0.4.1; only this one-time conversion needs it"]
    assert_nothing_installed(tmp_path / "cli")


# -- registry, loader, mapper ----------------------------------------------------------------------------


def test_registry_entry_describes_the_npm_source() -> None:
    spec = get_spec("oidv4_ssd")
    assert (spec.role, spec.backend, spec.licence) == ("detector", "ssd", "Apache-2.0")
    model, labels = spec.files
    url = "https://registry.npmjs.org/@mediapipe/objectron/-/objectron-0.4.1675468480.tgz"
    assert model.url == labels.url == url and model.member == labels.member == MEMBER
    assert labels.byte_range == (0, 184) and model.byte_range == (184, 9987912)  # back to back, 9,987,728 bytes
    assert model.source_sha256 == "d0a5255bf8c4f5a0bc4240741a76c41d5e939f7655078f945f50ab53a9375da6"
    assert labels.sha256 == "c148336a65f673013609a923fdcbdeec0f49df935045029c3746a3828a0e80e0"
    assert model.archive_sha256 == labels.archive_sha256 and len(model.archive_sha256 or "") == 64
    # npm's own dist.integrity of that version (https://registry.npmjs.org/@mediapipe/objectron).
    assert model.archive_integrity == labels.archive_integrity == (
        "sha512-IoWuW0ojc9GaSW6UoDCIXgwjLSqTEcR5w8NYuGH+R5+q+nKzS7KOIGfY/eyx4DttReumb398W6+PpW0DQ2Rs/w==")
    assert model.convert == "tflite_ssd" and registry.converter("tflite_ssd")[0] is ssd_convert.convert_tflite
    assert "oidv4_ssd" not in {n for members in registry.MODEL_SETS.values() for n in members}


def test_mapper_finds_the_second_detector_through_the_registry(fake: dict, tmp_path: Path) -> None:
    from pipeline.catalog import default_catalog
    from pipeline.mapper_config import _with_second_detector

    catalog = default_catalog()
    with pytest.raises(ModelMissingError, match="fetch with: morphonavi models fetch oidv4_ssd"):
        _with_second_detector(object(), "oidv4_ssd", tmp_path / "empty", catalog)
    spec = fake_spec(fake["url"], fake["tarball"], fake["payload"], fake["onnx_sha"])
    fetch(spec, tmp_path / "models", progress=False, log=lambda m: None)
    (tmp_path / "models" / "oidv4_ssd" / "labelmap.txt").write_text(
        "???\n" + "".join(f"{name}\n" for name in ["Table", "Desk"] + [f"c{i}" for i in range(3, C)]))
    merged = _with_second_detector(object(), "oidv4_ssd", tmp_path / "models", catalog)
    second = merged.members[1]
    assert second.name == "oidv4_ssd" and second.label_map["Table"] == catalog.lookup("Table").name
    assert "c3" not in second.label_map


@pytest.mark.skipif(not (SHARED_SSD / "oidv4_ssd.onnx").is_file(), reason=f"{SHARED_SSD} not present")
def test_the_shared_copy_is_found_and_verified_by_its_outputs(monkeypatch: pytest.MonkeyPatch,
                                                               tmp_path: Path) -> None:
    monkeypatch.setenv(registry.MODELS_ENV, str(tmp_path / "empty"))
    assert registry.locate("oidv4_ssd") == SHARED_SSD
    (result,) = verify(SHARED_SSD.parent, ["oidv4_ssd"])
    assert result.ok, result.messages
    assert any("outputs match it" in m for m in result.messages)  # other bytes (its own head), same outputs


def _tflite2onnx_available() -> bool:
    try:
        import tflite2onnx  # noqa: F401
    except ImportError:
        return False
    return True


def _cached_tarball() -> Path | None:
    folder = os.environ.get(CACHE_ENV, "").strip()
    path = Path(folder) / "objectron-0.4.1675468480.tgz" if folder else None
    return path if path is not None and path.is_file() else None


@pytest.mark.skipif(not (SHARED_SSD / "oidv4_ssd.onnx").is_file(), reason=f"{SHARED_SSD} not present")
@pytest.mark.skipif(not _tflite2onnx_available(), reason="tflite2onnx not installed (pip install 'tflite2onnx==0.4.1')")
@pytest.mark.skipif(_cached_tarball() is None,
                    reason=f"set {CACHE_ENV} to a folder holding objectron-0.4.1675468480.tgz (npm pack); tests never download")
def test_real_conversion_matches_the_shared_model(tmp_path: Path) -> None:
    tarball = _cached_tarball()
    assert tarball is not None
    real = get_spec("oidv4_ssd")
    spec = dataclasses.replace(real, files=tuple(dataclasses.replace(f, url=tarball.as_uri()) for f in real.files))
    files = fetch(spec, tmp_path, progress=False, log=lambda m: None)
    assert [f.checksum for f in files] == ["published", "published"]  # tarball, tflite, onnx and labels all pinned
    converted = tmp_path / "oidv4_ssd" / "oidv4_ssd.onnx"
    assert (tmp_path / "oidv4_ssd" / "labelmap.txt").read_bytes() == (SHARED_SSD / "labelmap.txt").read_bytes()
    rng = np.random.default_rng(0)
    for x in (ssd_convert.probe_input(), rng.uniform(-1, 1, (1, 3, 300, 300)).astype(np.float32)):
        ours, theirs = run(converted, x), run(SHARED_SSD / "oidv4_ssd.onnx", x)
        assert np.abs(ours[0] - theirs[0]).max() < 1e-5 and np.abs(ours[1] - theirs[1]).max() < 1e-5
