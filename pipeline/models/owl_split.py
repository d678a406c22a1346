"""Split a one-graph OWL export at its text embeddings, so a vocabulary's text tower runs once.

The Hugging Face exports of OWL-ViT / OWLv2 are one graph that runs the CLIP text tower on every
image. In the model, the class head reads the query embeddings that the graph also outputs as
``text_embeds`` [1, Q, D] (plus ``input_ids`` for the mask of padded queries). That tensor is a
reshape of the normalised text embeddings [Q, D] whose target shape takes the batch size from the
image side (``Shape(image_embeds)``), so the cut is made below such shape-only nodes (Reshape,
Unsqueeze, Squeeze, Flatten, Identity), at the first tensor that depends on the text inputs only:

- text: ``(input_ids, attention_mask) -> cut tensor``, run once per vocabulary;
- image: ``(pixel_values, cut tensor[, input_ids]) -> (logits, pred_boxes)``, run per photo (it
  redoes the cheap reshape).

The cut is refused (:class:`SplitError`; the caller then runs the whole graph) when the file has
no ``text_embeds`` tensor, when no such tensor is found below it, when the image part would still
read ``attention_mask`` (its class head would depend on the text tower through another path), or
when onnxruntime cannot load a part.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pipeline.models.base import ModelError
from pipeline.models.session import IOSignature, TensorSpec, check_signature, session_from

TEXT_EMBEDS = "text_embeds"
TEXT_INPUTS = ("input_ids", "attention_mask")
IMAGE_OUTPUTS = ("logits", "pred_boxes")


class SplitError(ModelError):
    """The export cannot be cut at its text embeddings (the whole graph is used instead)."""


@dataclass
class OwlParts:
    """The two sessions of a split OWL export.

    Attributes:
        text: ``(input_ids, attention_mask) -> text_output``.
        image: ``(pixel_values, text_output[, input_ids]) -> (logits, pred_boxes)``.
        image_inputs: The image part's input names.
        signature: The whole export's I/O (as read from the file).
        text_output: The tensor the graph was cut at (``text_embeds`` or the tensor it is reshaped from).
    """

    text: Any
    image: Any
    image_inputs: tuple[str, ...]
    signature: IOSignature
    text_output: str = TEXT_EMBEDS


def _signature(graph: Any) -> IOSignature:
    def spec(v: Any) -> TensorSpec:
        dims = tuple(d.dim_value if d.HasField("dim_value") else None for d in v.type.tensor_type.shape.dim)
        return TensorSpec(v.name, len(dims), dims)

    inits = {t.name for t in graph.initializer}
    return IOSignature(tuple(spec(v) for v in graph.input if v.name not in inits),
                       tuple(spec(v) for v in graph.output))


SHAPE_ONLY_OPS = frozenset({"Reshape", "Unsqueeze", "Squeeze", "Flatten", "Identity"})
"""Ops the cut may pass below: they only rearrange their first input (other inputs give shapes)."""


def _graph_inputs_read(graph: Any, outputs: tuple[str, ...], stop: set[str]) -> set[str]:
    """Which of the graph's inputs (initializers excluded) the ``outputs`` depend on when the tensors
    in ``stop`` are given (those count as read when reached)."""
    producer = {name: node for node in graph.node for name in node.output if name}
    inputs = {v.name for v in graph.input} - {t.name for t in graph.initializer}
    seen: set[str] = set()
    read: set[str] = set()
    todo = list(outputs)
    while todo:
        name = todo.pop()
        if name in seen:
            continue
        seen.add(name)
        if name in stop or name in inputs:
            read.add(name)
            continue
        node = producer.get(name)
        if node is not None:
            todo.extend(i for i in node.input if i)
    return read


def split_owl(model_path: Path | str, signature: IOSignature, what: str, threads: int | None = None) -> OwlParts:
    """Cut an OWL export at ``text_embeds`` and open both parts with onnxruntime.

    Args:
        model_path: The export's ``model.onnx``.
        signature: The I/O the whole export must have (checked first).
        what: Names the model in messages.
        threads: onnxruntime intra-op threads.

    Raises:
        SplitError: The file cannot be read with ``onnx``, or the cut is not possible.
        ModelError: The export's signature is wrong.
    """
    try:
        import onnx
        from onnx.utils import Extractor

        model = onnx.load(str(model_path))
    except Exception as exc:
        raise SplitError(f"{what}: cannot read the graph to split it: {exc}") from exc
    graph = model.graph
    actual = _signature(graph)
    check_signature(actual, signature, what)
    has_embeds = any(TEXT_EMBEDS in n.output for n in graph.node) or any(v.name == TEXT_EMBEDS for v in graph.output)
    if not has_embeds:
        raise SplitError(f"{what}: the graph has no {TEXT_EMBEDS!r} tensor to cut at")
    cut = _cut_tensor(graph, what)
    read = _graph_inputs_read(graph, IMAGE_OUTPUTS, {cut})
    if cut not in read or "attention_mask" in read:
        raise SplitError(f"{what}: the class head does not read the text tower only through {cut!r}")
    image_inputs = tuple(n for n in ("pixel_values", cut, "input_ids") if n in read)
    known = {v.name for v in list(graph.value_info) + list(graph.input) + list(graph.output)}
    if cut not in known:  # an intermediate tensor without a recorded type: give it the embeddings' type
        import onnx.helper

        out = next((v for v in graph.output if v.name == TEXT_EMBEDS), None)
        elem = out.type.tensor_type.elem_type if out is not None else onnx.TensorProto.FLOAT
        graph.value_info.append(onnx.helper.make_tensor_value_info(cut, elem, None))
    try:
        extractor = Extractor(model)
        text_model = extractor.extract_model(list(TEXT_INPUTS), [cut])
        image_model = extractor.extract_model(list(image_inputs), list(IMAGE_OUTPUTS))
        text_bytes, image_bytes = text_model.SerializeToString(), image_model.SerializeToString()
    except Exception as exc:
        raise SplitError(f"{what}: cutting the graph failed: {exc}") from exc
    del model, extractor, text_model, image_model
    try:
        text = session_from(text_bytes, f"{what} (text part)", threads)
        image = session_from(image_bytes, f"{what} (image part)", threads)
    except ModelError as exc:
        raise SplitError(f"{what}: a part of the cut graph does not load: {exc}") from exc
    return OwlParts(text=text, image=image, image_inputs=image_inputs, signature=actual, text_output=cut)


def _cut_tensor(graph: Any, what: str) -> str:
    """``text_embeds``, or the tensor below its shape-only producers that reads the text inputs only."""
    producer = {name: node for node in graph.node for name in node.output if name}
    cut = TEXT_EMBEDS
    for _ in range(16):
        if _graph_inputs_read(graph, (cut,), set()) <= set(TEXT_INPUTS):
            return cut
        node = producer.get(cut)
        if node is None or node.op_type not in SHAPE_ONLY_OPS or not node.input:
            break
        cut = node.input[0]
    raise SplitError(f"{what}: the text embeddings depend on the image (no text-only tensor below {TEXT_EMBEDS!r})")
