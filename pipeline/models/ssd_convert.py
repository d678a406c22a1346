"""Turning MediaPipe's Open Images SSD (TFLite) into the ONNX graph :mod:`pipeline.models.ssd` runs.

Two steps, run by ``morphonavi models fetch oidv4_ssd``:

1. ``tflite2onnx`` (pip, the optional extra ``morphonavi[ssd-convert]``: only this one-time conversion
   needs it) converts the TFLite file to a *raw* ONNX
   graph: input ``normalized_input_image_tensor`` float32 ``[1, 3, 300, 300]`` (NCHW; fp16 weights
   become fp32), outputs ``raw_outputs/box_encodings`` ``[1, N, 4]`` (``ty, tx, th, tw`` per anchor)
   and ``raw_outputs/class_predictions`` ``[1, N, C]`` (logits). tflite2onnx lists initializers in a
   different order on each run, so they are sorted by name: the bytes are reproducible.
2. :func:`append_decode_head` adds the SSD box decoding (MediaPipe ``TfLiteTensorsToDetections``
   with exponential box sizes) and a sigmoid, so the graph outputs ``boxes`` ``[1, N, 4]``
   (``x0, y0, x1, y1`` normalised to the input image, 0..1) and ``scores`` ``[1, N, C]``.

Anchors (:func:`ssd_anchors`) follow MediaPipe's ``SsdAnchorsCalculator`` with the Objectron OIDv4
settings (:class:`AnchorOptions`): 6 layers of strides 16..512 on a 300 x 300 input (feature maps
19, 10, 5, 3, 2, 1), scales linear from 0.2 to 0.95, aspect ratios 1, 2, 0.5, 3, 1/3 plus one box
at the geometric mean of this and the next scale; the lowest layer reduced to 3 boxes (scale 0.1
at ratio 1, then ratios 2 and 0.5): 1917 anchors. Decoding, per anchor ``(cx, cy, w, h)``::

    x = tx / 10 * w + cx    y = ty / 10 * h + cy    bw = exp(tw / 5) * w    bh = exp(th / 5) * h
    boxes = (x - bw / 2, y - bh / 2, x + bw / 2, y + bh / 2)

:func:`decode_numpy` is the same in NumPy (the reference the tests hold the graph to), and
:func:`check_outputs` compares a converted graph's outputs on a fixed probe input with the
reference conversion's (used when the produced bytes differ from the pinned sha256, e.g. with
another ``onnx`` version).
"""

from __future__ import annotations

import logging
import math
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pipeline.models.base import ModelError

INPUT = "normalized_input_image_tensor"
RAW_BOXES = "raw_outputs/box_encodings"
RAW_SCORES = "raw_outputs/class_predictions"
TFLITE2ONNX_VERSION = "0.4.1"
INSTALL_HINT = (f"pip install 'morphonavi[ssd-convert]' (from a source checkout: pip install -e '.[ssd-convert]'), "
                f"which installs tflite2onnx=={TFLITE2ONNX_VERSION}; only this one-time conversion needs it")


@dataclass(frozen=True)
class AnchorOptions:
    """MediaPipe ``SsdAnchorsCalculatorOptions`` (defaults: the Objectron OIDv4 SSD's).

    Sizes are in pixels of the network input; scales are fractions of the input side.
    """

    input_size: tuple[int, int] = (300, 300)  # (height, width) [px]
    strides: tuple[int, ...] = (16, 32, 64, 128, 256, 512)
    min_scale: float = 0.2
    max_scale: float = 0.95
    aspect_ratios: tuple[float, ...] = (1.0, 2.0, 0.5, 3.0, 0.3333)
    interpolated_scale_aspect_ratio: float = 1.0
    reduce_boxes_in_lowest_layer: bool = True
    anchor_offset: float = 0.5


@dataclass(frozen=True)
class DecodeOptions:
    """MediaPipe ``TfLiteTensorsToDetectionsCalculatorOptions`` box scales (encodings ``ty, tx, th, tw``)."""

    y_scale: float = 10.0
    x_scale: float = 10.0
    h_scale: float = 5.0
    w_scale: float = 5.0


def _scale(opts: AnchorOptions, index: int) -> float:
    n = len(opts.strides)
    if n == 1:
        return (opts.min_scale + opts.max_scale) / 2
    return opts.min_scale + (opts.max_scale - opts.min_scale) * index / (n - 1)


def ssd_anchors(opts: AnchorOptions = AnchorOptions()) -> np.ndarray:
    """Anchors ``[N, 4]`` float32 as ``(cx, cy, w, h)``, normalised to the input (0..1).

    Order: layer by layer; within a layer row-major over the feature map (y then x), then the layer's
    boxes in order (the order of the model's outputs). Layers of equal stride share one feature map.
    """
    out: list[np.ndarray] = []
    n = len(opts.strides)
    layer = 0
    while layer < n:
        ratios: list[float] = []
        scales: list[float] = []
        last = layer
        while last < n and opts.strides[last] == opts.strides[layer]:
            scale = _scale(opts, last)
            if last == 0 and opts.reduce_boxes_in_lowest_layer:
                ratios += [1.0, 2.0, 0.5]
                scales += [0.1, scale, scale]
            else:
                ratios += list(opts.aspect_ratios)
                scales += [scale] * len(opts.aspect_ratios)
                if opts.interpolated_scale_aspect_ratio > 0:
                    following = 1.0 if last == n - 1 else _scale(opts, last + 1)
                    scales.append(math.sqrt(scale * following))
                    ratios.append(opts.interpolated_scale_aspect_ratio)
            last += 1
        r = np.sqrt(np.asarray(ratios, dtype=np.float64))
        w = np.asarray(scales) * r
        h = np.asarray(scales) / r
        stride = opts.strides[layer]
        fh = math.ceil(opts.input_size[0] / stride)
        fw = math.ceil(opts.input_size[1] / stride)
        cy, cx = np.meshgrid((np.arange(fh) + opts.anchor_offset) / fh, (np.arange(fw) + opts.anchor_offset) / fw,
                             indexing="ij")
        k = len(ratios)
        grid = np.stack([np.repeat(cx.ravel(), k), np.repeat(cy.ravel(), k),
                         np.tile(w, fh * fw), np.tile(h, fh * fw)], axis=1)
        out.append(grid)
        layer = last
    return np.concatenate(out).astype(np.float32)


def decode_numpy(box_encodings: np.ndarray, logits: np.ndarray, anchors: np.ndarray,
                 scales: DecodeOptions = DecodeOptions()) -> tuple[np.ndarray, np.ndarray]:
    """Reference decode: ``([1, N, 4] x0, y0, x1, y1 normalised, [1, N, C] sigmoid scores)``.

    Args:
        box_encodings: ``[1, N, 4]`` raw ``ty, tx, th, tw``.
        logits: ``[1, N, C]`` raw class logits.
        anchors: ``[N, 4]`` ``(cx, cy, w, h)`` from :func:`ssd_anchors`.
    """
    e = np.asarray(box_encodings, dtype=np.float64)
    a = np.asarray(anchors, dtype=np.float64)[None]
    cx = e[..., 1] / scales.x_scale * a[..., 2] + a[..., 0]
    cy = e[..., 0] / scales.y_scale * a[..., 3] + a[..., 1]
    w = np.exp(e[..., 3] / scales.w_scale) * a[..., 2]
    h = np.exp(e[..., 2] / scales.h_scale) * a[..., 3]
    boxes = np.stack([cx - w / 2, cy - h / 2, cx + w / 2, cy + h / 2], axis=-1)
    scores = 1.0 / (1.0 + np.exp(-np.asarray(logits, dtype=np.float64)))
    return boxes.astype(np.float32), scores.astype(np.float32)


def _dims(value_info) -> list[int | str]:  # noqa: ANN001 - onnx.ValueInfoProto
    return [d.dim_value if d.HasField("dim_value") else d.dim_param for d in value_info.type.tensor_type.shape.dim]


def canonicalise(model):  # noqa: ANN001, ANN201 - onnx.ModelProto in and out
    """Sort the graph's initializers and value infos by name (tflite2onnx's order changes per run)."""
    g = model.graph
    for field in ("initializer", "value_info"):
        items = sorted(getattr(g, field), key=lambda t: t.name)
        del getattr(g, field)[:]
        getattr(g, field).extend(items)
    return model


def append_decode_head(model, anchors: np.ndarray | None = None,  # noqa: ANN001, ANN201 - onnx.ModelProto
                       scales: DecodeOptions = DecodeOptions()):
    """The raw SSD graph with the box decoding and sigmoid appended (edits ``model`` in place).

    Args:
        model: ONNX model with outputs ``raw_outputs/box_encodings`` ``[1, N, 4]`` and
            ``raw_outputs/class_predictions`` ``[1, N, C]``.
        anchors: ``[N, 4]`` ``(cx, cy, w, h)``; default :func:`ssd_anchors`.

    Returns:
        The model, whose only outputs are now ``boxes`` ``[1, N, 4]`` and ``scores`` ``[1, N, C]``.

    Raises:
        ModelError: The raw outputs are missing or their shapes do not match the anchors.
    """
    from onnx import TensorProto, helper, numpy_helper

    anchors = ssd_anchors() if anchors is None else np.asarray(anchors, dtype=np.float32)
    g = model.graph
    outputs = {o.name: _dims(o) for o in g.output}
    for name in (RAW_BOXES, RAW_SCORES):
        if name not in outputs:
            raise ModelError(f"raw SSD graph: no output {name!r} (outputs: {', '.join(outputs) or 'none'})")
    n = len(anchors)
    if outputs[RAW_BOXES] != [1, n, 4]:
        raise ModelError(f"raw SSD graph: {RAW_BOXES} has shape {outputs[RAW_BOXES]}, expected [1, {n}, 4]")
    score_dims = outputs[RAW_SCORES]
    if len(score_dims) != 3 or score_dims[:2] != [1, n] or not isinstance(score_dims[2], int) or score_dims[2] < 2:
        raise ModelError(f"raw SSD graph: {RAW_SCORES} has shape {score_dims}, expected [1, {n}, C]")
    classes = int(score_dims[2])

    def const(name: str, value: np.ndarray) -> str:
        g.initializer.append(numpy_helper.from_array(value, f"decode/{name}"))
        return f"decode/{name}"

    # Encodings ty, tx, th, tw -> tx, ty, tw, th, so every later tensor is in x, y order.
    xy_order = const("xy_order", np.array([1, 0, 3, 2], dtype=np.int64))
    inv_scale = const("inv_scale", np.array([1 / scales.x_scale, 1 / scales.y_scale,
                                             1 / scales.w_scale, 1 / scales.h_scale], dtype=np.float32))
    centre = const("anchor_centre", anchors[None, :, 0:2].copy())  # [1, N, 2] cx, cy
    size = const("anchor_size", anchors[None, :, 2:4].copy())  # [1, N, 2] w, h
    half = const("half", np.array(0.5, dtype=np.float32))
    axis = const("axis2", np.array([2], dtype=np.int64))
    s0, s2, s4 = (const(f"at{i}", np.array([i], dtype=np.int64)) for i in (0, 2, 4))
    node = helper.make_node
    g.node.extend([
        node("Gather", [RAW_BOXES, xy_order], ["decode/txy_twh"], axis=2, name="decode/reorder"),
        node("Mul", ["decode/txy_twh", inv_scale], ["decode/scaled"], name="decode/scale"),
        node("Slice", ["decode/scaled", s0, s2, axis], ["decode/t_xy"], name="decode/slice_xy"),
        node("Slice", ["decode/scaled", s2, s4, axis], ["decode/t_wh"], name="decode/slice_wh"),
        node("Mul", ["decode/t_xy", size], ["decode/shift"], name="decode/shift"),
        node("Add", ["decode/shift", centre], ["decode/centre"], name="decode/centre"),
        node("Exp", ["decode/t_wh"], ["decode/growth"], name="decode/exp"),
        node("Mul", ["decode/growth", size], ["decode/wh"], name="decode/wh"),
        node("Mul", ["decode/wh", half], ["decode/half_wh"], name="decode/half_wh"),
        node("Sub", ["decode/centre", "decode/half_wh"], ["decode/min_xy"], name="decode/min_xy"),
        node("Add", ["decode/centre", "decode/half_wh"], ["decode/max_xy"], name="decode/max_xy"),
        node("Concat", ["decode/min_xy", "decode/max_xy"], ["boxes"], axis=2, name="decode/boxes"),
        node("Sigmoid", [RAW_SCORES], ["scores"], name="decode/sigmoid"),
    ])
    del g.output[:]
    g.output.extend([helper.make_tensor_value_info("boxes", TensorProto.FLOAT, [1, n, 4]),
                     helper.make_tensor_value_info("scores", TensorProto.FLOAT, [1, n, classes])])
    return model


def require_tflite2onnx():  # noqa: ANN201 - the tflite2onnx module
    """The ``tflite2onnx`` module; :class:`ModelError` naming how to install it when it is missing."""
    try:
        import tflite2onnx  # type: ignore[import-not-found]
    except ImportError:
        raise ModelError(f"converting the TFLite model needs tflite2onnx: {INSTALL_HINT}") from None
    return tflite2onnx


def convert_tflite(tflite: Path | str, target: Path | str) -> None:
    """TFLite SSD -> decoded ONNX at ``target`` (raw conversion with tflite2onnx, canonical order, head).

    Raises:
        ModelError: tflite2onnx is not installed (naming how to install it) or the conversion fails;
            ``target`` is then not written.
    """
    tflite2onnx = require_tflite2onnx()
    import onnx

    with tempfile.TemporaryDirectory(prefix="ssd_convert_") as tmp:
        raw = Path(tmp) / "raw.onnx"
        chatty = logging.getLogger("tflite2onnx")  # warns once per fp16 tensor ("not supported/tested yet")
        level = chatty.level
        chatty.setLevel(logging.ERROR)
        try:
            tflite2onnx.convert(str(tflite), str(raw))
        except Exception as exc:  # noqa: BLE001 - any converter failure becomes one message
            raise ModelError(f"tflite2onnx could not convert {Path(tflite).name}: {type(exc).__name__}: {exc}") from exc
        finally:
            chatty.setLevel(level)
        model = append_decode_head(canonicalise(onnx.load(str(raw))))
    try:
        onnx.checker.check_model(model)
    except onnx.checker.ValidationError as exc:
        raise ModelError(f"converted SSD graph is not valid ONNX: {exc}") from exc
    onnx.save(model, str(target))


# -- output check against the reference conversion ------------------------------------------------

PROBE_TOLERANCE = 2e-3
"""Largest accepted |difference| of a probe statistic, relative to max(1, |reference|)."""

REFERENCE_PROBE: dict[str, tuple[float, ...]] = {
    "boxes": (686.99885, 669.92078, 1231.6176, 1258.8776),
    "scores": (1901.3153, 8.4447687, 4.979523, 5.8911709, 26.732024, 6.8214311, 6.0985518, 3.3433735, 7.3537298,
               3.7837345, 5.074781, 5.4703997, 4.964305, 5.5827286, 4.8890531, 5.932511, 11.999341, 5.0399775,
               11.525998, 11.816972, 6.9806111, 7.1625986, 5.7540234, 13.557455),
    "boxes_weighted": (0.98792596, -2.6099142, -2.8812788, -2.7069184),
    "scores_weighted": (-1.5692789, -0.14434693, -0.037064041, -0.11184089, -0.17351902, -0.073701609, -0.064429034,
                        -0.053970239, -0.21692258, -0.01834609, -0.14874081, -0.091729853, -0.057972099, -0.064485257,
                        -0.039799043, -0.12795731, -0.038461205, -0.05527384, -0.35137922, -0.034856944, -0.11292206,
                        -0.11944719, -0.032221593, -0.33994439),
}
"""Statistics of the reference conversion's outputs on :func:`probe_input` (see :func:`probe_stats`): the
model converted here with tflite2onnx 0.4.1, onnx 1.23.2 and numpy 2.4.6, whose outputs equal those of
``../shared/models/oidv4_ssd/oidv4_ssd.onnx`` exactly (max abs difference 0 on this probe and on a random input)."""


def probe_input(size: tuple[int, int] = (300, 300)) -> np.ndarray:
    """A fixed ``[1, 3, H, W]`` float32 input in -0.9..0.9 (smooth stripes, different per channel)."""
    i = np.arange(size[0], dtype=np.float64)[:, None]
    j = np.arange(size[1], dtype=np.float64)[None, :]
    x = np.stack([0.9 * np.sin(0.061 * i + 0.043 * j + 1.3 * c) * np.cos(0.017 * (i - j) * (c + 1)) for c in range(3)])
    return x[None].astype(np.float32)


def probe_stats(boxes: np.ndarray, scores: np.ndarray) -> dict[str, tuple[float, ...]]:
    """Sums over anchors of each box coordinate and class score, plain and weighted by ``cos(0.37 n)``."""
    b = np.asarray(boxes, dtype=np.float64)[0]
    s = np.asarray(scores, dtype=np.float64)[0]
    weights = np.cos(0.37 * np.arange(len(b)))
    return {"boxes": tuple(b.sum(0).tolist()), "scores": tuple(s.sum(0).tolist()),
            "boxes_weighted": tuple((weights @ b).tolist()), "scores_weighted": tuple((weights @ s).tolist())}


def check_outputs(model_path: Path | str, reference: dict[str, tuple[float, ...]] | None = None) -> float:
    """Largest relative difference of the model's probe statistics from the reference conversion's.

    Raises:
        ModelError: The model does not run, or a statistic differs by more than :data:`PROBE_TOLERANCE`.
    """
    import onnxruntime as ort

    reference = REFERENCE_PROBE if reference is None else reference
    try:
        opts = ort.SessionOptions()
        opts.intra_op_num_threads = 1
        sess = ort.InferenceSession(str(model_path), opts, providers=["CPUExecutionProvider"])
        boxes, scores = sess.run(["boxes", "scores"], {INPUT: probe_input()})
    except Exception as exc:  # noqa: BLE001 - onnxruntime raises several unrelated types
        raise ModelError(f"{Path(model_path).name} does not run: {exc}") from exc
    got = probe_stats(boxes, scores)
    worst = 0.0
    for key, ref in reference.items():
        values = got.get(key, ())
        if len(values) != len(ref):
            raise ModelError(f"{Path(model_path).name}: probe output {key} has {len(values)} values, "
                             f"expected {len(ref)}")
        for k, (a, b) in enumerate(zip(values, ref)):
            diff = abs(a - b) / max(1.0, abs(b))
            worst = max(worst, diff)
            if not diff <= PROBE_TOLERANCE:
                raise ModelError(f"{Path(model_path).name}: outputs differ from the reference conversion "
                                 f"({key}[{k}] = {a:.6g}, reference {b:.6g})")
    return worst


__all__ = ["AnchorOptions", "DecodeOptions", "INSTALL_HINT", "REFERENCE_PROBE", "append_decode_head", "canonicalise",
           "check_outputs", "convert_tflite", "decode_numpy", "probe_input", "probe_stats", "require_tflite2onnx",
           "ssd_anchors"]
