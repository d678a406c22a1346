"""A segment starts from where the previous one really ended, not from a stored state sample.

The link's state stream is sampled (``state_rate``); on a loaded machine the sampler can lag the
segment thread by a second or more, so the last sample may still show the robot mid-walk when the walk
has ended. The mission manager plans the next segment (is the take-off spot here? is the robot on the
ground?) from the link's telemetry as it is now. Here the samples are 10 s apart, which makes the lag
certain instead of occasional."""

from __future__ import annotations

import math

from console.link.manager import MissionStatus
from mav_helpers import config, events, mission_manager, vehicle
from planner.mission import Mission, MissionSegment, SegmentKind

WALK, TAKEOFF, FLY = SegmentKind.WALK, SegmentKind.TAKEOFF, SegmentKind.FLY


def test_the_next_segment_is_planned_from_where_the_walk_ended_not_from_a_stale_sample() -> None:
    with vehicle(config(state_rate=0.1)) as (link, emu):
        manager = mission_manager(link, failsafe_after=3.0, failsafe_hold=0.5)
        manager.start(Mission((MissionSegment(WALK, ((2.5, 0.7, 0.0), (2.5, 2.7, 0.0))),
                               MissionSegment(TAKEOFF, ((2.5, 2.7, 0.0), (2.5, 2.7, 1.5))),
                               MissionSegment(FLY, ((2.5, 2.7, 1.5), (2.5, 3.7, 1.5))))))
        assert manager.wait(60.0) is MissionStatus.DONE, events(manager)
        # it took off where the walk ended (2 m north of the origin), then flew on
        assert emu.record.takeoff_altitudes and math.dist(emu.pos[:2], (3.0, 0.0)) < 0.1, emu.pos
