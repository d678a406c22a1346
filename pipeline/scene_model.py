"""The scene's data classes (objects, their provenance and sightings, captures) and its field errors.

Imported by :mod:`pipeline.scene_json` (the JSON form) and re-exported by :mod:`pipeline.scene` (which
adds reading and writing files); use ``pipeline.scene`` everywhere else. Frames, units and the
``size`` order ``(w, h, l)`` are described in :mod:`pipeline.scene`.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Literal, Mapping, Sequence

SCENE_VERSION = 1
"""Version written into every scene file; files with a newer version are rejected."""

Frame = Literal["camera", "robot", "world"]
FRAMES: tuple[Frame, ...] = ("camera", "robot", "world")

Vec3 = tuple[float, float, float]


class SceneError(ValueError):
    """A scene file or dict is malformed; ``field`` names the offending field path."""

    def __init__(self, field: str, message: str) -> None:
        self.field = field
        super().__init__(f"{field}: {message}" if field else message)


@dataclass(frozen=True)
class Source:
    """Where an object came from and how its position was estimated.

    Attributes:
        capture: Id of the capture (photo) the object was mapped from, ``None`` if manual.
        method: Estimate that produced the position: ``fused`` (size prior + depth),
            ``geometric`` (size prior only), ``depth`` (depth map only), ``manual``,
            ``ground_truth`` or ``demo``.
        bbox: 2D box ``(x1, y1, x2, y2)`` [px] in the capture's image.
        mask_area: Segmentation mask area [px].
        distances: Distance estimates along the optical axis [m], keyed ``geometric``,
            ``depth`` and ``fused``, and ``ground_contact`` (the floor under the box bottom) or
            ``ground_contact_bound`` (that reading taken only as an upper bound: a nearer object may
            hide the contact) (``None`` where not available).
        positions: The object's centre in the other frames, keyed by frame name [m].
        down_weighted: Why distance cues were trusted less than usual, ``(cue, why)`` pairs (``cue``:
            ``size_prior``, ``ground_contact``, ``depth`` or ``fused``; :mod:`pipeline.ranging.reasons`).
    """

    capture: str | None = None
    method: str = "manual"
    bbox: tuple[float, float, float, float] | None = None
    mask_area: int | None = None
    distances: Mapping[str, float | None] = field(default_factory=dict)
    positions: Mapping[str, Vec3] = field(default_factory=dict)
    down_weighted: tuple[tuple[str, str], ...] = ()


@dataclass(frozen=True)
class Sighting:
    """One observation of an object by a capture, as the map fusion weighed it (world frame).

    Attributes:
        capture: Id of the capture that saw it (``None``: the object as it was before fusion kept
            history, e.g. loaded from a file).
        position: The observation's box centre [m].
        yaw: Its heading of the length axis about +z [rad].
        size: Its ``(w, h, l)`` [m].
        sigma: 1-sigma errors ``(along the camera ray [m], across it [m], yaw [rad])``.
        camera: Camera centre at capture [m], ``None`` if unknown (then ``sigma`` is isotropic).
        distance: Camera-to-object-centre distance [m], ``None`` if unknown.
        used: Whether it moved the object (``False``: rejected, or the object is pinned).
        note: Why not used, or what was corrected.
    """

    capture: str | None
    position: Vec3
    yaw: float
    size: Vec3
    sigma: Vec3
    camera: Vec3 | None = None
    distance: float | None = None
    used: bool = True
    note: str = ""


@dataclass(frozen=True)
class SceneObject:
    """One object: an oriented box with a label.

    Attributes:
        id: Unique id within the scene.
        label: Catalog class name (e.g. ``office_chair``).
        position: Box centre [m] in ``frame``.
        size: ``(w, h, l)`` full extents [m]; ``h`` vertical.
        yaw: Heading of the length axis about the frame's vertical axis [rad].
        frame: Frame of ``position`` and ``yaw``.
        score: Detector confidence in [0, 1] (1 for manual or ground-truth objects).
        size_known: Whether ``size`` comes from the catalog (True) or was measured/guessed.
        source: Provenance of the estimate.
        pinned: The operator moved, typed or confirmed it: observations never move it (see
            :attr:`is_pinned`, which also counts ``source.method == "manual"``).
        history: The observations fused into it, oldest first (see :mod:`pipeline.mapping.map_fusion`).
        flags: Corrections made by the map fusion, for the operator (``set on the floor: ...``).
        sigma: The mapper's 1-sigma [m] of the centre along the camera ray (inverse-variance fusion of
            its distance cues, :mod:`pipeline.ranging.fusion`), ``None`` when not estimated.
        cut: Sides of the 2D box the image border cuts (``left``, ``top``, ``right``, ``bottom``).
    """

    id: str
    label: str
    position: Vec3
    size: Vec3
    yaw: float = 0.0
    frame: Frame = "world"
    score: float = 1.0
    size_known: bool = True
    source: Source = field(default_factory=Source)
    pinned: bool = False
    history: tuple[Sighting, ...] = ()
    flags: tuple[str, ...] = ()
    sigma: float | None = None
    cut: tuple[str, ...] = ()

    @property
    def is_pinned(self) -> bool:
        """Placed, moved or confirmed by the operator: the map fusion never moves it."""
        return self.pinned or self.source.method == "manual"

    def moved(self, position: Vec3, yaw: float | None = None) -> "SceneObject":
        """A copy at a new position (and optionally heading), marked as manually placed."""
        return replace(
            self,
            position=position,
            yaw=self.yaw if yaw is None else yaw,
            source=replace(self.source, method="manual"),
        )


@dataclass(frozen=True)
class Capture:
    """One photo the scene was mapped from.

    Attributes:
        id: Unique id within the scene.
        timestamp: Capture time [s since the Unix epoch].
        image: Image file name (relative to the scene file) or ``None``.
        intrinsics: ``fx, fy, cx, cy`` [px] and ``width, height`` [px].
        robot_pose: Robot pose at capture in the world frame: ``x, y, z`` [m], ``yaw`` [rad].
        camera_position: Camera centre in the world frame [m].
        camera_quaternion: Camera-to-world rotation as quaternion ``(x, y, z, w)``.
        timings: Per-stage wall time [s] (``detect``, ``segment``, ``depth``, ``total`` ...).
        models: Names of the models used, keyed by stage.
    """

    id: str
    timestamp: float = 0.0
    image: str | None = None
    intrinsics: Mapping[str, float] = field(default_factory=dict)
    robot_pose: Mapping[str, float] = field(default_factory=dict)
    camera_position: Vec3 | None = None
    camera_quaternion: tuple[float, float, float, float] | None = None
    timings: Mapping[str, float] = field(default_factory=dict)
    models: Mapping[str, str] = field(default_factory=dict)


@dataclass(frozen=True)
class Scene:
    """A set of objects and the captures they were mapped from (read and written by :mod:`pipeline.scene`:
    ``load_scene``, ``save_scene``, ``scene_to_dict``)."""

    objects: tuple[SceneObject, ...] = ()
    captures: tuple[Capture, ...] = ()
    version: int = SCENE_VERSION
    last_ids: Mapping[str, int] = field(default_factory=dict)
    """Highest number each class's ids have had (``{"cardboard_box": 7}`` once ``cardboard_box-7`` was
    mapped), kept after the object is merged or removed: the map fusion numbers new objects above it,
    so an id is never given to another object (:func:`pipeline.mapping.map_extent.next_id`)."""

    def __post_init__(self) -> None:
        ids = [o.id for o in self.objects]
        if len(set(ids)) != len(ids):
            dup = next(i for i in ids if ids.count(i) > 1)
            raise SceneError("objects", f"duplicate object id {dup!r}")

    def object(self, object_id: str) -> SceneObject:
        """The object with this id (KeyError if absent)."""
        for obj in self.objects:
            if obj.id == object_id:
                return obj
        raise KeyError(object_id)

    def with_objects(self, objects: Sequence[SceneObject]) -> "Scene":
        """A copy holding ``objects`` instead."""
        return replace(self, objects=tuple(objects))
