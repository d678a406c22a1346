"""Perception model backends behind small interfaces, and the model registry / fetcher.

Use :func:`load_models` to get a :class:`ModelBundle` (detector, segmenter, depth estimator) of a
model set; backends live in one module per family (``yolox``, ``owl``, ``cloud``, ``sam``, ``depth``).
"""

from pipeline.models.base import (
    Box,
    DepthEstimator,
    DepthKind,
    DepthMap,
    Detection,
    Detector,
    Mask,
    ModelError,
    ModelMissingError,
    Prompt,
    Segmenter,
)
from pipeline.models.loader import ModelBundle, load_model, load_models

__all__ = [
    "Box",
    "DepthEstimator",
    "DepthKind",
    "DepthMap",
    "Detection",
    "Detector",
    "Mask",
    "ModelBundle",
    "ModelError",
    "ModelMissingError",
    "Prompt",
    "Segmenter",
    "load_model",
    "load_models",
]
