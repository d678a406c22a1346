"""The table of proxy-model builders by name (the model file stem), and the fallback box.

A builder is ``fn(parts, w, h, l)`` laying out :class:`~assets.proxy_builders.parts.Parts` at the
class's size [m]: x in [-l/2, l/2] (front +x), y in [-w/2, w/2], z in [0, h]. Families register
theirs with ``@builder("name", ...)``; :mod:`assets.proxy_builders` imports them all.
"""

from __future__ import annotations

from collections.abc import Callable

from .parts import Parts

Builder = Callable[[Parts, float, float, float], None]
BUILDERS: dict[str, Builder] = {}
NOMINAL_SIZES: dict[str, tuple[float, float, float]] = {
    "rock": (1.0, 0.6, 1.2),
    "debris_pile": (1.6, 0.7, 2.0),
    "unknown_object": (0.6, 0.5, 0.8),
}
"""``(w, h, l)`` [m] a class of unknown size is built at, by builder name."""
DEFAULT_NOMINAL_SIZE = (0.5, 0.5, 0.5)
"""``(w, h, l)`` [m] to build a class of unknown size that has no entry in NOMINAL_SIZES."""


def builder(*names: str) -> Callable[[Builder], Builder]:
    """Decorator: register the builder under each of ``names``."""
    def register(fn: Builder) -> Builder:
        for n in names:
            BUILDERS[n] = fn
        return fn

    return register


@builder("box")
def box(p: Parts, w: float, h: float, l: float) -> None:
    """The fallback (and ``box.glb``): a box with darker edges, for classes without a builder."""
    p.block((-l / 2, -w / 2, 0), (l / 2, w / 2, h), 0.15)
    e = 0.03 * min(w, h, l)
    for y in (-w / 2, w / 2):
        for z in (0, h):
            p.block((-l / 2, y - e, z - e), (l / 2, y + e, z + e), -0.45)
    for x in (-l / 2, l / 2):
        for z in (0, h):
            p.block((x - e, -w / 2, z - e), (x + e, w / 2, z + e), -0.45)
        for y in (-w / 2, w / 2):
            p.block((x - e, y - e, 0), (x + e, y + e, h), -0.45)
