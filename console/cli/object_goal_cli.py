"""``plan --goal-object ID_OR_LABEL``: a stop beside a named object (registered by :mod:`console.cli.morphonavi`).

``--goal-object`` values share the ``goal`` list with ``--goal`` so the stops keep the order in
which they were typed; :func:`resolve_stop` turns an object stop into the approach point chosen
by :func:`planner.object_goal.goal_beside` from where the route stands at that moment (world
frame [m]).
"""

from __future__ import annotations

from typing import Any, Sequence


class ObjectStop(str):
    """A ``--goal-object`` value: the id or label of an object."""


def object_stop(text: str) -> ObjectStop:
    """argparse ``type`` of ``--goal-object``."""
    import argparse

    if not text.strip():
        raise argparse.ArgumentTypeError("--goal-object: empty; give an object id or label, e.g. 'robot dog'")
    return ObjectStop(text.strip())


def resolve_stop(stop: Any, scene: Any, route: Any) -> Sequence[float]:
    """The goal point of one stop: a ``--goal`` point as is, a ``--goal-object`` beside its object.

    Prints which object was chosen and how it is reached; raises ``console.cli.errors.CliError`` when the
    object is unknown or cannot be reached.
    """
    if not isinstance(stop, ObjectStop):
        return stop
    from planner.object_goal import ObjectGoalError, goal_beside

    from console.cli.errors import CliError

    try:
        obj, app = goal_beside(scene, route.grid, str(stop), route.last_node(), route)
    except ObjectGoalError as exc:
        msg = str(exc).replace("widen the workspace to plan there", "widen the workspace with --bounds to plan there")
        raise CliError(f"--goal-object {str(stop)!r}: {msg}") from None
    how = {"walk": "by walking", "fly": "only by flying"}.get(app.mode, app.mode)
    g = app.goal
    print(f"goal object {str(stop)!r}: {obj.label} {obj.id!r}, stop at ({g[0]:.2f}, {g[1]:.2f}, {g[2]:.2f}) "
          f"{app.gap:.2f} m from it, reachable {how}")
    return g


__all__ = ["ObjectStop", "object_stop", "resolve_stop"]
