"""Tiny ONNX graphs with the real I/O signatures of the model exports, built with ``onnx.helper``.

Each graph computes something simple but checkable, so tests exercise the backends' real pre- and
post-processing without any downloaded weights:

- OWL: text embedding = sum of per-token colour vectors; patch embedding = mean normalised colour
  of each patch; ``logits = 2 * dot - 4`` (-1e6 for padded queries, as the real class head masks
  queries whose first token is 0); ``pred_boxes`` = the patch cells. As in the real export, the
  class head reads the ``text_embeds`` output (or, with ``head_reads_embeds=False``, a tensor
  upstream of it, so the graph cannot be cut at the text embeddings); with ``batch_from_image``
  ``text_embeds`` is reshaped with the batch size read from the image side, as in the real export.
- SAM: the encoder average-pools the image; the decoder's mask logit is the signed distance to
  the prompt box, computed in the ORIGINAL frame from ``orig_im_size`` and the resized-frame box,
  and is negative everywhere unless the point labels are (2, 3, -1).
- Depth Anything / FastDepth: depth = mean of the input channels.
- YOLOX: a fixed raw output given by the test.
"""

from __future__ import annotations

from pathlib import Path
from typing import Sequence

import numpy as np
import onnx
from onnx import TensorProto, helper, numpy_helper

OPSET = 17
IR_VERSION = 8


def _save(nodes, name, inputs, outputs, initializers, path: Path) -> Path:
    graph = helper.make_graph(nodes, name, inputs, outputs, initializer=initializers)
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", OPSET)])
    model.ir_version = IR_VERSION
    onnx.checker.check_model(model)
    path.parent.mkdir(parents=True, exist_ok=True)
    onnx.save(model, str(path))
    return path


def _const(name: str, value) -> onnx.TensorProto:
    return numpy_helper.from_array(np.asarray(value), name)


def _f(name: str, shape: Sequence[int | str | None]) -> onnx.ValueInfoProto:
    return helper.make_tensor_value_info(name, TensorProto.FLOAT, list(shape))


def _i64(name: str, shape: Sequence[int | str | None]) -> onnx.ValueInfoProto:
    return helper.make_tensor_value_info(name, TensorProto.INT64, list(shape))


# -- OWL ------------------------------------------------------------------------------------------

COLOR_WORDS = {"red": (1.0, -1.0, -1.0), "green": (-1.0, 1.0, -1.0), "blue": (-1.0, -1.0, 1.0)}
SPECIAL = ["!", "<|startoftext|>", "<|endoftext|>", "[UNK]"]


def owl_vocab(extra_words: Sequence[str] = ("a", "the", "thing", "box", "chair", "big", "small")) -> dict[str, int]:
    """Word -> id of the test tokenizer: specials, colour words, then ``extra_words``."""
    words = SPECIAL + list(COLOR_WORDS) + [w for w in extra_words if w not in COLOR_WORDS]
    return {w: i for i, w in enumerate(words)}


def write_tokenizer(path: Path, vocab: dict[str, int] | None = None) -> Path:
    """A CLIP-like ``tokenizer.json`` (WordLevel, whitespace split, start/end tokens) at ``path``."""
    from tokenizers import Tokenizer, models, pre_tokenizers, processors

    vocab = vocab or owl_vocab()
    tok = Tokenizer(models.WordLevel(vocab, unk_token="[UNK]"))
    tok.pre_tokenizer = pre_tokenizers.Whitespace()
    tok.post_processor = processors.TemplateProcessing(
        single="<|startoftext|> $A <|endoftext|>",
        special_tokens=[("<|startoftext|>", vocab["<|startoftext|>"]), ("<|endoftext|>", vocab["<|endoftext|>"])],
    )
    path.parent.mkdir(parents=True, exist_ok=True)
    tok.save(str(path))
    return path


def owl_model(path: Path, image_size: int = 32, patch: int = 8, vocab: dict[str, int] | None = None,
              head_reads_embeds: bool = True, batch_from_image: bool = False) -> Path:
    """OWL export signature: (input_ids, pixel_values, attention_mask) -> (logits, pred_boxes,
    text_embeds, image_embeds); colour words match patches of that colour."""
    vocab = vocab or owl_vocab()
    table = np.zeros((len(vocab), 3), dtype=np.float32)
    for word, vec in COLOR_WORDS.items():
        table[vocab[word]] = vec
    g = image_size // patch
    cells = [((j + 0.5) / g, (i + 0.5) / g, 1.0 / g, 1.0 / g) for i in range(g) for j in range(g)]
    boxes = np.asarray(cells, dtype=np.float32)[None]
    nodes = [
        helper.make_node("Gather", ["table", "input_ids"], ["tok_emb"]),  # [Q, L, 3]
        helper.make_node("Cast", ["attention_mask"], ["mask_f"], to=TensorProto.FLOAT),
        helper.make_node("Unsqueeze", ["mask_f", "ax2"], ["mask_3"]),
        helper.make_node("Mul", ["tok_emb", "mask_3"], ["tok_masked"]),
        helper.make_node("ReduceSum", ["tok_masked", "ax1"], ["text_vec"], keepdims=0),  # [Q, 3]
        helper.make_node(
            "AveragePool", ["pixel_values"], ["pooled"], kernel_shape=[patch, patch], strides=[patch, patch]
        ),
        helper.make_node("Transpose", ["pooled"], ["image_embeds"], perm=[0, 2, 3, 1]),  # [1, g, g, 3]
        *([  # as the real export: text_embeds = reshape(q, (batch of the image, -1, D))
            helper.make_node("Shape", ["image_embeds"], ["img_shape"]),
            helper.make_node("Gather", ["img_shape", "zero"], ["batch"], axis=0),
            helper.make_node("Unsqueeze", ["batch", "ax0"], ["batch_1"]),
            helper.make_node("Concat", ["batch_1", "minus_one", "dim3"], ["embeds_shape"], axis=0),
            helper.make_node("Reshape", ["text_vec", "embeds_shape"], ["text_embeds"]),
        ] if batch_from_image else [helper.make_node("Unsqueeze", ["text_vec", "ax0"], ["text_embeds"])]),
        helper.make_node("Reshape", ["image_embeds", "patch_shape"], ["patches"]),  # [1, P, 3]
        (helper.make_node("Transpose", ["text_embeds"], ["text_t"], perm=[0, 2, 1]) if head_reads_embeds  # [1, 3, Q]
         else helper.make_node("Transpose", ["text_vec"], ["text_t"], perm=[1, 0])),  # [3, Q]
        helper.make_node("MatMul", ["patches", "text_t"], ["dot"]),  # [1, P, Q]
        helper.make_node("Mul", ["dot", "two"], ["dot2"]),
        helper.make_node("Sub", ["dot2", "four"], ["raw_logits"]),
        helper.make_node("Gather", ["input_ids", "zero"], ["first_tok"], axis=1),  # [Q]
        helper.make_node("Greater", ["first_tok", "zero"], ["query_mask"]),
        helper.make_node("Where", ["query_mask", "raw_logits", "masked"], ["logits"]),
        helper.make_node("Identity", ["boxes_const"], ["pred_boxes"]),
    ]
    inits = [
        _const("table", table),
        _const("ax0", np.array([0], np.int64)),
        _const("ax1", np.array([1], np.int64)),
        _const("ax2", np.array([2], np.int64)),
        _const("patch_shape", np.array([1, g * g, 3], np.int64)),
        _const("two", np.float32(2.0)),
        _const("four", np.float32(4.0)),
        _const("zero", np.int64(0)),
        _const("minus_one", np.array([-1], np.int64)),
        _const("dim3", np.array([3], np.int64)),
        _const("masked", np.float32(-1e6)),
        _const("boxes_const", boxes),
    ]
    return _save(
        nodes,
        "tiny_owl",
        [
            _i64("input_ids", ["q", "l"]),
            _f("pixel_values", [1, 3, image_size, image_size]),
            _i64("attention_mask", ["q", "l"]),
        ],
        [_f("logits", [1, g * g, "q"]), _f("pred_boxes", [1, g * g, 4]), _f("text_embeds", [1, "q", 3]),
         _f("image_embeds", [1, g, g, 3])],
        inits,
        path,
    )


# -- SAM ------------------------------------------------------------------------------------------


def sam_encoder(path: Path, size: int = 64, pool: int = 8) -> Path:
    """Encoder signature: ``input`` [B, 3, S, S] -> ``output`` [B, 3, S/pool, S/pool]."""
    nodes = [helper.make_node("AveragePool", ["input"], ["output"], kernel_shape=[pool, pool], strides=[pool, pool])]
    e = size // pool
    return _save(nodes, "tiny_sam_encoder", [_f("input", ["batch_size", 3, size, size])],
                 [_f("output", ["batch_size", 3, e, e])], [], path)


def sam_decoder(path: Path, encoder_size: int = 64, embed: int = 8, iou: float = 0.875) -> Path:
    """SAM decoder signature; mask logit = signed distance [orig px] to the prompt box."""
    nodes = [
        helper.make_node("Gather", ["orig_im_size", "i0"], ["H"]),
        helper.make_node("Gather", ["orig_im_size", "i1"], ["W"]),
        helper.make_node("Max", ["H", "W"], ["long"]),
        helper.make_node("Div", ["S", "long"], ["scale"]),
        helper.make_node("Range", ["zero", "W", "one"], ["xs0"]),
        helper.make_node("Range", ["zero", "H", "one"], ["ys0"]),
        helper.make_node("Add", ["xs0", "half"], ["xs1"]),
        helper.make_node("Add", ["ys0", "half"], ["ys1"]),
        helper.make_node("Mul", ["xs1", "scale"], ["xs"]),  # pixel centres in the resized frame
        helper.make_node("Mul", ["ys1", "scale"], ["ys"]),
        helper.make_node("Reshape", ["point_coords", "flat"], ["pc"]),
        helper.make_node("Gather", ["pc", "i0"], ["x1"]),
        helper.make_node("Gather", ["pc", "i1"], ["y1"]),
        helper.make_node("Gather", ["pc", "i2"], ["x2"]),
        helper.make_node("Gather", ["pc", "i3"], ["y2"]),
        helper.make_node("Sub", ["xs", "x1"], ["dx1"]),
        helper.make_node("Sub", ["x2", "xs"], ["dx2"]),
        helper.make_node("Min", ["dx1", "dx2"], ["dx"]),
        helper.make_node("Sub", ["ys", "y1"], ["dy1"]),
        helper.make_node("Sub", ["y2", "ys"], ["dy2"]),
        helper.make_node("Min", ["dy1", "dy2"], ["dy"]),
        helper.make_node("Unsqueeze", ["dy", "ax1"], ["dy_col"]),  # [H, 1]
        helper.make_node("Min", ["dx", "dy_col"], ["dist"]),  # [H, W] in resized px
        helper.make_node("Div", ["dist", "scale"], ["dist_orig"]),
        # Gate: 1 when the labels are exactly (2, 3, -1), else 0 -> mask everywhere negative.
        helper.make_node("Reshape", ["point_labels", "flat"], ["pl"]),
        helper.make_node("Equal", ["pl", "want_labels"], ["eq"]),
        helper.make_node("Cast", ["eq"], ["eq_f"], to=TensorProto.FLOAT),
        helper.make_node("ReduceMin", ["eq_f"], ["gate"], keepdims=0),
        helper.make_node("Mul", ["dist_orig", "gate"], ["gated"]),
        helper.make_node("Sub", ["one", "gate"], ["not_gate"]),
        helper.make_node("Mul", ["not_gate", "big"], ["penalty"]),
        helper.make_node("Sub", ["gated", "penalty"], ["mask2d"]),
        helper.make_node("Unsqueeze", ["mask2d", "ax01"], ["masks"]),
        helper.make_node("Identity", ["iou_const"], ["iou_predictions"]),
        helper.make_node("Identity", ["low_res_const"], ["low_res_masks"]),
    ]
    inits = [
        _const("i0", np.int64(0)), _const("i1", np.int64(1)), _const("i2", np.int64(2)), _const("i3", np.int64(3)),
        _const("S", np.float32(encoder_size)), _const("zero", np.float32(0.0)), _const("one", np.float32(1.0)),
        _const("half", np.float32(0.5)), _const("big", np.float32(1000.0)),
        _const("flat", np.array([-1], np.int64)), _const("ax1", np.array([1], np.int64)),
        _const("ax01", np.array([0, 1], np.int64)),
        _const("want_labels", np.array([2.0, 3.0, -1.0], np.float32)),
        _const("iou_const", np.array([[iou]], np.float32)),
        _const("low_res_const", np.zeros((1, 1, 16, 16), np.float32)),
    ]
    inputs = [
        _f("image_embeddings", [1, 3, embed, embed]),
        _f("point_coords", [1, "num_points", 2]),
        _f("point_labels", [1, "num_points"]),
        _f("mask_input", [1, 1, 16, 16]),
        _f("has_mask_input", [1]),
        _f("orig_im_size", [2]),
    ]
    outputs = [_f("masks", ["b", 1, "h", "w"]), _f("iou_predictions", [1, 1]), _f("low_res_masks", [1, 1, 16, 16])]
    return _save(nodes, "tiny_sam_decoder", inputs, outputs, inits, path)


# -- depth ----------------------------------------------------------------------------------------


def depth_anything_model(path: Path) -> Path:
    """``pixel_values`` [1, 3, h, w] -> ``predicted_depth`` [1, h, w] = channel mean."""
    nodes = [helper.make_node("ReduceMean", ["pixel_values"], ["predicted_depth"], axes=[1], keepdims=0)]
    return _save(nodes, "tiny_depth_anything", [_f("pixel_values", ["b", 3, "h", "w"])],
                 [_f("predicted_depth", ["b", "h", "w"])], [], path)


def fastdepth_model(path: Path, size: int = 224) -> Path:
    """``0`` [1, 3, 224, 224] -> ``350`` [1, 1, 224, 224] = 10 * channel mean."""
    nodes = [
        helper.make_node("ReduceMean", ["0"], ["m"], axes=[1], keepdims=1),
        helper.make_node("Mul", ["m", "ten"], ["350"]),
    ]
    return _save(nodes, "tiny_fastdepth", [_f("0", [1, 3, size, size])], [_f("350", [1, 1, size, size])],
                 [_const("ten", np.float32(10.0))], path)


# -- YOLOX ----------------------------------------------------------------------------------------


def yolox_model(path: Path, raw: np.ndarray, input_size: int = 64) -> Path:
    """``images`` [1, 3, S, S] -> ``output`` = the fixed ``raw`` [1, A, 5 + C] (input consumed as 0 *)."""
    raw = np.asarray(raw, dtype=np.float32)
    nodes = [
        helper.make_node("ReduceMean", ["images"], ["mean"], keepdims=0),
        helper.make_node("Mul", ["mean", "zero"], ["nothing"]),
        helper.make_node("Add", ["raw", "nothing"], ["output"]),
    ]
    return _save(nodes, "tiny_yolox", [_f("images", [1, 3, input_size, input_size])],
                 [_f("output", list(raw.shape))], [_const("raw", raw), _const("zero", np.float32(0.0))], path)


def wrong_signature_model(path: Path, input_name: str = "x", output_name: str = "y") -> Path:
    """A valid ONNX file with the wrong I/O names (rank 4 in, rank 4 out)."""
    nodes = [helper.make_node("Identity", [input_name], [output_name])]
    return _save(nodes, "wrong", [_f(input_name, [1, 3, 8, 8])], [_f(output_name, [1, 3, 8, 8])], [], path)
