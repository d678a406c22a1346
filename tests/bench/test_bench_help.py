"""Every benchmark script is a command with ``--help`` (argparse)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

BENCH = Path(__file__).resolve().parents[2] / "bench"
SCRIPTS = sorted(p for p in BENCH.glob("*.py") if 'if __name__ == "__main__"' in p.read_text(encoding="utf-8"))


def test_there_are_benchmark_scripts() -> None:
    assert len(SCRIPTS) >= 5, SCRIPTS


@pytest.mark.parametrize("script", SCRIPTS, ids=lambda p: p.name)
def test_benchmark_script_has_help(script: Path) -> None:
    ok = subprocess.run([sys.executable, str(script), "--help"], capture_output=True, text=True, timeout=300,
                        cwd=BENCH.parent)
    assert ok.returncode == 0, ok.stderr
    assert ok.stdout.startswith("usage: ") and "--help" in ok.stdout
