"""OWL-ViT and OWLv2 open-vocabulary detectors (Hugging Face ``Xenova`` / ``onnx-community`` exports).

The exports are ONE graph (``model.onnx``, task zero-shot-object-detection):

- inputs ``input_ids`` int64 [Q, L] (one row per text query, CLIP BPE, at most 16 tokens),
  ``pixel_values`` float32 [1, 3, S, S], ``attention_mask`` int64 [Q, L];
- outputs ``logits`` [1, P, Q] (per patch box and query, before the sigmoid), ``pred_boxes``
  [1, P, 4] (normalised cx, cy, w, h), ``text_embeds`` [1, Q, D], ``image_embeds`` [1, g, g, D].

Pre-processing (``preprocessor_config.json``): pixels / 255, normalised with the CLIP mean/std.
OWL-ViT stretches the image to SxS (768 for base-patch32), so boxes are relative to the image;
OWLv2 pads the image to a square at the bottom/right with grey 0.5 and resizes it to SxS (960), so
boxes are relative to the padded square of side max(H, W).

Post-processing: score = sigmoid(max over queries), the best query names the class; boxes above
``score_threshold`` pass a class-wise NMS.

The export runs the text tower with every image. At load the graph is cut at ``text_embeds``
(:mod:`pipeline.models.owl_split`), so each vocabulary's text embeddings are computed once and
cached; when an export cannot be cut, the whole graph runs (and the tokens are still cached).
Tokenisation uses the ``tokenizers`` package and the export's ``tokenizer.json``.
"""

from __future__ import annotations

import logging
import time
from collections import OrderedDict
from pathlib import Path
from typing import Any, Literal, Sequence

import cv2
import numpy as np

from pipeline.models.base import Detection, ModelError, Prompt, check_image, check_prompts
from pipeline.models.hub_config import parse_size, parse_triplet, read_json
from pipeline.models.nms import batched_nms
from pipeline.models.owl_split import OwlParts, SplitError, split_owl
from pipeline.models.session import IOSignature, TensorSpec, open_session, run

log = logging.getLogger(__name__)

Variant = Literal["owlv2", "owlvit"]

CLIP_MEAN = (0.48145466, 0.4578275, 0.40821073)
CLIP_STD = (0.26862954, 0.26130258, 0.27577711)
DEFAULT_SIZE: dict[str, int] = {"owlv2": 960, "owlvit": 768}
MAX_TEXT_LENGTH = 16
OWLV2_PAD_VALUE = 0.5
TEXT_CACHE_SIZE = 8  # vocabularies whose text embeddings are kept

SIGNATURE = IOSignature(
    inputs=(
        TensorSpec("input_ids", 2),
        TensorSpec("pixel_values", 4, (1, 3, None, None)),
        TensorSpec("attention_mask", 2),
    ),
    outputs=(TensorSpec("logits", 3), TensorSpec("pred_boxes", 3)),
)


def _sigmoid(x: np.ndarray) -> np.ndarray:
    return 1.0 / (1.0 + np.exp(-np.clip(x, -60.0, 60.0)))


class ClipTokens:
    """CLIP tokeniser from a ``tokenizer.json``: texts -> padded ``input_ids`` / ``attention_mask``.

    Args:
        tokenizer_path: The ``tokenizer.json`` of the export.
        max_length: Tokens per query including the start/end tokens (OWL: 16).
        pad_token: Padding token (OWL pads with ``"!"``, id 0); ``None``: from
            ``tokenizer_config.json`` beside the tokenizer, else ``"!"``, else id 0.
    """

    def __init__(
        self, tokenizer_path: Path | str, max_length: int = MAX_TEXT_LENGTH, pad_token: str | None = None
    ) -> None:
        try:
            from tokenizers import Tokenizer
        except ImportError as exc:  # pragma: no cover - depends on the environment
            raise ModelError("the OWL detectors need the 'tokenizers' package: pip install tokenizers") from exc
        path = Path(tokenizer_path)
        if not path.is_file():
            raise ModelError(f"missing tokenizer file {path}")
        try:
            self.tokenizer = Tokenizer.from_file(str(path))
        except Exception as exc:  # tokenizers raises a plain Exception on bad JSON
            raise ModelError(f"{path}: not a valid tokenizer.json: {exc}") from exc
        self.tokenizer.no_padding()
        self.tokenizer.no_truncation()
        self.max_length = int(max_length)
        if pad_token is None:
            cfg = read_json(path.parent / "tokenizer_config.json")
            pad = cfg.get("pad_token")
            pad_token = pad.get("content") if isinstance(pad, dict) else pad
        pad_id = self.tokenizer.token_to_id(pad_token) if pad_token else None
        if pad_id is None:
            pad_id = self.tokenizer.token_to_id("!")
        self.pad_id = int(pad_id) if pad_id is not None else 0
        self._cache: dict[tuple[str, ...], tuple[np.ndarray, np.ndarray]] = {}

    def __call__(self, texts: Sequence[str]) -> tuple[np.ndarray, np.ndarray]:
        """``(input_ids, attention_mask)`` int64 [Q, L], L = longest query (<= ``max_length``); cached."""
        key = tuple(texts)
        hit = self._cache.get(key)
        if hit is not None:
            return hit
        rows = []
        for text in texts:
            ids = list(self.tokenizer.encode(text.lower()).ids)
            if not ids:
                raise ModelError(f"prompt {text!r} produced no tokens")
            if len(ids) > self.max_length:  # keep the end token: CLIP pools at it
                ids = ids[: self.max_length - 1] + ids[-1:]
            rows.append(ids)
        length = max(len(r) for r in rows)
        input_ids = np.full((len(rows), length), self.pad_id, dtype=np.int64)
        mask = np.zeros((len(rows), length), dtype=np.int64)
        for i, r in enumerate(rows):
            input_ids[i, : len(r)] = r
            mask[i, : len(r)] = 1
        self._cache[key] = (input_ids, mask)
        return input_ids, mask


class OwlDetector:
    """OWL-ViT / OWLv2 open-vocabulary detector on a combined ONNX export.

    Args:
        model_path: ``model.onnx``.
        tokenizer_path: ``tokenizer.json``.
        variant: ``"owlv2"`` (pad to square, 960) or ``"owlvit"`` (stretch, 768).
        preprocessor: ``preprocessor_config.json`` contents (``size``, ``image_mean``, ``image_std``).
        score_threshold: Minimum sigmoid score.
        nms_iou: IoU above which a lower-scoring box of the same class is dropped.
        threads: onnxruntime intra-op threads (default: every core).
        cache_text: Cut the graph at ``text_embeds`` so each vocabulary's text tower runs once
            (falls back to the whole graph when the export cannot be cut; see ``text_cache_off``).
    """

    def __init__(
        self,
        model_path: Path | str,
        tokenizer_path: Path | str,
        *,
        variant: Variant = "owlv2",
        preprocessor: dict[str, Any] | None = None,
        score_threshold: float = 0.1,
        nms_iou: float = 0.5,
        threads: int | None = None,
        name: str | None = None,
        cache_text: bool = True,
    ) -> None:
        if variant not in DEFAULT_SIZE:
            raise ModelError(f"OWL variant must be 'owlv2' or 'owlvit', got {variant!r}")
        self.variant: Variant = variant
        self.name = name or variant
        self.score_threshold = float(score_threshold)
        self.nms_iou = float(nms_iou)
        pre = preprocessor or {}
        where = f"model {self.name!r} preprocessor config"
        self.parts: OwlParts | None = None
        self.text_cache_off: str | None = "disabled" if not cache_text else None
        self.session: Any = None
        if cache_text and Path(model_path).is_file():
            try:
                self.parts = split_owl(model_path, SIGNATURE, f"model {self.name!r} ({model_path})", threads)
            except SplitError as exc:
                self.text_cache_off = str(exc)
                log.info("text embeddings not cached, running the whole graph: %s", exc)
        if self.parts is None:
            self.session = open_session(model_path, SIGNATURE, threads=threads, model_name=self.name)
            fixed = next(i for i in self.session.get_inputs() if i.name == "pixel_values").shape[2:4]
        else:
            fixed = next(t for t in self.parts.signature.inputs if t.name == "pixel_values").shape[2:4]
        if "size" in pre:
            self.input_hw = parse_size(pre["size"], where)
        elif all(isinstance(d, int) for d in fixed):
            self.input_hw = (int(fixed[0]), int(fixed[1]))
        else:
            self.input_hw = (DEFAULT_SIZE[variant], DEFAULT_SIZE[variant])
        self.mean = np.array(parse_triplet(pre.get("image_mean"), CLIP_MEAN, where), dtype=np.float32)
        self.std = np.array(parse_triplet(pre.get("image_std"), CLIP_STD, where), dtype=np.float32)
        self.tokens = ClipTokens(tokenizer_path)
        self.last_timings: dict[str, float] = {}
        self.text_tower_runs = 0  # how often the text embeddings were computed (split graph only)
        self._text_cache: OrderedDict[tuple[str, ...], np.ndarray] = OrderedDict()

    @classmethod
    def from_dir(cls, model_dir: Path | str, variant: Variant = "owlv2", **kwargs: Any) -> OwlDetector:
        """Load ``model.onnx``, ``tokenizer.json`` and ``preprocessor_config.json`` from ``model_dir``."""
        model_dir = Path(model_dir)
        return cls(
            model_dir / "model.onnx",
            model_dir / "tokenizer.json",
            variant=variant,
            preprocessor=read_json(model_dir / "preprocessor_config.json"),
            **kwargs,
        )

    def vocabulary(self, prompts: Sequence[Prompt]) -> frozenset[str]:
        """Every class named in ``prompts`` (open vocabulary)."""
        return frozenset(c for _, c in check_prompts(prompts, self.name))

    def preprocess(self, image_rgb: np.ndarray) -> tuple[np.ndarray, tuple[float, float]]:
        """``(pixel_values [1, 3, S, S], (sx, sy))``: a normalised box times (sx, sy) is in pixels."""
        h, w = image_rgb.shape[:2]
        in_h, in_w = self.input_hw
        image = image_rgb.astype(np.float32) / 255.0
        if self.variant == "owlv2":
            side = max(h, w)
            square = np.full((side, side, 3), OWLV2_PAD_VALUE, dtype=np.float32)
            square[:h, :w] = image
            image, scale = square, (float(side), float(side))
        else:
            scale = (float(w), float(h))
        interp = cv2.INTER_AREA if image.shape[0] > in_h else cv2.INTER_LINEAR
        resized = cv2.resize(image, (in_w, in_h), interpolation=interp)
        tensor = (resized - self.mean) / self.std
        return np.ascontiguousarray(tensor.transpose(2, 0, 1)[None], dtype=np.float32), scale

    def text_embeddings(self, texts: Sequence[str]) -> np.ndarray:
        """The queries' text embeddings (the tensor the graph was cut at: ``text_embeds`` [1, Q, D] or
        the normalised [Q, D] it is reshaped from), computed once per vocabulary (split graph only)."""
        if self.parts is None:
            raise ModelError(f"model {self.name!r}: text embeddings are not cached ({self.text_cache_off})")
        key = tuple(texts)
        hit = self._text_cache.get(key)
        if hit is not None:
            self._text_cache.move_to_end(key)
            return hit
        input_ids, attention_mask = self.tokens(texts)
        (embeds,) = run(self.parts.text, [self.parts.text_output],
                        {"input_ids": input_ids, "attention_mask": attention_mask}, f"model {self.name!r} (text part)")
        self.text_tower_runs += 1
        self._text_cache[key] = embeds
        while len(self._text_cache) > TEXT_CACHE_SIZE:
            self._text_cache.popitem(last=False)
        return embeds

    def detect(self, image_rgb: np.ndarray, prompts: Sequence[Prompt]) -> list[Detection]:
        """Detections of ``prompts`` (text, class name), best first."""
        image = check_image(image_rgb, self.name)
        pairs = list(dict.fromkeys(check_prompts(prompts, self.name)))
        if not pairs:
            self.last_timings = {"detect": 0.0}
            return []
        t0 = time.perf_counter()
        texts = [t for t, _ in pairs]
        input_ids, attention_mask = self.tokens(texts)
        pixel_values, (sx, sy) = self.preprocess(image)
        what = f"model {self.name!r}"
        if self.parts is None:
            logits, boxes = run(self.session, ["logits", "pred_boxes"],
                                {"input_ids": input_ids, "pixel_values": pixel_values, "attention_mask": attention_mask},
                                what)
        else:
            feeds = {"pixel_values": pixel_values, self.parts.text_output: self.text_embeddings(texts),
                     "input_ids": input_ids}
            logits, boxes = run(self.parts.image, ["logits", "pred_boxes"],
                                {k: feeds[k] for k in self.parts.image_inputs}, what)
        logits, boxes = np.asarray(logits)[0], np.asarray(boxes, dtype=np.float64)[0]
        if logits.ndim != 2 or logits.shape[1] != len(pairs) or boxes.shape != (logits.shape[0], 4):
            raise ModelError(
                f"model {self.name!r}: unexpected output shapes logits {logits.shape}, pred_boxes {boxes.shape} "
                f"for {len(pairs)} queries"
            )
        best = np.argmax(logits, axis=1)
        scores = _sigmoid(logits[np.arange(logits.shape[0]), best].astype(np.float64))
        keep = scores >= self.score_threshold
        boxes, best, scores = boxes[keep], best[keep], scores[keep]
        cx, cy, bw, bh = boxes.T
        h, w = image.shape[:2]
        xyxy = np.stack([(cx - bw / 2) * sx, (cy - bh / 2) * sy, (cx + bw / 2) * sx, (cy + bh / 2) * sy], axis=1)
        xyxy[:, [0, 2]] = np.clip(xyxy[:, [0, 2]], 0, w)
        xyxy[:, [1, 3]] = np.clip(xyxy[:, [1, 3]], 0, h)
        classes = [pairs[q][1] for q in best]
        order = batched_nms(xyxy, scores, classes, self.nms_iou)
        self.last_timings = {"detect": time.perf_counter() - t0}
        return [
            Detection(tuple(xyxy[i].tolist()), float(scores[i]), classes[i], pairs[best[i]][0])  # type: ignore
            for i in order
            if xyxy[i, 2] > xyxy[i, 0] and xyxy[i, 3] > xyxy[i, 1]
        ]
