"""The docs: the commands page matches the parsers, every relative link resolves, the README stays short,
and no page speaks of issue numbers (the CHANGELOG holds the history)."""
from __future__ import annotations

import importlib.util
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
PAGES = sorted((ROOT / "docs").rglob("*.md"))
LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)")
ISSUE = re.compile(r"\bissues?[ -]?#?\d+|(?<![\w&/])#\d+\b", re.IGNORECASE)


def _gen():
    spec = importlib.util.spec_from_file_location("gen_commands", ROOT / "docs" / "gen_commands.py")
    module = importlib.util.module_from_spec(spec)
    assert spec.loader is not None
    spec.loader.exec_module(module)
    return module


def _without_code(text: str) -> str:
    """The Markdown text with fenced code blocks blanked (links inside them are not links)."""
    return re.sub(r"```.*?```", "", text, flags=re.DOTALL)


def test_the_commands_page_is_what_the_parsers_give() -> None:
    page = (ROOT / "docs" / "reference" / "commands.md").read_text(encoding="utf-8")
    assert page == _gen().render(), "docs/reference/commands.md is stale: run .venv/bin/python docs/gen_commands.py"


def test_the_commands_page_names_every_command_and_option() -> None:
    import argparse

    from console.cli.morphonavi import build_parser

    page = (ROOT / "docs" / "reference" / "commands.md").read_text(encoding="utf-8")
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    assert len(sub.choices) >= 8
    for name, p in sub.choices.items():
        assert f"### `morphonavi {name}`" in page, name
        for action in p._actions:
            for flag in action.option_strings:
                if flag.startswith("--"):
                    assert flag in page, f"{name} {flag}"


def test_every_relative_link_points_to_a_file_that_exists() -> None:
    assert len(PAGES) >= 15, PAGES
    broken = []
    for page in [README, *PAGES]:
        for target in LINK.findall(_without_code(page.read_text(encoding="utf-8"))):
            if re.match(r"^[a-z][a-z0-9+.-]*:", target) or target.startswith("#"):
                continue  # http(s)://, mailto:, an anchor in the same page
            path = (page.parent / target.split("#", 1)[0]).resolve()
            if not path.exists():
                broken.append(f"{page.relative_to(ROOT)}: {target}")
    assert not broken, broken


def test_the_link_check_sees_a_broken_link(tmp_path: Path) -> None:
    page = tmp_path / "p.md"
    page.write_text("see [here](missing.md) and [web](https://x.org) and ![pic](p.md)\n```\n[not](a-link.md)\n```\n")
    targets = LINK.findall(_without_code(page.read_text()))
    assert targets == ["missing.md", "https://x.org", "p.md"]


def test_the_readme_is_short() -> None:
    lines = README.read_text(encoding="utf-8").count("\n")
    assert lines <= 250, f"README.md has {lines} lines (at most 250: put the rest in docs/)"


def test_no_page_speaks_of_issue_numbers() -> None:
    assert ISSUE.search("fixed in issue 19") and ISSUE.search("see #21") and ISSUE.search("the issue-9 faults")
    assert not ISSUE.search("colour #ff0000") and not ISSUE.search("a C# class")
    found = []
    for page in [README, *PAGES]:
        for n, line in enumerate(page.read_text(encoding="utf-8").splitlines(), 1):
            if ISSUE.search(line):
                found.append(f"{page.relative_to(ROOT)}:{n}: {line.strip()[:80]}")
    assert not found, found
