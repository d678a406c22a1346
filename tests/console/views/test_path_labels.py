"""The mission's spot labels (console/views/paths_view.py): one per take-off or landing spot, numbered as the
segment list, spots closer than SPOT_MERGE_M sharing one label, hung below the spot for the declutter."""

from __future__ import annotations

from types import SimpleNamespace

from planner.mission import SegmentKind

from console.views.paths_view import SPOT_MERGE_M, spot_labels


def _seg(kind: SegmentKind, spot: tuple[float, float, float]) -> SimpleNamespace:
    return SimpleNamespace(kind=kind, spot=spot)


def test_take_off_and_landing_at_one_spot_share_a_label() -> None:
    segs = [_seg(SegmentKind.WALK, (0.0, 0.0, 0.0)), _seg(SegmentKind.TAKEOFF, (1.0, 1.0, 0.0)),
            _seg(SegmentKind.FLY, (0.0, 0.0, 0.0)), _seg(SegmentKind.LAND, (3.0, 1.0, 0.0)),
            _seg(SegmentKind.TAKEOFF, (3.0 + SPOT_MERGE_M / 2, 1.0, 0.0)), _seg(SegmentKind.LAND, (1.0, 1.0, 0.0))]
    labels = spot_labels(segs)
    assert [s.text for s in labels] == ["2. take-off · 6. land", "4. land · 5. take-off"]
    assert labels[0].position == (1.0, 1.0, 0.05) and labels[0].anchor == "top-center"
    assert spot_labels(segs[:1]) == []
