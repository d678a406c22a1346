"""Return to a take-off spot within the robot's radius of a wall lands at the nearest spot the landing rule
fits and says so (it was refused with the edge message); a take-off spot that fits is landed on as before."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from console.session.session import RobotSnapshot, Session, SessionError
from console.session.topics import NOTICE
from pipeline.camera.geometry import Pose
from pipeline.scene import Scene, SceneObject
from planner.landing_spot import landing_problem


def _ground(x: float, y: float) -> RobotSnapshot:
    return RobotSnapshot(Pose.from_xyz_yaw(x, y, 0.0), mode="idle", armed=False, landed=True)


def _hover(x: float, y: float, z: float) -> RobotSnapshot:
    return RobotSnapshot(Pose.from_xyz_yaw(x, y, z), mode="holding", armed=True, landed=False)


def _session(tmp_path: Path, launch: tuple[float, float]) -> tuple[Session, list]:
    s = Session(tmp_path / "s", start=(launch[0], launch[1], 0.0), autosave=False)
    s.spawn(Scene(objects=(SceneObject("box-1", "cardboard_box", (2.5, 4.0, 0.6), (0.5, 1.2, 0.5)),)))
    notices: list = []
    s.subscribe(lambda topic, payload: notices.append(payload) if topic == NOTICE else None)
    s.set_robot(_ground(*launch))  # stood disarmed there: the launch spot
    s.set_robot(_hover(2.5, 2.5, 1.5))
    return s, notices


def test_return_to_a_take_off_spot_beside_the_wall_lands_at_the_nearest_fit_spot(tmp_path: Path) -> None:
    s, notices = _session(tmp_path, (0.2, 0.7))  # 0.2 m from the wall x = 0: inside the robot's 0.35 m
    mission = s.return_mission()
    end = mission.segments[-1].end
    assert end[2] == pytest.approx(0.0) and end[:2] == pytest.approx((0.375, 0.625))  # the nearest floor cell that fits
    assert landing_problem(s.grid, end) is None and min(end[0], end[1]) > 0.35  # keeps its radius from the walls
    said = [n.body for n in notices if n.title == "Return"]
    d = math.dist(end[:2], (0.2, 0.7))
    assert said == [f"Return: lands at (0.38, 0.62), {d:.2f} m from the take-off spot (0.20, 0.70), where the robot "
                    "cannot land: too near the wall"]


def test_return_to_a_take_off_spot_that_fits_lands_on_it_and_says_nothing_more(tmp_path: Path) -> None:
    s, notices = _session(tmp_path, (2.5, 0.7))
    end = s.return_mission().segments[-1].end
    assert end[:2] == pytest.approx((2.5, 0.7), abs=0.13)  # its cell's centre
    assert not [n for n in notices if n.title == "Return"]


def test_return_with_no_floor_spot_that_fits_is_refused_with_the_reason(tmp_path: Path) -> None:
    s, _ = _session(tmp_path, (0.2, 0.7))
    s.spawn(Scene(objects=(SceneObject("mat", "sports_mat", (2.5, 4.0, 0.025), (8.0, 0.05, 5.0)),)))  # the whole floor
    with pytest.raises(SessionError, match=r"no floor spot fits the landing rule \(the take-off spot \(0.20, 0.70\): "
                                           r"too near the wall\)"):
        s.return_mission()
