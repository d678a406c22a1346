"""The object an agent names, followed through map fusion, as the console's own picks are.

Map fusion may merge an object into an older one of its class (one object mapped twice) or remove one that
later captures should have seen and did not; the session remembers both
(:mod:`console.session.object_follow`). An agent that read ``list_objects`` before such a change and then asks
for ``office_chair-2`` gets the object that id became, never a "not reachable" for an object that is still
there under another id.
"""

from __future__ import annotations

from typing import Any


class ObjectGone(ValueError):
    """The named object was removed from the map; the message says why."""


def followed_object(session: Any, name: str) -> tuple[str, str]:
    """``(what to plan to, note)`` for the object ``name`` (an id or a label) an agent asked for.

    An id or a label in the map now is itself (note ``""``). An id that map fusion merged away is the id of
    the object it was merged into, followed through later merges by the session's
    :meth:`~console.session.object_follow.ObjectFollow.resolve_object` (the same function the console's
    selection and Go to use), with a note naming both (``office_chair-2 was merged into office_chair-1``).
    Any other name is returned unchanged: :func:`planner.object_goal.goal_beside` refuses it, listing the
    labels the map holds.

    Raises:
        ObjectGone: ``name`` (or the object it was merged into) was removed from the map; the message
            names it and says why.
    """
    from planner.object_goal import ObjectGoalError, find_object

    from console.session.object_follow import RemovedObject, UnknownObject

    try:
        find_object(session.scene, name)
        return name, ""
    except ObjectGoalError:
        pass
    resolve = getattr(session, "resolve_object", None)
    if resolve is None:
        return name, ""
    try:
        oid = resolve(name)
    except UnknownObject:  # never in the map: goal_beside says what the map holds
        return name, ""
    except RemovedObject as exc:
        text = str(exc)
        raise ObjectGone(text if text.startswith(f"{name} ") else f"{name} left the map: {text}") from None
    return oid, (f"{name} was merged into {oid} (one object mapped twice)" if oid != name else "")


__all__ = ["ObjectGone", "followed_object"]
