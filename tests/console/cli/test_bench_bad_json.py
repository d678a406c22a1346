"""`morphonavi bench DATASET` on a dataset whose JSON is broken names the file and the place of the error, like the
other readers (``... index.json: not valid JSON (line 2, column 12): Expecting value``), exits 2, and shows no
traceback (pipeline/bench/evaluate.py)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from console.cli.morphonavi import main

ARGS = ["--gt-boxes", "--no-models", "--no-progress", "--out", ""]


def _bench(root: Path, capsys: pytest.CaptureFixture[str]) -> tuple[int, str]:
    code = main(["bench", str(root), *ARGS])
    return code, capsys.readouterr().err


def test_a_bad_index_json_names_the_file_with_its_line_and_column(tmp_path: Path,
                                                                  capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "index.json").write_text('[{"json": "kitchen/1.json",\n  "image": }]\n', encoding="utf-8")
    code, err = _bench(tmp_path, capsys)
    assert code == 2, err
    assert f"{tmp_path / 'index.json'}: not valid JSON (line 2, column 12): Expecting value" in err, err
    assert "char" not in err and "Traceback" not in err, err


def test_a_bad_sample_json_names_that_file_with_its_line_and_column(tmp_path: Path,
                                                                    capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "kitchen").mkdir()
    (tmp_path / "index.json").write_text(json.dumps([{"json": "kitchen/1.json", "image": "kitchen/1.jpg"}]),
                                         encoding="utf-8")
    (tmp_path / "kitchen" / "1.json").write_text('{"image": "1.jpg", "width": 640,, "height": 480}', encoding="utf-8")
    code, err = _bench(tmp_path, capsys)
    assert code == 2, err
    assert f"{tmp_path / 'kitchen' / '1.json'}: not valid JSON (line 1, column 33): Expecting property name" in err, err


def test_an_index_json_that_is_not_text_says_so(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "index.json").write_bytes(b'[{"json": "\xff\xfe"}]')
    code, err = _bench(tmp_path, capsys)
    assert code == 2, err
    assert "index.json" in err and "not UTF-8" in err and "Traceback" not in err, err
