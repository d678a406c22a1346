"""What a language-model agent proposes, waiting for the operator: the approval queue, rate-limited.

A :class:`Proposal` says what the agent wants done (``kind``, a one-line ``title``, the plan in
``details``) and why (the agent's own text, ``why``). It stays ``pending`` until an operator decides
in the console's approval panel (:mod:`console.views.approval_view`):

- **Approve** runs the proposal's action (given by the agent door, :mod:`console.mcp.door`); the
  proposal ends ``approved`` with the action's outcome, or ``failed`` with the reason the action
  was refused (e.g. the mission changed meanwhile);
- **Reject** ends it ``rejected``, with the operator's optional note for the agent.

A proposal the agent gives up on (its client went away) ends ``withdrawn``. Nothing in this
module moves the robot: only the action an operator approves does.

Flooding is refused, naming the limit: at most :data:`MAX_PENDING` proposals wait at once and at
most :data:`RATE_LIMIT` are made per :data:`RATE_WINDOW` seconds.
"""

from __future__ import annotations

import threading
import time
import uuid
from collections import deque
from dataclasses import dataclass, replace
from typing import Any, Callable

MAX_PENDING = 3
"""Proposals that may wait for the operator at once."""
RATE_LIMIT = 6
"""Proposals an agent may make per :data:`RATE_WINDOW`."""
RATE_WINDOW = 60.0
"""The rate limit's sliding window [s]."""
KEEP_DECIDED = 20
"""Decided proposals kept for the panel's history and for late waiters."""
STATES = ("pending", "deciding", "approved", "rejected", "failed", "withdrawn")


class ProposalError(ValueError):
    """A proposal refused before it reaches the operator (rate limit, unknown id); the message says why."""


@dataclass(frozen=True)
class Proposal:
    """One proposal (immutable snapshot; the queue replaces it when it changes).

    Attributes:
        id: Short unique id (``p-1a2b3c``).
        kind: What it does: ``mission``, ``capture`` (capture and map) ...
        title: One line for the panel (``Execute mission m-12ab: walk → take-off → fly → land``).
        why: The agent's reason, as the agent wrote it.
        details: What exactly would happen (segments, lengths), for the operator.
        created: When it was made [s, ``time.time()``].
        state: ``pending``, ``deciding`` (approved, its action running), ``approved``, ``rejected``,
            ``failed`` (approved, but the action was refused) or ``withdrawn``.
        outcome: What happened, for the agent and the operator (empty while pending).
        note: The operator's note when deciding (optional).
    """

    id: str
    kind: str
    title: str
    why: str
    details: str = ""
    created: float = 0.0
    state: str = "pending"
    outcome: str = ""
    note: str = ""

    @property
    def decided(self) -> bool:
        """Whether the operator's decision is final (``deciding``: an approved action is being carried out)."""
        return self.state not in ("pending", "deciding")

    def to_dict(self) -> dict[str, Any]:
        return {"id": self.id, "kind": self.kind, "title": self.title, "why": self.why, "details": self.details,
                "created": self.created, "state": self.state, "outcome": self.outcome, "note": self.note}


Listener = Callable[[str, Proposal], None]
"""Called with ``("proposed" | "decided", proposal)`` after every change (outside the queue's lock)."""


class ProposalQueue:
    """The proposals waiting for the operator and the last ones decided; thread-safe, observable.

    Args:
        max_pending: Proposals that may wait at once.
        rate_limit: Proposals allowed per ``rate_window`` [s].
        rate_window: The sliding window [s].
        clock: Monotonic clock [s] (tests).
    """

    def __init__(self, max_pending: int = MAX_PENDING, rate_limit: int = RATE_LIMIT, rate_window: float = RATE_WINDOW,
                 clock: Callable[[], float] = time.monotonic) -> None:
        for name, v in (("max_pending", max_pending), ("rate_limit", rate_limit)):
            if not (isinstance(v, int) and v >= 1):
                raise ValueError(f"{name}: must be a whole number >= 1, got {v!r}")
        if not (isinstance(rate_window, (int, float)) and 0 < rate_window < 1e6):
            raise ValueError(f"rate_window: must be within 0..1e6 s, got {rate_window!r}")
        self.max_pending, self.rate_limit, self.rate_window = max_pending, rate_limit, float(rate_window)
        self._clock = clock
        self._cond = threading.Condition()
        self._items: dict[str, Proposal] = {}  # pending and recently decided, in creation order
        self._actions: dict[str, Callable[[], str]] = {}
        self._made: deque[float] = deque()
        self._listeners: list[Listener] = []

    # --- observers ---------------------------------------------------------------------------------
    def subscribe(self, listener: Listener) -> Callable[[], None]:
        """Call ``listener(event, proposal)`` after every change; returns the unsubscribe function."""
        with self._cond:
            self._listeners.append(listener)

        def unsubscribe() -> None:
            with self._cond:
                if listener in self._listeners:
                    self._listeners.remove(listener)

        return unsubscribe

    def _tell(self, event: str, proposal: Proposal) -> None:
        with self._cond:
            listeners = list(self._listeners)
        for listener in listeners:
            try:
                listener(event, proposal)
            except Exception:  # a broken panel must not break the queue
                import logging

                logging.getLogger(__name__).exception("proposal listener failed")

    # --- reading -------------------------------------------------------------------------------------
    def get(self, proposal_id: str) -> Proposal:
        with self._cond:
            p = self._items.get(proposal_id)
        if p is None:
            raise ProposalError(f"proposal_id: no proposal {proposal_id!r} (unknown, or decided long ago)")
        return p

    def pending(self) -> list[Proposal]:
        """The proposals waiting for the operator, oldest first."""
        with self._cond:
            return [p for p in self._items.values() if p.state == "pending"]

    def decided(self) -> list[Proposal]:
        """The last proposals decided, oldest first."""
        with self._cond:
            return [p for p in self._items.values() if p.decided]

    # --- the agent's side -----------------------------------------------------------------------------
    def propose(self, kind: str, title: str, why: str, action: Callable[[], str], details: str = "") -> Proposal:
        """Queue a proposal whose ``action`` (returning the outcome text, raising with the reason)
        runs if an operator approves it. Raises :class:`ProposalError` when flooding."""
        with self._cond:
            now = self._clock()
            while self._made and now - self._made[0] >= self.rate_window:
                self._made.popleft()
            waiting = sum(1 for p in self._items.values() if p.state == "pending")
            if waiting >= self.max_pending:
                raise ProposalError(f"rate limited: {waiting} proposals already wait for the operator (at most "
                                    f"{self.max_pending}); wait for a decision before proposing more")
            if len(self._made) >= self.rate_limit:
                again = self.rate_window - (now - self._made[0])
                raise ProposalError(f"rate limited: at most {self.rate_limit} proposals per {self.rate_window:.0f} s; "
                                    f"try again in {max(1, round(again))} s")
            self._made.append(now)
            p = Proposal(f"p-{uuid.uuid4().hex[:6]}", kind, title, why, details, time.time())
            self._items[p.id] = p
            self._actions[p.id] = action
            self._trim_locked()
            self._cond.notify_all()
        self._tell("proposed", p)
        return p

    def wait(self, proposal_id: str, timeout: float) -> Proposal:
        """Block until the proposal is decided or ``timeout`` [s] passes; returns it as it then is."""
        end = time.monotonic() + max(0.0, float(timeout))
        with self._cond:
            while True:
                p = self._items.get(proposal_id)
                if p is None:
                    raise ProposalError(f"proposal_id: no proposal {proposal_id!r} (unknown, or decided long ago)")
                left = end - time.monotonic()
                if p.decided or left <= 0:
                    return p
                self._cond.wait(left)

    def withdraw(self, proposal_id: str, why: str) -> Proposal:
        """The agent gives up on a pending proposal (its client went away); decided ones stay as they are."""
        return self._finish(proposal_id, "withdrawn", f"withdrawn: {why}", "")

    # --- the operator's side ------------------------------------------------------------------------------
    def approve(self, proposal_id: str, note: str = "") -> Proposal:
        """Run the proposal's action (on the caller's thread) and record its outcome."""
        with self._cond:
            p = self._items.get(proposal_id)
            if p is None or p.decided:
                return self._decided_or_unknown(proposal_id, p)
            self._items[p.id] = replace(p, state="deciding")  # a second click does not run it twice
            action = self._actions.pop(p.id, None)
        try:
            outcome = action() if action is not None else "approved"
            state = "approved"
        except Exception as exc:  # the action refused (mission changed, robot busy ...): say why
            outcome, state = f"approved, but not carried out: {exc}", "failed"
        with self._cond:
            self._items[p.id] = p = replace(p, state=state, outcome=outcome, note=note)
            self._trim_locked()
            self._cond.notify_all()
        self._tell("decided", p)
        return p

    def reject(self, proposal_id: str, note: str = "") -> Proposal:
        """Refuse the proposal (nothing runs); ``note`` is passed to the agent."""
        text = "rejected by the operator" + (f": {note}" if note else "")
        return self._finish(proposal_id, "rejected", text, note)

    def _finish(self, proposal_id: str, state: str, outcome: str, note: str) -> Proposal:
        with self._cond:
            p = self._items.get(proposal_id)
            if p is None or p.decided:
                return self._decided_or_unknown(proposal_id, p)
            self._actions.pop(p.id, None)
            self._items[p.id] = p = replace(p, state=state, outcome=outcome, note=note)
            self._cond.notify_all()
        self._tell("decided", p)
        return p

    @staticmethod
    def _decided_or_unknown(proposal_id: str, p: Proposal | None) -> Proposal:
        if p is None:
            raise ProposalError(f"proposal_id: no proposal {proposal_id!r} (unknown, or decided long ago)")
        if p.state == "deciding":
            raise ProposalError(f"proposal {proposal_id} is being carried out")
        raise ProposalError(f"proposal {proposal_id} was already decided: {p.state}")

    def _trim_locked(self) -> None:
        done = [k for k, p in self._items.items() if p.decided]
        for k in done[:-KEEP_DECIDED] if len(done) > KEEP_DECIDED else []:
            del self._items[k]


__all__ = ["KEEP_DECIDED", "MAX_PENDING", "RATE_LIMIT", "RATE_WINDOW", "Proposal", "ProposalError", "ProposalQueue"]
