"""Write docs/reference/commands.md from the `morphonavi` argparse parsers (every command and option).

Run `.venv/bin/python docs/gen_commands.py` after changing an option; `--check` exits 1 when the committed
page differs from what the parsers give (tests/test_docs.py runs the same comparison).
"""
from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "reference" / "commands.md"
WIDTH = 110  # [characters] help text width, fixed so the page does not depend on the terminal

HEADER = """# Commands: every `morphonavi` command and option

Generated from the command's own parsers by `.venv/bin/python docs/gen_commands.py` (do not edit by hand).
Each command also prints this with `--help`, e.g. `morphonavi map --help`. Options that take a list of
numbers (`--pose`, `--start`, `--goal`, `--bounds`, ...) accept negative values as they are
(`--pose -1,2,0,90`). Frames and units are in [file formats](formats.md#frames-and-units).
"""


def _subparsers(parser: argparse.ArgumentParser) -> list[tuple[str, argparse.ArgumentParser]]:
    """The (name, parser) of each subcommand, in the order they were added (aliases left out)."""
    out: list[tuple[str, argparse.ArgumentParser]] = []
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            seen: set[int] = set()
            for name, sub in action.choices.items():
                if id(sub) not in seen:
                    seen.add(id(sub))
                    out.append((name, sub))
    return out


def _sections(parser: argparse.ArgumentParser, path: list[str], level: int) -> list[str]:
    title = " ".join(["morphonavi", *path])
    lines = [f"{'#' * level} `{title}`", "", "```text", parser.format_help().rstrip(), "```", ""]
    for name, sub in _subparsers(parser):
        lines += _sections(sub, [*path, name], min(level + 1, 4))
    return lines


def render() -> str:
    """The commands page as the current parsers describe it."""
    os.environ["COLUMNS"] = str(WIDTH)  # argparse reads the width from here
    sys.path.insert(0, str(ROOT))
    from console.cli.morphonavi import build_parser

    parser = build_parser()
    names = [name for name, _ in _subparsers(parser)]
    index = ["| command | what it does |", "|---|---|"]
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for choice in action._choices_actions:
                index.append(f"| [`{choice.dest}`](#morphonavi-{choice.dest}) | {choice.help} |")
    assert len(index) - 2 == len(names), (names, index)
    body = _sections(parser, [], 2)
    return HEADER + "\n" + "\n".join(index) + "\n\n" + "\n".join(body).rstrip() + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="compare with the committed page instead of writing it")
    args = ap.parse_args(argv)
    text = render()
    if args.check:
        same = PAGE.exists() and PAGE.read_text(encoding="utf-8") == text
        print("docs/reference/commands.md is up to date" if same else
              "docs/reference/commands.md differs from the parsers: run .venv/bin/python docs/gen_commands.py")
        return 0 if same else 1
    PAGE.write_text(text, encoding="utf-8")
    print(f"wrote {PAGE.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
