"""What the session announces to its listeners: the topic names and the listener signature.

Every change is announced as ``(topic, payload)``; the payload type is given in brackets.
"""

from __future__ import annotations

from typing import Any, Callable

# Topics announced to listeners (payload in brackets).
SCENE = "scene"  # scene objects changed [None]
GRID = "grid"  # planning grid rebuilt [None]
ROUTE = "route"  # candidate / registered path changed [None]
MISSION = "mission"  # mission built or cleared [None]
RUN = "run"  # mission execution status [RunStatus]
CAPTURE = "capture"  # new last capture [CaptureRecord]
ROBOT = "robot"  # live robot state [RobotSnapshot]
JOB = "job"  # background job progress [JobStatus]
SELECTION = "selection"  # selected object changed [str | None]
SETTINGS = "settings"  # goal mode / altitude / layers changed [None]
NOTICE = "notice"  # message for every operator [Notice]
AGENT = "agent"  # a language-model agent's tool call, proposal or the operator's decision (console.mcp) [dict]
SEARCH = "search"  # a search step or its end (console.session.search_report) [dict]

Listener = Callable[[str, Any], None]
