"""Routes land only where a mission may land: the A*'s ``no_land`` gate (no move from the air down into a
refused floor cell; walking through it and taking off from it stay allowed) against the plain Dijkstra,
with the layer-aware heuristic too; and the refusal that names the landing when only refused landings
lead to the goal."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.scene import SceneObject
from planner.astar import AStarSearcher, astar, dijkstra_reference
from planner.grid import Workspace, build_grid
from planner.landing_spot import no_landing
from planner.no_path import no_path_text


def _lands_on(path: np.ndarray, gate: np.ndarray) -> bool:
    return any(a[2] > 0 and b[2] == 0 and gate[b[0], b[1]] for a, b in zip(path[:-1], path[1:]))


@pytest.mark.parametrize("seed", range(12))
@pytest.mark.parametrize("budget", [None, 0])
def test_the_gate_matches_dijkstra_and_no_path_lands_on_a_refused_cell(seed: int, budget: int | None) -> None:
    rng = np.random.default_rng(seed)
    cost = np.ones((9, 8, 4))
    cost[:, :, 1:] = 4.0
    cost[:, 3:5, 0] = np.inf  # a wall on the ground: the robot must fly over it
    cost[rng.random(cost.shape) < 0.15] = np.inf
    cost[0, 0, 0] = cost[8, 7, 0] = 1.0
    gate = rng.random((9, 8)) < 0.5
    gate[8, 7] = bool(seed % 2)  # the goal itself refused for a landing in half the cases: walk in
    a = AStarSearcher().search(cost, (0, 0, 0), (8, 7, 0), no_corner_cutting=True, no_land=gate, layer_budget=budget)
    b = dijkstra_reference(cost, (0, 0, 0), (8, 7, 0), no_corner_cutting=True, no_land=gate)
    assert a.found == b.found
    if a.found:
        assert a.cost == pytest.approx(b.cost, rel=1e-12)
        assert not _lands_on(a.path, gate)
    free = astar(cost, (0, 0, 0), (8, 7, 0), no_corner_cutting=True)
    assert free.found >= a.found and (not a.found or free.cost <= a.cost + 1e-9)


def test_an_empty_gate_is_the_plain_search_and_a_wrong_shape_is_named() -> None:
    cost = np.ones((5, 5, 3))
    plain = astar(cost, (0, 0, 0), (4, 4, 2))
    gated = astar(cost, (0, 0, 0), (4, 4, 2), no_land=np.zeros((5, 5), dtype=bool))
    assert gated.cost == plain.cost and np.array_equal(gated.path, plain.path)
    with pytest.raises(ValueError, match=r"no_land must be a bool array of the grid's plan shape \(5, 5\)"):
        astar(cost, (0, 0, 0), (4, 4, 2), no_land=np.zeros((5, 4), dtype=bool))


def test_the_refusal_names_the_landing_the_rule_refuses_and_why() -> None:
    ws = Workspace((0.0, 0.0, 0.0), (5.0, 8.0, 3.0), 0.25)
    box = SceneObject("cardboard_box-1", "cardboard_box", (2.5, 4.0, 0.25), (0.5, 0.5, 0.5), 0.0)
    grid = build_grid([box], ws, margin=0.35)
    gate = no_landing(grid)
    cell = ws.cell_of((2.5, 4.0 + 0.25 + 0.45, 0.0))  # 0.45 m from the box: walkable, in its danger band
    assert cell is not None and grid.state[cell[0], cell[1], 0] != 2 and gate[cell[0], cell[1]]
    path = np.array([[cell[0], cell[1], 2], [cell[0], cell[1], 1], [cell[0], cell[1], 0]], dtype=np.int64)

    class Found:
        found = True

    Found.path = path  # type: ignore[attr-defined]
    text = no_path_text(grid, (2.5, 6.0, 0.625), (2.5, 4.7, 0.0), Found())
    assert text.startswith("no path from (2.50, 6.00, 0.62) to (2.50, 4.70, 0.00): the only routes land at (2.62, 4.62)"
                           ", where the robot may not land: the landing spot (2.62, 4.62) is in the danger band"), text
    assert no_path_text(grid, (2.5, 6.0, 0.625), (2.5, 4.7, 0.0)).endswith("the goal is cut off by obstacles")
