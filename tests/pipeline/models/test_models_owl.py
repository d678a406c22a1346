"""OWLv2 / OWL-ViT backends on tiny ONNX graphs with the hub exports' I/O signature."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("tokenizers", reason="the OWL backends need the 'tokenizers' package")

from onnx_fixtures import owl_model, wrong_signature_model, write_tokenizer  # noqa: E402

from pipeline.models.base import ModelError  # noqa: E402
from pipeline.models.owl import ClipTokens, OwlDetector  # noqa: E402

WHITE = 255
PROMPTS = [("a red box", "red_thing"), ("a green box", "green_thing"), ("a blue box", "blue_thing")]


def _model_dir(tmp_path: Path, size: int = 32) -> Path:
    d = tmp_path / "owl"
    owl_model(d / "model.onnx", image_size=size, patch=8)
    write_tokenizer(d / "tokenizer.json")
    (d / "preprocessor_config.json").write_text(json.dumps({"size": {"height": size, "width": size}}))
    return d


def _image() -> np.ndarray:
    """64 x 128 white image, a red block at x 32..64, y 0..32 and a green block at x 96..128, y 32..64."""
    img = np.full((64, 128, 3), WHITE, dtype=np.uint8)
    img[0:32, 32:64] = (255, 0, 0)
    img[32:64, 96:128] = (0, 255, 0)
    return img


def test_owlv2_pads_to_square_and_maps_boxes_back(tmp_path: Path) -> None:
    det = OwlDetector.from_dir(_model_dir(tmp_path), variant="owlv2", score_threshold=0.5)
    found = det.detect(_image(), PROMPTS)
    by_label = {d.label: d for d in found}
    assert set(by_label) == {"red_thing", "green_thing"}
    # 128x128 padded square, 4x4 patches of 32 px: the red block is patch (row 0, col 1).
    assert by_label["red_thing"].box == pytest.approx((32, 0, 64, 32), abs=1e-3)
    assert by_label["green_thing"].box == pytest.approx((96, 32, 128, 64), abs=1e-3)
    assert by_label["red_thing"].prompt == "a red box"
    assert by_label["red_thing"].score > 0.99
    assert found[0].score >= found[-1].score
    assert det.vocabulary(PROMPTS) == {"red_thing", "green_thing", "blue_thing"}


def test_owlv2_padding_is_grey_not_a_colour(tmp_path: Path) -> None:
    det = OwlDetector.from_dir(_model_dir(tmp_path), variant="owlv2", score_threshold=0.1)
    tensor, scale = det.preprocess(_image())
    assert tensor.shape == (1, 3, 32, 32) and scale == (128.0, 128.0)
    # Bottom half of the square is padding: grey 0.5 after CLIP normalisation.
    expected = (0.5 - det.mean) / det.std
    assert tensor[0, :, 20, 5] == pytest.approx(expected, abs=1e-4)
    labels = [d.label for d in det.detect(_image(), PROMPTS)]
    assert labels.count("blue_thing") == 0


def test_owlvit_stretches_the_image(tmp_path: Path) -> None:
    det = OwlDetector.from_dir(_model_dir(tmp_path), variant="owlvit", score_threshold=0.5)
    img = np.full((64, 128, 3), WHITE, dtype=np.uint8)
    img[16:32, 32:64] = (255, 0, 0)  # stretched to 32x32: x / 4, y / 2 -> patch (row 1, col 1)
    (red,) = det.detect(img, PROMPTS)
    assert red.label == "red_thing"
    assert red.box == pytest.approx((32, 16, 64, 32), abs=1e-3)


def test_same_class_prompts_are_merged_by_nms(tmp_path: Path) -> None:
    det = OwlDetector.from_dir(_model_dir(tmp_path), variant="owlv2", score_threshold=0.5)
    prompts = [("a red box", "red_thing"), ("a big red thing", "red_thing"), ("green", "green_thing")]
    found = det.detect(_image(), prompts)
    assert sorted(d.label for d in found) == ["green_thing", "red_thing"]


def test_tokens_are_padded_masked_and_cached(tmp_path: Path) -> None:
    path = write_tokenizer(tmp_path / "tokenizer.json")
    tokens = ClipTokens(path)
    ids, mask = tokens(["red", "a big red box"])
    assert ids.dtype == np.int64 and ids.shape == (2, 6)
    assert mask.tolist() == [[1, 1, 1, 0, 0, 0], [1, 1, 1, 1, 1, 1]]
    assert ids[0, 3:].tolist() == [tokens.pad_id] * 3 and tokens.pad_id == 0  # "!" pads, as in OWL
    assert tokens(["red", "a big red box"])[0] is ids  # cached per prompt tuple
    long_ids, _ = tokens([" ".join(["red"] * 30)])
    assert long_ids.shape == (1, 16)
    assert long_ids[0, -1] == tokens.tokenizer.token_to_id("<|endoftext|>")  # end token kept


def test_bad_inputs_raise_model_errors(tmp_path: Path) -> None:
    det = OwlDetector.from_dir(_model_dir(tmp_path), variant="owlv2")
    with pytest.raises(ModelError, match="HxWx3"):
        det.detect(np.zeros((8, 8), np.uint8), PROMPTS)
    with pytest.raises(ModelError, match=r"prompts\[0\]"):
        det.detect(_image(), ["red"])  # type: ignore[list-item]
    assert det.detect(_image(), []) == []
    with pytest.raises(ModelError, match="variant"):
        OwlDetector.from_dir(tmp_path / "owl", variant="owl3")  # type: ignore[arg-type]


def test_wrong_export_is_refused_with_the_expected_signature(tmp_path: Path) -> None:
    d = tmp_path / "bad"
    wrong_signature_model(d / "model.onnx")
    write_tokenizer(d / "tokenizer.json")
    with pytest.raises(ModelError) as err:
        OwlDetector.from_dir(d)
    text = str(err.value)
    assert "missing input 'input_ids'" in text and "pixel_values" in text and "x[1,3,8,8]" in text


def test_missing_or_corrupt_tokenizer(tmp_path: Path) -> None:
    d = _model_dir(tmp_path)
    (d / "tokenizer.json").write_text("{not json")
    with pytest.raises(ModelError, match="tokenizer"):
        OwlDetector.from_dir(d)
    (d / "tokenizer.json").unlink()
    with pytest.raises(ModelError, match="missing tokenizer file"):
        OwlDetector.from_dir(d)


# --- text embeddings cached per vocabulary (the export cut at text_embeds) -----------------------


def _detections(found: list) -> list[tuple]:
    return [(d.label, d.prompt, tuple(round(v, 4) for v in d.box), round(d.score, 6)) for d in found]


def test_text_tower_runs_once_per_vocabulary_and_matches_the_whole_graph(tmp_path: Path) -> None:
    d = _model_dir(tmp_path)
    cached = OwlDetector.from_dir(d, variant="owlv2", score_threshold=0.5)
    whole = OwlDetector.from_dir(d, variant="owlv2", score_threshold=0.5, cache_text=False)
    assert cached.parts is not None and cached.text_cache_off is None
    assert set(cached.parts.image_inputs) == {"pixel_values", "text_embeds", "input_ids"}  # no attention_mask
    assert whole.parts is None and whole.text_cache_off == "disabled"

    first = cached.detect(_image(), PROMPTS)
    assert _detections(first) == _detections(whole.detect(_image(), PROMPTS))
    assert {x.label for x in first} == {"red_thing", "green_thing"}
    assert cached.text_tower_runs == 1
    other = np.full((64, 128, 3), WHITE, dtype=np.uint8)
    other[32:64, 0:32] = (0, 0, 255)
    (blue,) = cached.detect(other, PROMPTS)  # a new photo, same vocabulary: no text tower
    assert blue.label == "blue_thing" and cached.text_tower_runs == 1
    cached.detect(_image(), PROMPTS[:2])  # another vocabulary
    assert cached.text_tower_runs == 2
    cached.detect(_image(), PROMPTS)
    assert cached.text_tower_runs == 2  # still cached


def test_the_cut_passes_below_a_reshape_that_reads_the_image_batch(tmp_path: Path) -> None:
    """In the real exports text_embeds = reshape(normalised text embeddings, (image batch, -1, D)):
    the text part must not need the image, so the cut moves to the reshape's input."""
    d = _model_dir(tmp_path)
    owl_model(d / "model.onnx", image_size=32, patch=8, batch_from_image=True)
    cached = OwlDetector.from_dir(d, variant="owlv2", score_threshold=0.5)
    assert cached.parts is not None, cached.text_cache_off
    assert cached.parts.text_output == "text_vec"
    assert [i.name for i in cached.parts.text.get_inputs()] == ["input_ids", "attention_mask"]
    assert set(cached.parts.image_inputs) == {"pixel_values", "text_vec", "input_ids"}
    whole = OwlDetector.from_dir(d, variant="owlv2", score_threshold=0.5, cache_text=False)
    assert _detections(cached.detect(_image(), PROMPTS)) == _detections(whole.detect(_image(), PROMPTS))
    assert {x.label for x in cached.detect(_image(), PROMPTS)} == {"red_thing", "green_thing"}
    assert cached.text_tower_runs == 1


def test_padded_queries_are_masked_in_the_image_part(tmp_path: Path) -> None:
    """The image part still reads input_ids: a query whose first token is padding never scores."""
    det = OwlDetector.from_dir(_model_dir(tmp_path), variant="owlv2", score_threshold=0.5)
    ids, _ = det.tokens(["a red box"])
    pixel_values, _ = det.preprocess(_image())
    embeds = det.text_embeddings(["a red box"])
    logits, _ = det.parts.image.run(None, {"pixel_values": pixel_values, "text_embeds": embeds, "input_ids": ids})
    assert logits.max() > 0
    logits, _ = det.parts.image.run(None, {"pixel_values": pixel_values, "text_embeds": embeds,
                                            "input_ids": np.zeros_like(ids)})
    assert logits.max() < -1e5


def test_an_export_that_cannot_be_cut_runs_whole(tmp_path: Path) -> None:
    d = _model_dir(tmp_path)
    owl_model(d / "model.onnx", image_size=32, patch=8, head_reads_embeds=False)
    det = OwlDetector.from_dir(d, variant="owlv2", score_threshold=0.5)
    assert det.parts is None and "does not read the text tower only through 'text_embeds'" in det.text_cache_off
    assert {x.label for x in det.detect(_image(), PROMPTS)} == {"red_thing", "green_thing"}
    with pytest.raises(ModelError, match="not cached"):
        det.text_embeddings(["a red box"])
