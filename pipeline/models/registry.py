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

Model sets: ``"offline"`` (the default: YOLOX-Nano, MobileSAM, FastDepth: small files that run anywhere),
``"hub"`` (hub downloads: OWLv2, Depth Anything V2 Small, MobileSAM; its old name ``"default"`` is still
accepted) and ``"cloud"`` (Grounding DINO
1.5 Pro through the cloud API, with MobileSAM and Depth Anything V2 Small).

The table of models and sets is :mod:`pipeline.models.known_models` (its names are re-exported
here). These functions are what ``morphonavi models list|fetch|verify`` call.
"""

from __future__ import annotations

import hashlib
import json
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Literal, Mapping, Sequence

from pipeline.models.base import FETCH_COMMAND, ModelError
from pipeline.models.cloud import API_KEY_ENV
from pipeline.models.known_models import (  # noqa: F401 - re-exported: the registry's public names
    CONVERTERS,
    MODEL_SET_ALIASES,
    MODEL_SETS,
    MODELS,
    ModelFile,
    ModelSpec,
    Role,
    converter,
    model_set_name,
    require_converter,
)

MODELS_ENV = "MORPHONAVI_MODELS"
CHECKSUMS_FILE = "checksums.json"
"""Per-model file recording the sha256 of downloads that have no published checksum."""


def get_spec(name: str) -> ModelSpec:
    """The spec called ``name``; :class:`ModelError` listing the known names otherwise."""
    spec = MODELS.get(name)
    if spec is None:
        raise ModelError(f"unknown model {name!r}; known models: {', '.join(MODELS)}")
    return spec


def set_members(set_name: str) -> tuple[str, str, str]:
    """``(detector, segmenter, depth)`` model names of a set; :class:`ModelError` for unknown sets."""
    members = MODEL_SETS.get(model_set_name(set_name))
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

    A converted file's record comes first: :func:`pipeline.models.fetch.fetch` records the bytes it
    installs (the reference conversion's, or another toolchain's whose outputs matched them)."""
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
    size_issue: str = ""
    """Present files whose size is not the registry's (``""`` when none), e.g. a truncated download."""

    def as_row(self) -> dict[str, str]:
        """Printable columns; ``size`` is the files' on disk when present, else the registry's."""
        size = "?" if self.size is None else _size_text(self.size)
        if self.status == "missing":
            where = f"run: {FETCH_COMMAND} {self.name}"
        elif self.status == "api":
            where = self.note
        else:
            where = str(self.location)
        if self.size_issue:
            size += " (size differs!)"
            where += f"; {self.size_issue}; run: morphonavi models verify {self.name}"
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
        size, issue = (spec.size, "") if folder is None else _sizes_on_disk(spec, folder)
        rows.append(
            ModelStatus(
                spec.name, spec.role, spec.backend, sets, "present" if folder else "missing", folder, size,
                spec.licence, spec.description, () if folder else tuple(missing_files(spec, primary)),
                size_issue=issue,
            )
        )
    return rows


CONVERTED_SIZE_TOLERANCE = 0.01
"""A converted file's size may differ from the reference conversion's by this fraction (another onnx
version serialises a few hundred bytes differently: the ``../shared/models`` SSD has 492 bytes fewer)."""


def _size_text(size: int) -> str:
    return f"{size / 1e6:.1f} MB" if size >= 1e5 else f"{size} B"


def _sizes_on_disk(spec: ModelSpec, folder: Path) -> tuple[int, str]:
    """``(total bytes on disk, size mismatches)`` of a present model's files, checked against the sizes
    the registry knows (exactly; a converted file within :data:`CONVERTED_SIZE_TOLERANCE`)."""
    total, issues = 0, []
    for f in spec.files:
        got = (folder / f.path).stat().st_size
        total += got
        if f.size is None:
            continue
        off = abs(got - f.size) > (CONVERTED_SIZE_TOLERANCE * f.size if f.convert else 0)
        if off:
            issues.append(f"{f.path} has {got} bytes, expected {f.size}")
    return total, ", ".join(issues)


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
            if check_hashes and f.convert:
                problem = _converted_problem(name, f, folder, messages)
                if problem:
                    ok = False
                    messages.append(problem)
            elif check_hashes:
                sha, origin = expected_sha256(spec, f, folder)
                if sha is not None:
                    actual = sha256_file(path)
                    if actual != sha:
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


def _converted_problem(name: str, f: ModelFile, folder: Path, notes: list[str]) -> str:
    """What is wrong with a converted file (``""`` when nothing): the pinned sha256 (the reference
    conversion) or the one recorded when it was fetched must match; a file without a record (first use,
    a copy made elsewhere) is checked by its outputs on a fixed probe (a note goes to ``notes``)."""
    path = folder / f.path
    actual = sha256_file(path)
    recorded = recorded_checksums(folder).get(f.path)
    if actual == f.sha256 or (recorded is not None and actual == recorded):
        return ""
    if recorded is not None:
        return (f"{f.path}: modified since it was fetched (sha256 {actual}, recorded {recorded} in "
                f"{folder / CHECKSUMS_FILE}); run: {FETCH_COMMAND} {name}")
    try:
        worst = converter(f.convert or "")[1](path)
    except ModelError as exc:
        return f"{f.path}: sha256 {actual} differs from the reference conversion's {f.sha256}; {exc}"
    notes.append(f"{f.path}: no recorded sha256 (first use): sha256 differs from the reference conversion's; "
                 f"outputs match it (largest relative difference {worst:.1e}); {FETCH_COMMAND} {name} records it")
    return ""
