"""The object catalog: the classes the mapper looks for, their prompts, sizes and proxy models.

The catalog is a TOML file (the packaged one is ``assets/catalog.toml``; its header documents the
format). Each class has detector prompts, label synonyms, a typical size ``(w, h, l)`` [m] (``h``
vertical, ``l`` along the object's heading, ``w`` the other horizontal extent; ``None`` when
unknown, which selects the depth-only distance path), a proxy model file and a display colour.

Labels from any source (open-vocabulary prompts, COCO / VOC / SUN RGB-D / KITTI names) resolve to
a class with :meth:`Catalog.lookup`, which ignores case, spaces, underscores, hyphens, punctuation
and a leading article: ``"tvmonitor"``, ``"TV monitor"``, ``"night_stand"`` and
``"an office chair"`` all resolve.

Loading never trusts the file: every problem raises :class:`CatalogError` naming the entry and field
(``object[3] (office_chair).size[1]: must be > 0, got -1.0``).
"""

from __future__ import annotations

import difflib
import functools
import math
import re
import sys
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from assets import CATALOG_PATH, PROXY_DIR

if TYPE_CHECKING:
    import trimesh

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - exercised on Python 3.10 only
    import tomli as tomllib

CATALOG_VERSION = 1
"""Newest catalog format version this loader reads."""

DEFAULT_SPREAD = (0.2, 0.2, 0.2)
"""Relative size spread ``(w, h, l)`` of a class whose entry gives no ``spread``."""

Size = tuple[float, float, float]
RGB = tuple[int, int, int]

_NAME_RE = re.compile(r"^[a-z][a-z0-9_]*$")
_COLOR_RE = re.compile(r"^#(?:[0-9a-fA-F]{6}|[0-9a-fA-F]{3})$")
_ARTICLE_RE = re.compile(r"^(?:a|an|the)\s+")
_ENTRY_KEYS = {"name", "prompts", "synonyms", "size", "spread", "on_floor", "model", "color"}
_REQUIRED_KEYS = ("name", "prompts", "size", "model", "color")


class CatalogError(KeyError, ValueError):
    """The catalog is malformed, or a class name is not in it.

    ``field`` is the path of the offending field (``object[3] (office_chair).size``), empty when the
    problem is not tied to one field.
    """

    def __init__(self, field: str, message: str) -> None:
        self.field = field
        self.message = f"{field}: {message}" if field else message
        super().__init__(self.message)

    def __str__(self) -> str:  # KeyError would quote the message.
        return self.message


def normalize_label(label: str) -> str:
    """Matching key of a label: lower case, leading article dropped, only ``[a-z0-9]`` kept.

    ``"An Office-Chair"``, ``"office_chair"`` and ``"officechair"`` all give ``"officechair"``.
    """
    text = " ".join(re.sub(r"[_\-]+", " ", label.lower()).split())
    text = _ARTICLE_RE.sub("", text)
    return re.sub(r"[^a-z0-9]", "", text)


def parse_color(text: str) -> RGB:
    """``"#rrggbb"`` or ``"#rgb"`` -> ``(r, g, b)`` in 0..255; :class:`CatalogError` otherwise."""
    if not isinstance(text, str) or not _COLOR_RE.match(text):
        raise CatalogError("", f'must be a colour "#rrggbb", got {text!r}')
    digits = text[1:]
    if len(digits) == 3:
        digits = "".join(c * 2 for c in digits)
    return (int(digits[0:2], 16), int(digits[2:4], 16), int(digits[4:6], 16))


@dataclass(frozen=True)
class CatalogEntry:
    """One object class.

    Attributes:
        name: Unique snake_case class name; the label written into scenes.
        prompts: Open-vocabulary detector text prompts (at least one).
        synonyms: Other label spellings that resolve to this class.
        size: Typical full extents ``(w, h, l)`` [m], ``h`` vertical, ``l`` along the heading;
            ``None`` when unknown (distance from the depth map only).
        model: Proxy model file name, relative to ``models_dir``.
        color: Display colour ``(r, g, b)``, 0..255.
        models_dir: Directory the model file lives in.
        spread: Relative 1-sigma of real instances' ``(w, h, l)`` around ``size`` (people vary
            little, cabinets a lot); :data:`DEFAULT_SPREAD` when the file gives none.
        on_floor: Instances stand on the floor (their box bottom is a floor contact point; not
            for things on tables or stacked).
    """

    name: str
    prompts: tuple[str, ...]
    synonyms: tuple[str, ...]
    size: Size | None
    model: str
    color: RGB
    models_dir: Path = field(default=PROXY_DIR, repr=False, compare=False)
    spread: Size = (0.2, 0.2, 0.2)
    on_floor: bool = True

    @property
    def height(self) -> float | None:
        """Typical vertical extent [m], ``None`` when the size is unknown."""
        return None if self.size is None else self.size[1]

    @property
    def size_known(self) -> bool:
        """Whether the class has a size prior."""
        return self.size is not None

    @property
    def model_path(self) -> Path:
        """Absolute path of the proxy model file."""
        return self.models_dir / self.model


class Catalog:
    """An ordered, validated set of :class:`CatalogEntry` with label resolution.

    Args:
        entries: The classes, in display order.
        source: File the catalog was read from, if any (for messages).

    Raises:
        CatalogError: Two classes share a name, or a name / synonym / prompt of one class
            resolves to the same key as one of another class.
    """

    def __init__(self, entries: Iterable[CatalogEntry], source: Path | None = None) -> None:
        self._entries = tuple(entries)
        self.source = source
        self._by_name: dict[str, CatalogEntry] = {}
        # Matching key -> (class name, "name" | "synonym" | "prompt", original spelling).
        self._keys: dict[str, tuple[str, str, str]] = {}
        for i, entry in enumerate(self._entries):
            where = f"object[{i}] ({entry.name})"
            if entry.name in self._by_name:
                first = self.names.index(entry.name)
                raise CatalogError(
                    f"{where}.name", f"duplicate class name {entry.name!r} (also object[{first}])"
                )
            self._by_name[entry.name] = entry
            spellings = [("name", entry.name)]
            spellings += [("synonyms", s) for s in entry.synonyms]
            spellings += [("prompts", p) for p in entry.prompts]
            counters = {"name": 0, "synonyms": 0, "prompts": 0}
            for kind, text in spellings:
                index = counters[kind]
                counters[kind] += 1
                path = f"{where}.{kind}" if kind == "name" else f"{where}.{kind}[{index}]"
                key = normalize_label(text)
                if not key:
                    raise CatalogError(path, f"{text!r} has no letters or digits")
                owner = self._keys.get(key)
                if owner is not None and owner[0] != entry.name:
                    raise CatalogError(
                        path,
                        f"{text!r} already resolves to class {owner[0]!r} "
                        f"(its {owner[1].rstrip('s')} {owner[2]!r}); a spelling may belong to one "
                        "class only",
                    )
                if owner is None:
                    self._keys[key] = (entry.name, kind, text)

    @classmethod
    def load(cls, path: Path | str | None = None, models_dir: Path | str | None = None) -> Catalog:
        """Read and validate a catalog TOML file.

        Args:
            path: Catalog file; ``None`` for the packaged ``assets/catalog.toml``.
            models_dir: Directory of the proxy models; default ``proxy_models/`` next to the file.

        Raises:
            CatalogError: The file is missing, is not TOML, or any field is invalid.
        """
        path = Path(CATALOG_PATH if path is None else path)
        models = Path(models_dir) if models_dir is not None else path.parent / "proxy_models"
        try:
            data = tomllib.loads(path.read_text(encoding="utf-8"))
        except FileNotFoundError:
            raise CatalogError("", f"catalog file not found: {path}") from None
        except (OSError, UnicodeDecodeError) as e:
            raise CatalogError("", f"cannot read catalog file {path}: {e}") from None
        except tomllib.TOMLDecodeError as e:
            raise CatalogError("", f"{path} is not valid TOML: {e}") from None
        return cls.from_dict(data, models_dir=models, source=path)

    @classmethod
    def from_dict(
        cls, data: dict[str, Any], models_dir: Path = PROXY_DIR, source: Path | None = None
    ) -> Catalog:
        """Validate a parsed catalog (``{"version": 1, "object": [...]}``); see :meth:`load`."""
        unknown = sorted(set(data) - {"version", "object"})
        if unknown:
            raise CatalogError(unknown[0], 'unknown top-level key (expected "version", "object")')
        version = data.get("version")
        if version is None:
            raise CatalogError("version", "missing (expected version = 1)")
        if not isinstance(version, int) or isinstance(version, bool) or version < 1:
            raise CatalogError("version", f"must be a positive integer, got {version!r}")
        if version > CATALOG_VERSION:
            raise CatalogError(
                "version", f"{version} is newer than this loader supports ({CATALOG_VERSION})"
            )
        objects = data.get("object")
        if not isinstance(objects, list) or not objects:
            raise CatalogError("object", "missing or empty: add at least one [[object]] table")
        entries = [_parse_entry(i, raw, Path(models_dir)) for i, raw in enumerate(objects)]
        return cls(entries, source=source)

    @property
    def entries(self) -> tuple[CatalogEntry, ...]:
        """All classes, in file order."""
        return self._entries

    @property
    def names(self) -> tuple[str, ...]:
        """All class names, in file order."""
        return tuple(e.name for e in self._entries)

    def get(self, name: str) -> CatalogEntry:
        """The class called exactly ``name``.

        Raises:
            CatalogError: No such class; the message suggests close names, or the class the
                label resolves to if ``name`` is a synonym or prompt.
        """
        entry = self._by_name.get(name)
        if entry is not None:
            return entry
        resolved = self.lookup(name)
        if resolved is not None:
            hint = f"it resolves to class {resolved.name!r} (use Catalog.lookup for labels)"
        else:
            close = difflib.get_close_matches(name, self.names, n=3, cutoff=0.6)
            hint = (
                f"did you mean {', '.join(repr(c) for c in close)}?"
                if close
                else f"known classes: {', '.join(self.names)}"
            )
        raise CatalogError("", f"no catalog class named {name!r}; {hint}")

    def lookup(self, label: str) -> CatalogEntry | None:
        """The class a label resolves to by name, synonym or prompt, or ``None``.

        Matching ignores case, spaces, underscores, hyphens, punctuation and a leading
        ``a``/``an``/``the``; a plural (``"chairs"``, ``"boxes"``) falls back to its singular.
        """
        key = normalize_label(label)
        if not key:
            return None
        candidates = [key]
        if key.endswith("ies"):
            candidates.append(key[:-3] + "y")
        if key.endswith("es"):
            candidates.append(key[:-2])
        if key.endswith("s"):
            candidates.append(key[:-1])
        for k in candidates:
            owner = self._keys.get(k)
            if owner is not None:
                return self._by_name[owner[0]]
        return None

    def prompts(self) -> list[tuple[str, str]]:
        """Every detector prompt with its class: ``[(prompt, class_name), ...]`` in file order."""
        return [(p, e.name) for e in self._entries for p in e.prompts]

    def __iter__(self) -> Iterator[CatalogEntry]:
        return iter(self._entries)

    def __len__(self) -> int:
        return len(self._entries)

    def __contains__(self, name: object) -> bool:
        return name in self._by_name

    def __repr__(self) -> str:
        return f"Catalog({len(self)} classes from {self.source})"


def load_proxy_mesh(path: Path | str) -> trimesh.Trimesh:
    """Load a proxy ``.glb`` as one mesh with per-vertex colours (``mesh.visual.vertex_colors``).

    The file is y-up as glTF 2.0 says (file ``(X, Y, Z)`` = object ``(y, z, x)``); the mesh returned is in the
    object frame (x forward along the heading, y left, z up) with bounds ``[-0.5, 0.5]^3``: scale it by
    ``(l, w, h)`` to place it. (A glTF viewer uses the file as is, scaled by ``[w, h, l]`` along its axes
    and turned by :func:`pipeline.rotation.yaw_gltf_quat_wxyz`.)

    Raises:
        CatalogError: The file is missing or is not a mesh.
    """
    import trimesh  # local: the rest of the catalog does not need it

    path = Path(path)
    if not path.is_file():
        raise CatalogError("", f"proxy model not found: {path}")
    try:
        loaded = trimesh.load(path, process=False)
    except Exception as e:  # trimesh raises many types for corrupt files
        raise CatalogError("", f"cannot read proxy model {path}: {e}") from None
    meshes = [loaded] if isinstance(loaded, trimesh.Trimesh) else []
    if isinstance(loaded, trimesh.Scene):
        for node in loaded.graph.nodes_geometry:
            transform, geometry_name = loaded.graph[node]
            geometry = loaded.geometry[geometry_name]
            if isinstance(geometry, trimesh.Trimesh):
                meshes.append(_with_vertex_colors(geometry).copy().apply_transform(transform))
    meshes = [m for m in meshes if len(m.faces)]
    if not meshes:
        raise CatalogError("", f"proxy model {path} has no triangles")
    mesh = _with_vertex_colors(meshes[0]) if len(meshes) == 1 else trimesh.util.concatenate(meshes)
    mesh.vertices = object_from_gltf(mesh.vertices)
    return mesh


GLTF_TO_OBJECT = [2, 0, 1]
"""Column order turning glTF vertices (X left, Y up, Z forward) into the object frame (x forward, y left, z up)."""


def object_from_gltf(vertices: np.ndarray) -> np.ndarray:
    """Vertices of a y-up glTF proxy model in the object frame (x forward, y left, z up)."""
    return np.asarray(vertices, dtype=np.float64)[:, GLTF_TO_OBJECT]


def _with_vertex_colors(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """Move glTF ``COLOR_0`` (kept by trimesh as a vertex attribute) into ``ColorVisuals``."""
    import trimesh

    colors = getattr(mesh.visual, "vertex_attributes", {}).get("color")
    if colors is not None and len(colors) == len(mesh.vertices):
        mesh.visual = trimesh.visual.ColorVisuals(mesh, vertex_colors=np.asarray(colors))
    return mesh


@functools.lru_cache(maxsize=1)
def default_catalog() -> Catalog:
    """The packaged catalog, loaded once per process."""
    return Catalog.load()


def _parse_entry(index: int, raw: Any, models_dir: Path) -> CatalogEntry:
    """Validate one ``[[object]]`` table."""
    where = f"object[{index}]"
    if not isinstance(raw, dict):
        raise CatalogError(where, f"must be a table, got {type(raw).__name__}")
    name = raw.get("name")
    if not isinstance(name, str) or not _NAME_RE.match(name):
        raise CatalogError(f"{where}.name", f"must be a snake_case string, got {name!r}")
    where = f"{where} ({name})"
    unknown = sorted(set(raw) - _ENTRY_KEYS)
    if unknown:
        raise CatalogError(
            f"{where}.{unknown[0]}", f"unknown field (expected {', '.join(sorted(_ENTRY_KEYS))})"
        )
    for key in _REQUIRED_KEYS:
        if key not in raw:
            raise CatalogError(f"{where}.{key}", "missing")

    prompts = _strings(f"{where}.prompts", raw["prompts"])
    if not prompts:
        raise CatalogError(f"{where}.prompts", "must list at least one detector prompt")
    synonyms = _strings(f"{where}.synonyms", raw.get("synonyms", []))
    size = _size(f"{where}.size", raw["size"])
    spread = _spread(f"{where}.spread", raw.get("spread", list(DEFAULT_SPREAD)))
    on_floor = raw.get("on_floor", True)
    if not isinstance(on_floor, bool):
        raise CatalogError(f"{where}.on_floor", f"must be true or false, got {on_floor!r}")

    model = raw["model"]
    if not isinstance(model, str) or not model.strip():
        raise CatalogError(f"{where}.model", f"must be a file name, got {model!r}")
    if not (models_dir / model).is_file():
        raise CatalogError(f"{where}.model", f"file not found: {models_dir / model}")

    try:
        color = parse_color(raw["color"])
    except CatalogError as e:
        raise CatalogError(f"{where}.color", e.message) from None

    return CatalogEntry(
        name=name,
        prompts=prompts,
        synonyms=synonyms,
        size=size,
        model=model,
        color=color,
        models_dir=models_dir,
        spread=spread,
        on_floor=on_floor,
    )


def _strings(path: str, value: Any) -> tuple[str, ...]:
    """A list of non-empty strings."""
    if not isinstance(value, list):
        raise CatalogError(path, f"must be a list of strings, got {type(value).__name__}")
    for i, item in enumerate(value):
        if not isinstance(item, str) or not item.strip():
            raise CatalogError(f"{path}[{i}]", f"must be a non-empty string, got {item!r}")
    return tuple(value)


def _spread(path: str, value: Any) -> Size:
    """A relative size spread ``[s_w, s_h, s_l]``: three finite numbers within 0..2."""
    if not isinstance(value, list) or len(value) != 3:
        raise CatalogError(path, f"must be [s_w, s_h, s_l] (relative 1-sigma), got {value!r}")
    out = []
    for i, v in enumerate(value):
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise CatalogError(f"{path}[{i}]", f"must be a finite number, got {v!r}")
        if not 0 <= v <= 2:
            raise CatalogError(f"{path}[{i}]", f"must be within 0..2 (a relative spread), got {v!r}")
        out.append(float(v))
    return (out[0], out[1], out[2])


def _size(path: str, value: Any) -> Size | None:
    """``"unknown"`` -> ``None``; otherwise a positive finite ``[w, h, l]``."""
    if value == "unknown":
        return None
    if not isinstance(value, list) or len(value) != 3:
        raise CatalogError(path, f'must be [w, h, l] in metres or "unknown", got {value!r}')
    out = []
    for i, v in enumerate(value):
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise CatalogError(f"{path}[{i}]", f"must be a finite number, got {v!r}")
        if v <= 0:
            raise CatalogError(f"{path}[{i}]", f"must be > 0, got {v!r}")
        out.append(float(v))
    return (out[0], out[1], out[2])
