"""What each mission and route button may do in each mission state: one table, used by the session
(which refuses with the reason) and by the views (which disable the button and show the reason).

Mission states are :class:`~console.session.session_types.RunStatus` states: ``idle`` (none run yet),
``running``, ``paused``, ``failsafe`` (the link was lost: holding or landing), and the ended
``done``, ``aborted``, ``failed``. While a mission is under way (running, paused or failsafe) the
route and the mission must not change under it: a new Build would show a new mission id while
Resume continues the old one, so Build, Execute and every route edit are off with the reason,
and only Pause (running), Resume (paused / failsafe) and Abort act on the mission under way. An
ended mission leaves the console as idle does (Resume has nothing to continue).

Other rules (robot state, readiness, battery, where the mission starts) are in
:mod:`console.session.operator_state`; this table only says what the mission state allows.
"""

from __future__ import annotations

STATES = ("idle", "running", "paused", "failsafe", "done", "aborted", "failed")
"""Every mission state, in the order the docs' table lists them."""

BUTTONS = ("plan", "register", "discard", "undo", "clear", "build", "execute", "replan", "add_landing",
           "pause", "resume", "abort")
"""Every button the table rules: the route edits (``plan`` is a goal click), the mission panel's."""

_DOING = {"plan": "planning a new goal", "register": "registering a path", "discard": "discarding the candidate",
          "undo": "removing a registered segment", "clear": "clearing the route",
          "build": "building a new mission", "execute": "executing another mission",
          "replan": "re-planning from the robot", "add_landing": "adding a landing"}
_UNDER_WAY = {"running": "a mission is running: pause or abort it",
              "paused": "a mission is paused: resume or abort it",
              "failsafe": "a failsafe is acting on the mission (link lost): wait for it, or abort the mission"}


def _row(state: str) -> dict[str, str | None]:
    row: dict[str, str | None] = {}
    for b in BUTTONS:
        if b in _DOING:
            row[b] = f"{_UNDER_WAY[state]} before {_DOING[b]}" if state in _UNDER_WAY else None
        elif b == "pause":
            row[b] = None if state == "running" else f"nothing to pause: {_state_text(state)}"
        elif b == "resume":
            row[b] = None if state in ("paused", "failsafe") else f"nothing to resume: {_state_text(state)}"
        else:  # abort
            row[b] = None if state in _UNDER_WAY else f"nothing to abort: {_state_text(state)}"
    if state == "paused":  # the one place where a new mission would silently replace the one Resume runs
        row["build"] = ("a mission is paused: resume or abort it before building a new one (Resume continues "
                        "the paused mission, not a new build)")
    return row


def _state_text(state: str) -> str:
    return {"idle": "no mission has run", "running": "the mission is running",
            "paused": "the mission is paused", "failsafe": "a failsafe is acting",
            "done": "the mission is done", "aborted": "the mission was aborted",
            "failed": "the mission failed"}.get(state, f"mission state {state}")


RULES: dict[str, dict[str, str | None]] = {s: _row(s) for s in STATES}
"""``RULES[state][button]``: ``None`` when the state allows the button, else why not (for the operator)."""


def blocker(button: str, state: str) -> str | None:
    """Why ``button`` may not act in mission ``state``, or ``None`` when the state allows it.

    Raises:
        ValueError: An unknown button or state (a programming error, named).
    """
    if button not in BUTTONS:
        raise ValueError(f"button: expected one of {', '.join(BUTTONS)}, got {button!r}")
    if state not in RULES:
        raise ValueError(f"state: expected one of {', '.join(STATES)}, got {state!r}")
    return RULES[state][button]


def allowed(button: str, state: str) -> bool:
    """Whether mission ``state`` allows ``button``."""
    return blocker(button, state) is None


def table_markdown() -> str:
    """The table as Markdown (for the docs): a row per state, a column per button, ``yes`` / ``-``."""
    head = "| state | " + " | ".join(BUTTONS) + " |"
    rule = "|---" * (len(BUTTONS) + 1) + "|"
    rows = [f"| {s} | " + " | ".join("yes" if RULES[s][b] is None else "-" for b in BUTTONS) + " |" for s in STATES]
    return "\n".join([head, rule, *rows])


__all__ = ["BUTTONS", "RULES", "STATES", "allowed", "blocker", "table_markdown"]
