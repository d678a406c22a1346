"""MAVLink link quality: duplicates dropped, loss from sequence gaps, latency, message rates, signing.

:class:`LinkQuality` sees every packet of the vehicle before it is used (on the receive thread):

- **duplicates**: a packet whose (system, component, ``seq``, message id, checksum) was received in the
  last ``dup_window`` seconds, less than one ``seq`` wrap (250 packets of that source) ago, is an
  exact copy (two telemetry links, a radio's retransmission): it is
  dropped and counted, so a late copy never looks like new telemetry or a reboot;
- **loss**: per (system, component) the MAVLink ``seq`` should count up by one; a forward gap of ``n``
  (``n < 128``) is ``n`` lost packets; loss is the fraction lost over the last ``window`` seconds;
- **latency**: round-trip time of TIMESYNC (``tc1 == 0`` requests answered by the vehicle) [s];
- **rates**: messages per second of each type over the window;
- **signing**: whether the vehicle's packets carry a MAVLink 2 signature (a vehicle that signs what it
  sends requires signed commands and ignores unsigned ones, ``GCS_Signing.cpp``), and how many
  packets failed our key's check.

The figure shown to the operator (:meth:`LinkQuality.summary`): ``"link 97 % (3 % lost, RTT 12 ms)"``.
Times are monotonic [s].
"""

from __future__ import annotations

import collections
import math
import threading
import time
from dataclasses import dataclass
from typing import Any

MAVLINK_IFLAG_SIGNED = 0x01
"""MAVLink 2 incompat flag: the packet carries a signature."""


@dataclass(frozen=True)
class QualityFigures:
    """One reading of the link's quality.

    Attributes:
        loss: Fraction of the vehicle's packets lost over the window, in [0, 1] (``None``: too few packets).
        rtt: TIMESYNC round-trip time [s], ``None`` before the first answer.
        rates: Messages per second by type over the window.
        duplicates: Exact copies dropped since the link opened.
        received: Packets of the vehicle over the window.
        signed: The vehicle signs its packets (MAVLink 2 signing).
    """

    loss: float | None
    rtt: float | None
    rates: dict[str, float]
    duplicates: int
    received: int
    signed: bool

    @property
    def quality(self) -> float | None:
        """1 - loss (``None`` when unknown)."""
        return None if self.loss is None else 1.0 - self.loss

    def summary(self) -> str:
        """``"link 97 % (3 % lost, RTT 12 ms)"``, or ``"link quality unknown"``."""
        if self.loss is None:
            return "link quality unknown (too few packets yet)"
        rtt = f", RTT {self.rtt * 1000:.0f} ms" if self.rtt is not None else ""
        return f"link {100 * (1 - self.loss):.0f} % ({100 * self.loss:.0f} % lost{rtt})"


class LinkQuality:
    """Per-packet bookkeeping of the vehicle's link (thread-safe).

    Args:
        window: Loss and rates are measured over this many seconds.
        dup_window: A copy arriving within this many seconds of the original is a duplicate [s].
    """

    def __init__(self, window: float = 5.0, dup_window: float = 5.0) -> None:
        self.window, self.dup_window = window, dup_window
        self._lock = threading.Lock()
        self._seen: dict[tuple[int, int, int, int, int], tuple[float, int]] = {}  # key -> (time, count)
        self._count: dict[tuple[int, int], int] = {}  # accepted packets per source
        self._seen_order: collections.deque[tuple[float, tuple[int, int, int, int, int]]] = collections.deque()
        self._last_seq: dict[tuple[int, int], int] = {}
        self._events: collections.deque[tuple[float, int, int, str]] = collections.deque()  # (t, got, lost, type)
        self.duplicates = 0
        self.signed = False
        self.rtt: float | None = None
        self._rtt_samples: collections.deque[float] = collections.deque(maxlen=10)

    def accept(self, msg: Any, vehicle: tuple[int, int] | None) -> bool:
        """Record one packet; False if it is a duplicate to drop. Loss is counted for ``vehicle``'s
        (system, component) only (``None``: not known yet, nothing counted)."""
        header = getattr(msg, "_header", None)
        if header is None:
            return True
        now = time.monotonic()
        src = (int(header.srcSystem), int(header.srcComponent))
        key = (*src, int(header.seq), int(header.msgId), int(getattr(msg, "_crc", 0) or 0))
        with self._lock:
            self._expire(now)
            count = self._count.get(src, 0)
            seen = self._seen.get(key)
            if seen is not None and count - seen[1] < 250:  # same seq less than a wrap ago: a copy
                self.duplicates += 1
                return False
            self._count[src] = count + 1
            self._seen[key] = (now, count)
            self._seen_order.append((now, key))
            if src != vehicle:
                return True
            if int(getattr(header, "incompat_flags", 0)) & MAVLINK_IFLAG_SIGNED:
                self.signed = True
            lost = 0
            last = self._last_seq.get(src)
            if last is not None:
                gap = (int(header.seq) - last - 1) % 256
                if gap < 128:
                    lost = gap
                else:  # an older packet arriving late (reordered): not a loss, not new
                    self._events.append((now, 1, 0, msg.get_type()))
                    return True
            self._last_seq[src] = int(header.seq)
            self._events.append((now, 1, lost, msg.get_type()))
        return True

    def _expire(self, now: float) -> None:
        while self._seen_order and now - self._seen_order[0][0] > self.dup_window:
            _, k = self._seen_order.popleft()
            if self._seen.get(k, (math.inf, 0))[0] <= now - self.dup_window:
                del self._seen[k]
        while self._events and now - self._events[0][0] > self.window:
            self._events.popleft()

    def reset_sequence(self) -> None:
        """After a reboot / reconnect the vehicle's sequence starts again: no gap to count."""
        with self._lock:
            self._last_seq.clear()

    def timesync(self, msg: Any, sent: dict[int, float]) -> None:
        """A TIMESYNC answer (``tc1 != 0``) to one of our requests (``ts1`` -> monotonic [s] sent)."""
        if int(msg.tc1) == 0:
            return
        t0 = sent.pop(int(msg.ts1), None)
        if t0 is None:
            return
        with self._lock:
            self._rtt_samples.append(time.monotonic() - t0)
            self.rtt = sorted(self._rtt_samples)[len(self._rtt_samples) // 2]  # median: one late answer is not the link

    def figures(self) -> QualityFigures:
        now = time.monotonic()
        with self._lock:
            self._expire(now)
            got = sum(e[1] for e in self._events)
            lost = sum(e[2] for e in self._events)
            span = min(self.window, now - self._events[0][0]) if self._events else 0.0
            counts: dict[str, int] = {}
            for e in self._events:
                counts[e[3]] = counts.get(e[3], 0) + 1
            rates = {k: c / span for k, c in counts.items()} if span > 0.5 else {}
            loss = lost / (got + lost) if got + lost >= 20 else None
            return QualityFigures(loss, self.rtt, rates, self.duplicates, got, self.signed)


__all__ = ["LinkQuality", "QualityFigures", "MAVLINK_IFLAG_SIGNED"]
