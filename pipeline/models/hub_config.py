"""Reading the JSON configs that ship beside hub ONNX exports (``config.json``,
``preprocessor_config.json``, ``tokenizer_config.json``)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from pipeline.models.base import ModelError


def read_json(path: Path, required: bool = False) -> dict[str, Any]:
    """The JSON object in ``path``; ``{}`` when it is absent and not ``required``.

    Raises:
        ModelError: The file is required but absent, or is not a JSON object.
    """
    if not path.is_file():
        if required:
            raise ModelError(f"missing config file {path}")
        return {}
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ModelError(f"{path}: not a readable JSON file: {exc}") from exc
    if not isinstance(data, dict):
        raise ModelError(f"{path}: expected a JSON object, got {type(data).__name__}")
    return data


def parse_size(value: Any, where: str) -> tuple[int, int]:
    """A hub ``size`` entry as ``(height, width)`` [px].

    Accepts ``518``, ``[768, 768]``, ``{"height": 960, "width": 960}`` and ``{"shortest_edge": 224}``.
    """
    try:
        if isinstance(value, bool):
            raise TypeError
        if isinstance(value, (int, float)):
            h = w = int(value)
        elif isinstance(value, (list, tuple)) and len(value) == 2:
            h, w = int(value[0]), int(value[1])
        elif isinstance(value, dict) and "height" in value and "width" in value:
            h, w = int(value["height"]), int(value["width"])
        elif isinstance(value, dict) and "shortest_edge" in value:
            h = w = int(value["shortest_edge"])
        else:
            raise TypeError
    except (TypeError, ValueError):
        raise ModelError(f"{where}: cannot read an image size from {value!r}") from None
    if h <= 0 or w <= 0:
        raise ModelError(f"{where}: image size must be positive, got {value!r}")
    return h, w


def parse_triplet(value: Any, default: tuple[float, float, float], where: str) -> tuple[float, float, float]:
    """A 3-vector (mean / std) from a config, or ``default`` when absent."""
    if value is None:
        return default
    try:
        a, b, c = (float(v) for v in value)
    except (TypeError, ValueError):
        raise ModelError(f"{where}: expected 3 numbers, got {value!r}") from None
    return (a, b, c)
