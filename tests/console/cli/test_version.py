"""``morphonavi --version`` prints the installed package's version; the licence file ships."""

from __future__ import annotations

from importlib.metadata import version
from pathlib import Path

import pytest

from console.cli.morphonavi import main

REPO = Path(__file__).resolve().parents[3]


def test_version_prints_the_package_version(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exit_:
        main(["--version"])
    assert exit_.value.code == 0
    assert capsys.readouterr().out.strip() == f"morphonavi {version('morphonavi')}"


def test_mit_licence_file_matches_pyproject() -> None:
    text = (REPO / "LICENSE").read_text(encoding="utf-8")
    assert text.startswith("MIT License") and "WITHOUT WARRANTY OF ANY KIND" in text
    assert 'license = { text = "MIT" }' in (REPO / "pyproject.toml").read_text(encoding="utf-8")
