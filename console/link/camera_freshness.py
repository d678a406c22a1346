"""Is a live camera still showing the world? Frames that keep arriving but stop changing are stale.

A stream can freeze while frames keep coming: an MJPEG server re-sending its last JPEG, an RTSP
relay repeating the last decoded picture, a capture card holding its buffer, a file of one still.
The arrival clock then says "live, last frame 0.0 s ago" while the picture is seconds old. Two
checks decide, per frame:

- **Content**: a frame whose pixels equal the previous frame's (same BLAKE2 hash of the bytes, or
  a mean absolute difference under ``still_level`` grey levels on a strided sample: a real sensor's
  noise alone gives 1-3 levels) is *the same frame*.
- **Timestamps**: a source that stamps its frames (OpenCV ``CAP_PROP_POS_MSEC``: RTSP / file
  presentation times) and repeats one stamp is re-delivering one frame, whatever the pixels.

Either condition lasting ``stale_after`` seconds makes the camera stale; the first changed frame
(new content and, where stamped, a new stamp) makes it fresh again. Times are ``time.monotonic()``
seconds; stamps are the source's milliseconds.
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass

import numpy as np

STALE_AFTER_S = 2.0
"""Default: the same frame (or stamp) for this long [s] makes a camera stale."""

STILL_LEVEL = 0.25
"""Default: mean absolute difference [grey levels, 0-255] under which two frames count as the same."""


@dataclass(frozen=True)
class Freshness:
    """The verdict on the newest frame.

    Attributes:
        stale: Whether the camera shows a frozen picture.
        same_for: How long [s] the picture (or the stamp) has not changed; 0 when it just changed.
        reason: ``same frame`` or ``timestamp stuck`` while stale, else ``""``.
        stamp_ms: The stuck stamp [ms] when ``reason`` is ``timestamp stuck``.
        proven: Whether the picture has changed at least once since the source started (a stream
            that has only ever shown one picture is not yet known to be live).
        changed: Whether the newest frame differs from the one before it: only such a frame is known
            to be new (a frame equal to its predecessor may be the first of a freeze).
    """

    stale: bool
    same_for: float = 0.0
    reason: str = ""
    stamp_ms: float | None = None
    proven: bool = True
    changed: bool = True

    def describe(self) -> str:
        """The operator's words: ``camera stale: the same frame for 4.2 s`` ("" when fresh)."""
        if not self.stale:
            return ""
        if self.reason == "timestamp stuck" and self.stamp_ms is not None:
            return (f"camera stale: the stream's timestamp stuck at {self.stamp_ms / 1000.0:.3f} s for "
                    f"{self.same_for:.1f} s")
        return f"camera stale: the same frame for {self.same_for:.1f} s"


def _signature(frame: np.ndarray) -> bytes:
    return hashlib.blake2b(np.ascontiguousarray(frame).tobytes(), digest_size=16).digest()


def _sample(frame: np.ndarray) -> np.ndarray:
    """Every 4th pixel of every 4th row (all channels), as int16: enough to measure a difference."""
    return np.asarray(frame[::4, ::4], dtype=np.int16)


class FreshnessTracker:
    """Feeds on every frame (:meth:`update`) and tells whether the picture is frozen.

    Args:
        stale_after: The same frame or stamp for this long [s] is stale; > 0 and finite.
        still_level: Mean absolute difference [grey levels] under which two frames are the same; >= 0.

    Raises:
        ValueError: A bad argument (named).
    """

    def __init__(self, stale_after: float = STALE_AFTER_S, still_level: float = STILL_LEVEL) -> None:
        if not (isinstance(stale_after, (int, float)) and math.isfinite(stale_after) and stale_after > 0):
            raise ValueError(f"stale_after: must be a finite number of seconds > 0, got {stale_after!r}")
        if not (isinstance(still_level, (int, float)) and math.isfinite(still_level) and still_level >= 0):
            raise ValueError(f"still_level: must be a finite number of grey levels >= 0, got {still_level!r}")
        self.stale_after = float(stale_after)
        self.still_level = float(still_level)
        self._sig: bytes | None = None
        self._sample: np.ndarray | None = None
        self._content_since: float | None = None  # arrival of the first frame of the current picture
        self._stamp: float | None = None
        self._stamp_since: float | None = None
        self._stamps_move = False  # the source has shown advancing stamps (else stamps are not judged)
        self._last: float | None = None  # arrival of the newest frame
        self._changed = False  # the picture has changed at least once
        self._new = False  # the newest frame differs from the one before it

    def same_picture(self, frame: np.ndarray) -> bool:
        """Whether ``frame`` shows the same picture as the previous one (does not update)."""
        if self._sig is None or self._sample is None:
            return False
        if _signature(frame) == self._sig:
            return True
        sample = _sample(frame)
        if sample.shape != self._sample.shape:
            return False
        return float(np.mean(np.abs(sample - self._sample))) < self.still_level

    def update(self, frame: np.ndarray, now: float, stamp_ms: float | None = None) -> Freshness:
        """Record a frame that arrived at ``now`` [s, monotonic] with the source's stamp [ms] (``None``
        or <= 0 when the source gives none) and return the verdict at that moment."""
        self._new = not self.same_picture(frame) and self._sig is not None
        if not self.same_picture(frame):
            if self._sig is not None:
                self._changed = True
            self._content_since = now
        self._sig, self._sample = _signature(frame), _sample(frame)
        self._last = now
        if stamp_ms is not None and math.isfinite(stamp_ms) and stamp_ms > 0:
            if self._stamp is None or stamp_ms != self._stamp:
                if self._stamp is not None:
                    self._stamps_move = True
                self._stamp, self._stamp_since = float(stamp_ms), now
        return self.verdict()

    def verdict(self) -> Freshness:
        """The verdict from the frames received so far: spans are measured up to the newest frame's
        arrival (no frame at all for a while is a lost stream, the source's other check)."""
        if self._content_since is None or self._last is None:
            return Freshness(False)
        same = self._last - self._content_since
        if same >= self.stale_after:
            return Freshness(True, same, "same frame", proven=self._changed, changed=self._new)
        if self._stamps_move and self._stamp_since is not None and self._last - self._stamp_since >= self.stale_after:
            return Freshness(True, self._last - self._stamp_since, "timestamp stuck", self._stamp, self._changed,
                             self._new)
        return Freshness(False, same, proven=self._changed, changed=self._new)

    def reset(self) -> None:
        """Forget the frames seen (a reconnected stream starts fresh)."""
        self.__init__(self.stale_after, self.still_level)  # type: ignore[misc]


__all__ = ["Freshness", "FreshnessTracker", "STALE_AFTER_S", "STILL_LEVEL"]
