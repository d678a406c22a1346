"""Split a one-graph OWL export at its text embeddings, so a vocabulary's text tower runs once.

The Hugging Face exports of OWL-ViT / OWLv2 are one graph that runs the CLIP text tower on every
image. In the model, the class head reads the query embeddings that the graph also outputs as
``text_embeds`` [1, Q, D] (plus ``input_ids`` for the mask of padded queries). Cutting the graph
at that tensor gives two graphs:

- text: ``(input_ids, attention_mask) -> text_embeds``, run once per vocabulary;
- image: ``(pixel_values, text_embeds[, input_ids]) -> (logits, pred_boxes)``, run per photo.

The cut is refused (the caller then runs the whole graph) when the file has no ``text_embeds``
tensor or when the image part would still read ``attention_mask`` (its class head would then
depend on the text tower through another path).
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
        text: ``(input_ids, attention_mask) -> text_embeds``.
        image: ``(pixel_values, text_embeds[, input_ids]) -> (logits, pred_boxes)``.
        image_inputs: The image part's input names.
        signature: The whole export's I/O (as read from the file).
    """

    text: Any
    image: Any
    image_inputs: tuple[str, ...]
    signature: IOSignature


def _signature(graph: Any) -> IOSignature:
    def spec(v: Any) -> TensorSpec:
        dims = tuple(d.dim_value if d.HasField("dim_value") else None for d in v.type.tensor_type.shape.dim)
        return TensorSpec(v.name, len(dims), dims)

    inits = {t.name for t in graph.initializer}
    return IOSignature(tuple(spec(v) for v in graph.input if v.name not in inits),
                       tuple(spec(v) for v in graph.output))


def _graph_inputs_read(graph: Any, outputs: tuple[str, ...], stop: set[str]) -> set[str]:
    """Which of the graph's inputs the ``outputs`` depend on when the tensors in ``stop`` are given."""
    producer = {name: node for node in graph.node for name in node.output if name}
    inputs = {v.name for v in graph.input}
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
    read = _graph_inputs_read(graph, IMAGE_OUTPUTS, {TEXT_EMBEDS})
    if TEXT_EMBEDS not in read or "attention_mask" in read:
        raise SplitError(f"{what}: the class head does not read the text tower only through {TEXT_EMBEDS!r}")
    image_inputs = tuple(n for n in ("pixel_values", TEXT_EMBEDS, "input_ids") if n in read)
    try:
        extractor = Extractor(model)
        text_model = extractor.extract_model(list(TEXT_INPUTS), [TEXT_EMBEDS])
        image_model = extractor.extract_model(list(image_inputs), list(IMAGE_OUTPUTS))
        text_bytes, image_bytes = text_model.SerializeToString(), image_model.SerializeToString()
    except Exception as exc:
        raise SplitError(f"{what}: cutting the graph failed: {exc}") from exc
    del model, extractor, text_model, image_model
    return OwlParts(
        text=session_from(text_bytes, f"{what} (text part)", threads),
        image=session_from(image_bytes, f"{what} (image part)", threads),
        image_inputs=image_inputs,
        signature=actual,
    )
