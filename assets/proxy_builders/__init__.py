"""The proxy-model builders, one module per object family, registered by name in :data:`BUILDERS`.

- :mod:`~assets.proxy_builders.parts`: :class:`Parts` (coloured primitives -> one mesh), the
  neutral accent colours and :func:`normalize` (bounding box exactly ``[-0.5, 0.5]^3``);
- :mod:`~assets.proxy_builders.registry`: :data:`BUILDERS`, :data:`NOMINAL_SIZES`, the
  ``@builder`` decorator and the fallback box;
- the families: :mod:`~assets.proxy_builders.furniture`, :mod:`~assets.proxy_builders.room_objects`,
  :mod:`~assets.proxy_builders.outdoor`, :mod:`~assets.proxy_builders.vehicles` (importing this
  package registers them all).

``python -m assets.make_proxy_models`` reads the catalog and writes the ``.glb`` files.
"""

from __future__ import annotations

from . import furniture, outdoor, room_objects, vehicles  # noqa: F401  (registers the builders)
from .parts import RGB, Parts, normalize
from .registry import BUILDERS, DEFAULT_NOMINAL_SIZE, NOMINAL_SIZES, Builder, box, builder

__all__ = ["BUILDERS", "NOMINAL_SIZES", "DEFAULT_NOMINAL_SIZE", "RGB", "Builder", "Parts", "box", "builder",
           "normalize"]
