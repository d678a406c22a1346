"""Model registry, directory resolution, list / verify, and load_models."""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np
import pytest
from onnx_fixtures import depth_anything_model, fastdepth_model, sam_decoder, sam_encoder, wrong_signature_model

from pipeline.models import ModelBundle, ModelError, ModelMissingError, load_model, load_models
from pipeline.models import registry
from pipeline.models.base import DepthEstimator, Detector, Segmenter
from pipeline.models.registry import (
    MODEL_SETS,
    MODELS,
    MODELS_ENV,
    format_table,
    list_models,
    locate,
    resolve_models_dir,
    search_dirs,
    set_members,
    verify,
)

SHARED_MODELS = Path(__file__).resolve().parents[3].parent / "shared" / "models"


def test_registry_is_consistent() -> None:
    assert MODEL_SETS["offline"] == ("yolox_nano", "mobilesam", "fastdepth")
    assert MODEL_SETS["hub"] == ("owlv2", "mobilesam", "depth_anything_v2_small")
    assert set_members("default") == MODEL_SETS["hub"]  # the hub set's old name is still accepted
    for names in MODEL_SETS.values():
        roles = [MODELS[n].role for n in names]
        assert roles == ["detector", "segmenter", "depth"]
    for spec in MODELS.values():
        for f in spec.files:
            assert f.url.startswith("https://")
            assert f.sha256 is None or len(f.sha256) == 64
    # The offline set is exactly the shared development weights, with their real checksums.
    offline_files = {f"{n}/{f.path}": f.sha256 for n in MODEL_SETS["offline"] for f in MODELS[n].files}
    assert offline_files["mobilesam/encoder.onnx"].startswith("18348d14")
    assert all(offline_files.values())
    # Hub files have no invented checksums.
    assert all(f.sha256 is None for f in MODELS["owlv2"].files)


def test_models_dir_precedence(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.delenv(MODELS_ENV, raising=False)
    assert resolve_models_dir().parts[-2:] == ("morphonavi", "models")
    monkeypatch.setenv(MODELS_ENV, str(tmp_path / "env"))
    assert resolve_models_dir() == tmp_path / "env"
    assert resolve_models_dir(tmp_path / "explicit") == tmp_path / "explicit"
    assert search_dirs(tmp_path / "explicit") == [tmp_path / "explicit"]
    assert search_dirs()[0] == tmp_path / "env"


def _offline_tiny(base: Path) -> Path:
    """A models dir with tiny stand-ins for the offline set (same file names and signatures)."""
    sam_encoder(base / "mobilesam" / "encoder.onnx")
    sam_decoder(base / "mobilesam" / "decoder.onnx")
    fastdepth_model(base / "fastdepth" / "fastdepth.onnx")
    from onnx_fixtures import yolox_model

    yolox_model(base / "yolox_nano" / "yolox_nano.onnx", np.zeros((1, 84, 85), np.float32), input_size=64)
    (base / "yolox_nano" / "coco_classes.txt").write_text("\n".join(f"c{i}" for i in range(80)))
    return base


def test_list_and_load_from_an_explicit_dir(tmp_path: Path) -> None:
    base = _offline_tiny(tmp_path / "models")
    rows = {r.name: r for r in list_models(base)}
    assert rows["fastdepth"].status == "present" and rows["fastdepth"].location == base / "fastdepth"
    assert rows["owlv2"].status == "missing"
    assert rows["owlv2"].as_row()["where"] == "run: morphonavi models fetch owlv2"
    assert rows["grounding_dino_cloud"].status == "api"
    table = format_table([r.as_row() for r in rows.values()])
    assert table.splitlines()[0].split()[:4] == ["NAME", "ROLE", "SETS", "STATUS"]
    bundle = load_models("offline", base, threads=1, label_map={"c56": "chair"})
    assert isinstance(bundle, ModelBundle) and bundle.names == MODEL_SETS["offline"]
    assert isinstance(bundle.detector, Detector) and isinstance(bundle.segmenter, Segmenter)
    assert isinstance(bundle.depth, DepthEstimator)
    assert bundle.detector.vocabulary([("a chair", "chair"), ("a bed", "bed")]) == {"chair"}
    assert bundle.depth.estimate(np.zeros((10, 20, 3), np.uint8)).values.shape == (10, 20)


def test_missing_models_name_the_fetch_command(tmp_path: Path) -> None:
    with pytest.raises(ModelMissingError) as err:
        load_models("offline", tmp_path)
    text = str(err.value)
    for name in ("yolox_nano", "mobilesam", "fastdepth"):
        assert f"morphonavi models fetch {name}" in text
    assert str(tmp_path) in text
    base = _offline_tiny(tmp_path / "m")
    (base / "mobilesam" / "decoder.onnx").unlink()
    expected = r"^model 'mobilesam' not found .*fetch with: morphonavi models fetch mobilesam$"
    with pytest.raises(ModelMissingError, match=expected):
        load_models("offline", base)
    with pytest.raises(ModelError, match="unknown model set 'fast'; known sets: offline, hub, cloud"):
        load_models("fast", base)


def test_cloud_set_needs_only_the_key_and_local_models(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    base = _offline_tiny(tmp_path)
    d = base / "depth_anything_v2_small"
    depth_anything_model(d / "model.onnx")
    (d / "config.json").write_text(json.dumps({"model_type": "depth_anything"}))
    (d / "preprocessor_config.json").write_text(json.dumps({"size": {"height": 28, "width": 28}}))
    monkeypatch.delenv("MORPHONAVI_CLOUD_API_KEY", raising=False)
    with pytest.raises(ModelError, match="MORPHONAVI_CLOUD_API_KEY"):
        load_models("cloud", base)
    monkeypatch.setenv("MORPHONAVI_CLOUD_API_KEY", "k")
    bundle = load_models("cloud", base, threads=1)
    assert bundle.detector.name == "cloud:GroundingDino-1.5-Pro" and bundle.depth.kind == "inverse_relative"


def test_verify_reports_signature_and_checksum_problems(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    base = _offline_tiny(tmp_path)
    wrong_signature_model(base / "fastdepth" / "fastdepth.onnx")
    results = {r.name: r for r in verify(base, check_hashes=False)}
    assert results["mobilesam"].ok and results["yolox_nano"].ok
    assert not results["fastdepth"].ok and "missing input '0'" in "; ".join(results["fastdepth"].messages)
    assert "owlv2" not in results  # absent models are only reported when asked for
    (missing,) = verify(base, ["owlv2"])
    assert not missing.ok and "morphonavi models fetch owlv2" in missing.messages[0]
    # With checksums: the tiny stand-ins do not match the published hashes.
    (sam,) = verify(base, ["mobilesam"])
    assert not sam.ok and "differs from the published" in sam.messages[0]
    with pytest.raises(ModelError, match="unknown model"):
        verify(base, ["nope"])


@pytest.mark.skipif(not SHARED_MODELS.is_dir(), reason=f"shared development weights not found at {SHARED_MODELS}")
def test_shared_layout_is_recognised_and_verified(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    assert locate("yolox_nano", SHARED_MODELS) == SHARED_MODELS / "yolox_nano"
    monkeypatch.setenv(MODELS_ENV, str(tmp_path / "empty"))  # nothing in the cache: falls back to shared
    assert registry.shared_models_dir() == SHARED_MODELS
    assert locate("fastdepth") == SHARED_MODELS / "fastdepth"
    t0 = time.perf_counter()
    results = verify(SHARED_MODELS, MODEL_SETS["offline"])
    assert all(r.ok for r in results), [r.messages for r in results]
    print(f"\nverify of the offline set (sha256 + signatures): {time.perf_counter() - t0:.2f} s")
    det = load_model("yolox_nano", SHARED_MODELS, threads=1)
    assert det.vocabulary([("a chair", "chair")]) == {"chair"}  # identity label map by default


def test_cli_list_and_verify(tmp_path: Path) -> None:
    from pipeline.models.cli_support import models_list, models_verify

    base = _offline_tiny(tmp_path)
    text = models_list(base)
    assert "fastdepth" in text and f"searched: {base}" in text and "offline: yolox_nano, mobilesam, fastdepth" in text
    table, code = models_verify(base, ["offline"])
    assert code == 1 and "FAILED" in table  # tiny stand-ins fail the published checksums
    assert models_verify(tmp_path / "empty") == (f"no models found in {tmp_path / 'empty'}", 1)
    assert models_verify(base, ["nope"])[1] == 1
