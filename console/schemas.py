"""The published JSON Schemas of MorphoNavi's files, from the one place each is defined, and their writer.

``python -m console.schemas`` writes ``docs/schemas/<name>.schema.json`` (``--check``: exit 1 naming the files
that differ from what would be written; ``--validate KIND FILE``: check a file against its schema, naming every
bad field, exit 1 when there is one). The schemas themselves live beside the code that reads each format:

- ``scene``: :data:`pipeline.scene_schema.SCENE_SCHEMA` (scene files, ``map --out``);
- ``mission``: :data:`planner.mission_schema.MISSION_SCHEMA` (``plan --out``, the console's missions);
- ``session``: :data:`console.session.session_schema.SESSION_SCHEMA` (the console's ``session.json``);
- ``history``: :data:`console.session.history_schema.HISTORY_SCHEMA` (the console's undo history ``history.json``);
- ``camera``: :data:`pipeline.camera.camera_schema.CAMERA_SCHEMA` (``camera.toml``, as parsed);
- ``scene_graph``: :data:`planner.scene_graph_schema.SCENE_GRAPH_SCHEMA` (``describe --json``);
- ``search_result``: :data:`console.session.search_result_schema.SEARCH_RESULT_SCHEMA` (``search --out``).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from pipeline.camera.camera_schema import CAMERA_SCHEMA
from pipeline.scene_schema import SCENE_SCHEMA
from planner.mission_schema import MISSION_SCHEMA
from planner.scene_graph_schema import SCENE_GRAPH_SCHEMA

from console.session.history_schema import HISTORY_SCHEMA
from console.session.search_result_schema import SEARCH_RESULT_SCHEMA
from console.session.session_schema import SESSION_SCHEMA

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10 only
    import tomli as tomllib

SCHEMAS: dict[str, dict[str, Any]] = {
    "scene": SCENE_SCHEMA,
    "mission": MISSION_SCHEMA,
    "session": SESSION_SCHEMA,
    "history": HISTORY_SCHEMA,
    "camera": CAMERA_SCHEMA,
    "scene_graph": SCENE_GRAPH_SCHEMA,
    "search_result": SEARCH_RESULT_SCHEMA,
}
"""Published schemas by file name stem (``docs/schemas/<name>.schema.json``)."""

DEFAULT_DIR = Path(__file__).resolve().parents[1] / "docs" / "schemas"


def schema_text(schema: dict[str, Any]) -> str:
    """The file text of a schema (indented JSON, sorted as written, final newline)."""
    return json.dumps(schema, indent=2, ensure_ascii=False) + "\n"


def stale(folder: Path) -> list[str]:
    """The schema files in ``folder`` that are missing or differ from the schemas."""
    out = []
    for name, schema in SCHEMAS.items():
        path = folder / f"{name}.schema.json"
        if not path.is_file() or path.read_text(encoding="utf-8") != schema_text(schema):
            out.append(str(path))
    return out


def write(folder: Path) -> list[Path]:
    """Write every schema into ``folder`` (created if missing); returns the files."""
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for name, schema in SCHEMAS.items():
        path = folder / f"{name}.schema.json"
        path.write_text(schema_text(schema), encoding="utf-8")
        paths.append(path)
    return paths


def validate_file(kind: str, path: Path) -> list[str]:
    """The schema errors of the JSON (or, for ``camera``, TOML) file ``path`` ([] when it is valid); a file that
    cannot be read or parsed gives one message."""
    from pipeline.schema_check import schema_errors

    try:
        text = path.read_text(encoding="utf-8")
        if kind == "camera" and not text.lstrip().startswith("{"):
            data = tomllib.loads(text)
        else:
            data = json.loads(text)
    except (OSError, UnicodeDecodeError, ValueError, RecursionError) as exc:
        return [f"cannot read {path}: {exc}"]
    return schema_errors(SCHEMAS[kind], data)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m console.schemas", description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=DEFAULT_DIR, help=f"folder to write (default {DEFAULT_DIR})")
    parser.add_argument("--check", action="store_true", help="write nothing; exit 1 naming the files that differ")
    parser.add_argument("--validate", nargs=2, metavar=("KIND", "FILE"),
                        help=f"check FILE against the schema of KIND ({', '.join(SCHEMAS)}); exit 1 naming every bad field")
    args = parser.parse_args(argv)
    if args.validate:
        kind, file = args.validate
        if kind not in SCHEMAS:
            parser.error(f"--validate: unknown kind {kind!r}; one of {', '.join(SCHEMAS)}")
        errors = validate_file(kind, Path(file))
        for line in errors:
            print(f"{file}: {line}", file=sys.stderr)
        if not errors:
            print(f"{file}: a valid {kind} file")
        return 1 if errors else 0
    if args.check:
        bad = stale(args.out)
        for path in bad:
            print(f"out of date: {path} (run python -m console.schemas)", file=sys.stderr)
        return 1 if bad else 0
    for path in write(args.out):
        print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
