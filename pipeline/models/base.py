"""Interfaces and value types shared by every perception backend.

The mapper talks to three small interfaces and never to a concrete backend:

- :class:`Detector` finds boxes for ``(prompt text, class name)`` pairs;
- :class:`Segmenter` turns a box into a pixel mask (one encoder run per image, one decoder run per box);
- :class:`DepthEstimator` returns a dense :class:`DepthMap` at the original image size.

Images are ``numpy`` arrays ``uint8`` HxWx3 in RGB order; pixel coordinates are ``(u, v)`` = (right,
down) with the origin at the top-left corner of the top-left pixel. Every backend failure raises a
:class:`ModelError` (or a subclass) with a message that names the model and what to do.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal, Mapping, Protocol, Sequence, runtime_checkable

import numpy as np

from pipeline.boxes import BoxError, clip_box, parse_box

Box = tuple[float, float, float, float]
"""``(x1, y1, x2, y2)`` in pixels of the original image, ``x1 <= x2`` and ``y1 <= y2``."""

Prompt = tuple[str, str]
"""``(prompt text, class name)``, e.g. ``("an office chair", "office_chair")``."""

DepthKind = Literal["metric", "relative", "inverse_relative"]

FETCH_COMMAND = "morphonavi models fetch"


class ModelError(RuntimeError):
    """A model could not be loaded or run, or was given bad input."""


class ModelMissingError(ModelError, FileNotFoundError):
    """Model files are not on disk; the message names the command that fetches them.

    ``names`` are the registry names of the missing models.
    """

    def __init__(self, names: str | Sequence[str], detail: str = "") -> None:
        self.names = (names,) if isinstance(names, str) else tuple(names)
        commands = "; ".join(f"{FETCH_COMMAND} {n}" for n in self.names)
        which = ", ".join(repr(n) for n in self.names)
        noun = "model" if len(self.names) == 1 else "models"
        text = f"{noun} {which} not found"
        if detail:
            text += f" ({detail})"
        self.message = f"{text}; fetch with: {commands}"
        super().__init__(self.message)

    def __str__(self) -> str:
        return self.message


@dataclass(frozen=True)
class Detection:
    """One detected object.

    Attributes:
        box: ``(x1, y1, x2, y2)`` [px] in the original image.
        score: Detector confidence in ``[0, 1]``.
        label: Class name (a catalog class) the detection was mapped to.
        prompt: The text prompt or backend label that fired (e.g. ``"an office chair"``, ``"tvmonitor"``).
    """

    box: Box
    score: float
    label: str
    prompt: str

    def __post_init__(self) -> None:
        box = tuple(float(v) for v in self.box)
        if len(box) != 4 or not all(math.isfinite(v) for v in box):
            raise ModelError(f"Detection.box: expected 4 finite numbers, got {self.box!r}")
        if box[2] < box[0] or box[3] < box[1]:
            raise ModelError(f"Detection.box: expected x1 <= x2 and y1 <= y2, got {box}")
        object.__setattr__(self, "box", box)
        object.__setattr__(self, "score", float(self.score))

    @property
    def width(self) -> float:
        """Box width [px]."""
        return self.box[2] - self.box[0]

    @property
    def height(self) -> float:
        """Box height [px]."""
        return self.box[3] - self.box[1]


@dataclass(frozen=True, eq=False)
class Mask:
    """A segmentation mask of one object.

    Attributes:
        values: ``bool`` HxW at the original image size, ``True`` on the object.
        predicted_iou: The segmenter's own estimate of the mask quality in ``[0, 1]``.
        box: The prompt box it was computed for [px].
    """

    values: np.ndarray
    predicted_iou: float
    box: Box = (0.0, 0.0, 0.0, 0.0)

    @property
    def area(self) -> int:
        """Number of object pixels."""
        return int(np.count_nonzero(self.values))


@dataclass(frozen=True, eq=False)
class DepthMap:
    """Dense depth of one image.

    Attributes:
        values: ``float32`` HxW at the ORIGINAL image size.
        kind: ``"metric"``: depth along the optical axis z [m]; ``"relative"``: depth up to an
            unknown scale; ``"inverse_relative"``: inverse depth (disparity) up to scale and shift,
            larger = nearer.
    """

    values: np.ndarray
    kind: DepthKind

    def __post_init__(self) -> None:
        if self.kind not in ("metric", "relative", "inverse_relative"):
            raise ModelError(f"DepthMap.kind: expected metric, relative or inverse_relative, got {self.kind!r}")
        if self.values.ndim != 2:
            raise ModelError(f"DepthMap.values: expected a HxW array, got shape {self.values.shape}")


@runtime_checkable
class Detector(Protocol):
    """Finds objects named by ``(prompt text, class name)`` pairs."""

    name: str
    score_threshold: float

    def detect(self, image_rgb: np.ndarray, prompts: Sequence[Prompt]) -> list[Detection]:
        """Detections of the prompts' classes in ``image_rgb`` (uint8 HxWx3 RGB), best first."""
        ...

    def vocabulary(self, prompts: Sequence[Prompt]) -> frozenset[str]:
        """The class names among ``prompts`` this detector can find at all."""
        ...


@runtime_checkable
class Segmenter(Protocol):
    """Box-promptable segmenter: :meth:`set_image` once, then :meth:`segment_box` per box."""

    name: str

    def set_image(self, image_rgb: np.ndarray) -> None:
        """Encode ``image_rgb`` (uint8 HxWx3 RGB); later boxes refer to this image."""
        ...

    def segment_box(self, box: Box) -> Mask:
        """Mask of the object inside ``box`` [px] of the image given to :meth:`set_image`."""
        ...

    def segment(self, image_rgb: np.ndarray, boxes: Sequence[Box]) -> list[Mask]:
        """One encoder run for the image, one decoder run per box."""
        ...


@runtime_checkable
class DepthEstimator(Protocol):
    """Monocular depth."""

    name: str
    kind: DepthKind

    def estimate(self, image_rgb: np.ndarray) -> DepthMap:
        """Depth of ``image_rgb`` (uint8 HxWx3 RGB) at its own size."""
        ...


def check_image(image: object, who: str = "model") -> np.ndarray:
    """``image`` as a C-contiguous uint8 HxWx3 array, or :class:`ModelError` saying what is wrong."""
    if not isinstance(image, np.ndarray):
        raise ModelError(f"{who}: expected a numpy uint8 HxWx3 RGB image, got {type(image).__name__}")
    if image.ndim != 3 or image.shape[2] != 3:
        raise ModelError(f"{who}: expected a HxWx3 RGB image, got shape {image.shape}")
    if image.dtype != np.uint8:
        raise ModelError(f"{who}: expected dtype uint8, got {image.dtype} (load images with pipeline.camera.image_io)")
    if image.shape[0] < 2 or image.shape[1] < 2:
        raise ModelError(f"{who}: image too small ({image.shape[1]}x{image.shape[0]} px)")
    return np.ascontiguousarray(image)


def check_box(box: Sequence[float], width: int, height: int, who: str = "model") -> Box:
    """``box`` as floats clipped to the image, or :class:`ModelError` when it is malformed or empty."""
    try:
        clipped = clip_box(parse_box(box, allow_empty=True), width, height)
    except BoxError as exc:
        raise ModelError(f"{who}: {exc}") from None
    if clipped is None:
        raise ModelError(f"{who}: box {box!r} does not overlap the {width}x{height} image")
    return clipped


def check_prompts(prompts: Sequence[Prompt], who: str = "detector") -> list[Prompt]:
    """``prompts`` as a list of ``(text, class name)`` string pairs, or :class:`ModelError`."""
    out: list[Prompt] = []
    if isinstance(prompts, (str, bytes)):
        raise ModelError(f"{who}: prompts must be a sequence of (text, class name) pairs, got a string")
    for i, p in enumerate(prompts):
        if not (isinstance(p, (tuple, list)) and len(p) == 2 and all(isinstance(s, str) for s in p)):
            raise ModelError(f"{who}: prompts[{i}] must be a (text, class name) pair of strings, got {p!r}")
        text, cls = p[0].strip(), p[1].strip()
        if not text or not cls:
            raise ModelError(f"{who}: prompts[{i}] has an empty text or class name: {p!r}")
        out.append((text, cls))
    return out


def closed_vocabulary(prompts: Sequence[Prompt], label_map: Mapping[str, str], who: str = "detector") -> frozenset[str]:
    """Class names of ``prompts`` that a closed-vocabulary detector can report: those some backend
    label maps to through ``label_map`` (backend label -> catalog class); :class:`ModelError` on bad prompts."""
    mapped = set(label_map.values())
    return frozenset(c for _, c in check_prompts(prompts, who) if c in mapped)
