"""Build the low-poly proxy model (``.glb``) of every catalog class.

Run ``python -m assets.make_proxy_models`` to regenerate ``assets/proxy_models/`` from
``assets/catalog.toml`` (``--out DIR`` writes elsewhere, ``--only NAME`` builds some classes only).
The output is deterministic: the same catalog gives the same vertices.

Each model is built from a few primitives (boxes, rods, cylinders, spheres, tori) at the class's
typical size in metres, coloured per part with shades of the class colour (plus a few neutral
accents such as black tyres), then normalised:

- Built in the OBJECT frame: x = length axis (the catalog ``l``, the object's heading; its front faces
  +x), y = width (catalog ``w``, y to the object's left), z = up (catalog ``h``).
- Stored y-up as glTF 2.0 says (up +Y, front +Z, left +X): file ``(X, Y, Z)`` = object ``(y, z, x)``, so
  any glTF viewer shows the model upright, and scaling the file's axes by the object's ``[w, h, l]``
  (the scene file's size order) sizes it. :func:`pipeline.catalog.load_proxy_mesh` turns it back into
  the object frame; Foxglove does the same turn for every glTF model (ROS REP 103, z up).
- The axis-aligned bounding box is exactly ``[-0.5, 0.5]^3``.

Colours are per-vertex (``COLOR_0``) with one matte material and no normals, so glTF viewers
(three.js / viser) shade the faces flat. ``box.glb`` is the neutral fallback for unknown labels.

This module reads the catalog and writes the files; the meshes are built by
:mod:`assets.proxy_builders` (parts and colours, the builder table, one module per object family).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Iterable, Sequence
from pathlib import Path

import trimesh

from assets import CATALOG_PATH, FALLBACK_MODEL, PROXY_DIR
from assets.proxy_builders import (BUILDERS, DEFAULT_NOMINAL_SIZE, NOMINAL_SIZES, RGB, Builder, Parts, box,
                                   builder, normalize)

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10 only
    import tomli as tomllib

OBJECT_TO_GLTF = [1, 2, 0]
"""Column order turning object-frame vertices (x forward, y left, z up) into glTF's (X left, Y up, Z forward)."""

FALLBACK_COLOR: RGB = (158, 158, 158)
"""Colour of ``box.glb``, the model of labels without a catalog entry."""


# --- Catalog reading and output ---------------------------------------------------------------


def read_catalog(path: Path = CATALOG_PATH) -> list[dict]:
    """The raw ``[[object]]`` tables (name, size, model, color) of a catalog file.

    Reads the TOML directly (not :mod:`pipeline.catalog`, which requires the models to exist).
    """
    with open(path, "rb") as f:
        data = tomllib.load(f)
    return list(data.get("object", []))


def _parse_color(text: str) -> RGB:
    t = text.lstrip("#")
    if len(t) == 3:
        t = "".join(c * 2 for c in t)
    return (int(t[0:2], 16), int(t[2:4], 16), int(t[4:6], 16))


def build_model(kind: str, size: Sequence[float] | None, color: RGB) -> trimesh.Trimesh:
    """Build and normalise one proxy mesh.

    Args:
        kind: Builder name (the model file stem, e.g. ``office_chair``); unknown kinds get a box.
        size: Typical ``(w, h, l)`` [m] the parts are laid out at; ``None`` for the nominal size.
        color: Class colour ``(r, g, b)``.

    Returns:
        The mesh in the object frame (x forward, y left, z up), bounds exactly ``[-0.5, 0.5]^3``.
    """
    w, h, l = size if size is not None else NOMINAL_SIZES.get(kind, DEFAULT_NOMINAL_SIZE)
    parts = Parts(color)
    BUILDERS.get(kind, box)(parts, float(w), float(h), float(l))
    return normalize(parts.mesh())


def _matte_material(tree: dict) -> None:
    """glTF post-processing: one non-metallic material that multiplies the vertex colours."""
    tree["materials"] = [
        {
            "pbrMetallicRoughness": {
                "baseColorFactor": [1, 1, 1, 1],
                "metallicFactor": 0.0,
                "roughnessFactor": 0.85,
            }
        }
    ]
    for mesh in tree.get("meshes", []):
        for prim in mesh["primitives"]:
            prim["material"] = 0


def export_glb(mesh: trimesh.Trimesh, path: Path, name: str) -> None:
    """Write ``mesh`` (object frame, z up) as a y-up GLB with vertex colours, a matte material and no normals."""
    gltf = mesh.copy()
    gltf.vertices = mesh.vertices[:, OBJECT_TO_GLTF]  # a proper rotation: faces keep their winding
    scene = trimesh.Scene()
    scene.add_geometry(gltf, geom_name=name, node_name=name)
    data = trimesh.exchange.gltf.export_glb(
        scene, include_normals=False, tree_postprocessor=_matte_material
    )
    path.write_bytes(data)


def write_models(
    out_dir: Path = PROXY_DIR, catalog: Path = CATALOG_PATH, only: Iterable[str] | None = None
) -> dict[str, Path]:
    """Build the model of every catalog entry plus the fallback box into ``out_dir``.

    Returns:
        ``{model file name: written path}``.
    """
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    wanted = set(only) if only is not None else None
    jobs: list[tuple[str, Sequence[float] | None, RGB, str]] = []
    for entry in read_catalog(Path(catalog)):
        size = entry.get("size")
        jobs.append(
            (
                entry["model"],
                None if size == "unknown" else size,
                _parse_color(entry["color"]),
                entry["name"],
            )
        )
    jobs.append((FALLBACK_MODEL, (1.0, 1.0, 1.0), FALLBACK_COLOR, "box"))
    written: dict[str, Path] = {}
    for model, size, color, name in jobs:
        if wanted is not None and name not in wanted and model not in wanted:
            continue
        kind = Path(model).stem
        mesh = build_model(kind, size, color)
        path = out_dir / model
        export_glb(mesh, path, name)
        written[model] = path
    return written


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--out",
        type=Path,
        default=PROXY_DIR,
        help="output directory (default: assets/proxy_models)",
    )
    parser.add_argument("--catalog", type=Path, default=CATALOG_PATH, help="catalog TOML file")
    parser.add_argument("--only", nargs="+", metavar="NAME", help="build only these classes")
    args = parser.parse_args(argv)
    try:
        written = write_models(args.out, args.catalog, args.only)
    except (OSError, KeyError, ValueError, tomllib.TOMLDecodeError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    for model, path in written.items():
        mesh = trimesh.load(path, force="mesh", process=False)
        print(f"{model:24s} {len(mesh.faces):5d} faces {path.stat().st_size / 1024:6.1f} KB")
    return 0


__all__ = ["BUILDERS", "NOMINAL_SIZES", "DEFAULT_NOMINAL_SIZE", "FALLBACK_COLOR", "Builder", "Parts", "builder",
           "normalize", "read_catalog", "build_model", "export_glb", "write_models", "main"]


if __name__ == "__main__":
    sys.exit(main())
