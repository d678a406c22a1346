"""`RobotLink.segment_under_way` asks each link for its current run through `_current_run` (it read the private
`_run` of its subclasses): the simulated robot's walk is under way until it ends or is aborted, and a link that
keeps its run elsewhere answers through its own `_current_run`."""

from __future__ import annotations

import pytest

from console.link.base import LinkError, RobotLink, RunStatus, SegmentRun
from console.link.sim import SimRobot
from planner.mission import MissionSegment, SegmentKind


def test_the_simulated_walk_is_under_way_until_aborted() -> None:
    robot = SimRobot(manual_clock=True)
    robot.connect()
    try:
        assert robot.segment_under_way() is False and robot._current_run() is None
        x, y, z = robot.latest_state().position
        run = robot.run_segment(MissionSegment(SegmentKind.WALK, ((x, y, z), (x, y + 1.0, z))))
        robot.step(0.1)
        assert robot._current_run() is run and robot.segment_under_way() is True
        with pytest.raises(LinkError, match="a walk segment is still running: hold or abort it first"):
            robot.run_segment(MissionSegment(SegmentKind.WALK, ((x, y, z), (x + 1.0, y, z))))
        robot.abort()
        assert run.done and robot.segment_under_way() is False
    finally:
        robot.close()


class _OtherLink(RobotLink):
    """A link that keeps its run under another name (no `_run`)."""

    def __init__(self, run: SegmentRun | None) -> None:
        super().__init__()
        self.current = run

    def _current_run(self) -> SegmentRun | None:
        return self.current

    @property
    def connected(self) -> bool:
        return True

    def connect(self) -> None: ...
    def close(self) -> None: ...
    def capture(self):  # type: ignore[no-untyped-def]
        raise NotImplementedError
    def run_segment(self, segment: MissionSegment) -> SegmentRun:
        raise NotImplementedError
    def hold(self) -> None: ...
    def abort(self) -> None: ...


def test_a_link_answers_through_its_own_current_run() -> None:
    run = SegmentRun(MissionSegment(SegmentKind.WALK, ((0.0, 0.0, 0.0), (1.0, 0.0, 0.0))))
    link = _OtherLink(run)
    assert link.segment_under_way() is True
    run.finish(RunStatus.HELD, "")
    assert link.segment_under_way() is False
    assert _OtherLink(None).segment_under_way() is False
