"""The code runs on the oldest Python that pyproject.toml admits (3.10): checked statically with vermin,
since only one interpreter is installed here."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def test_sources_need_no_newer_python_than_pyproject_admits() -> None:
    declared = re.search(r'requires-python\s*=\s*">=\s*(\d+)\.(\d+)"', (REPO / "pyproject.toml").read_text())
    assert declared, "pyproject.toml must declare requires-python = \">=X.Y\""
    target = f"{declared[1]}.{declared[2]}"
    folders = [str(REPO / d) for d in ("pipeline", "planner", "console", "assets", "bench", "tests")]
    proc = subprocess.run(
        [sys.executable, "-c", "import sys, vermin; sys.exit(vermin.main())", f"--target={target}-", "--violations", "--no-tips",
         "--eval-annotations", "--backport", "typing", *folders],
        capture_output=True, text=True, timeout=300,
    )
    assert proc.returncode == 0, f"code needing a Python newer than {target}:\n{proc.stdout}\n{proc.stderr}"
