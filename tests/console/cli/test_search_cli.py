"""`morphonavi search` on the paper's room: prints each step, finds the robot dog behind the line of
boxes by flying over it, ends within 1 m of it with no refusal from the simulator, writes result.json."""

from __future__ import annotations

import json
import math
from pathlib import Path

from console.cli.morphonavi import main
from console.schemas import SCHEMAS
from pipeline.schema_check import schema_errors


def test_search_finds_the_dog_behind_the_line_and_writes_the_result(tmp_path: Path, capsys) -> None:
    out = tmp_path / "result.json"
    code = main(["search", "--target", "robot dog", "--out", str(out), "--max-captures", "16"])
    text = capsys.readouterr().out
    assert code == 0, text[-3000:]
    data = json.loads(out.read_text())
    assert schema_errors(SCHEMAS["search_result"], data) == []  # the documented schema (docs/schemas)
    for key in ("found", "target_id", "final_position", "distance_to_target", "path_length", "captures", "time",
                "reason"):
        assert key in data, key
    assert data["found"] is True and data["target_id"] == "robot_dog-1", data["reason"]
    assert math.dist(data["final_position"][:2], (2.5, 6.3)) < 1.0, data["final_position"]
    assert data["distance_to_target"] < 1.0 and data["path_length"] > 5.0 and 2 <= data["captures"] <= 16
    assert "takeoff" in text and "next viewpoint" in text and "capture 1 (where the robot stands)" in text
    assert "refused" not in text and "contact with" not in text and "failed" not in text, text[-3000:]
    assert text.strip().splitlines()[-2].startswith("FOUND: found; target robot_dog-1")


def test_search_refuses_bad_options_naming_them(tmp_path: Path, capsys) -> None:
    assert main(["search", "--target", "robot dog", "--max-captures", "0"]) == 2
    assert "--max-captures: must be a whole number" in capsys.readouterr().err
    assert main(["search", "--target", "robot dog", "--world", str(tmp_path / "nope.json")]) == 2
    assert "--world" in capsys.readouterr().err


def test_a_search_ended_by_its_budget_writes_a_result_following_the_documented_schema(tmp_path: Path, capsys) -> None:
    """A synonym of the class ('quadruped'), noisy perception with a seed, one capture: not found, exit 1."""
    out = tmp_path / "result.json"
    code = main(["search", "--target", "quadruped", "--max-captures", "1", "--perception", "noisy", "--seed", "7",
                 "--out", str(out)])
    text = capsys.readouterr().out
    assert code == 1, text[-3000:]
    assert "noisy ground-truth perception, noise seed 7" in text
    data = json.loads(out.read_text())
    assert schema_errors(SCHEMAS["search_result"], data) == [], data
    assert data["found"] is False and data["captures"] == 1 and data["target"] == "quadruped"
    assert "budget of 1 capture" in data["reason"] and data["left_unseen"] and data["contacts"] == 0
