"""The distance stage of the mapper: per-object cues, depth-scale fitting, fusion and the centre.

For each detection :class:`Ranger` measures what does not need the depth scale (truncation by the
image border, the size-prior estimate, the floor contact, the depth-map reading), fits the depth
map's scale from the objects whose distance the other cues give, then fuses the cues of every object
and places its centre (camera frame, OpenCV: x right, y down, z forward) [m].

Fusion modes (:attr:`MapperConfig.fusion`): ``sigma`` (default): every cue returns a distance and a
sigma (:mod:`pipeline.ranging.size_prior`, :mod:`pipeline.ranging.ground_contact`, the depth map) and
:func:`pipeline.ranging.fusion.fuse_cues` combines them by inverse variance with outlier rejection; ``fixed``
and ``adaptive``: the former size prior + depth weights (:func:`pipeline.ranging.distance.fuse_distances`),
kept to reproduce the README's step table.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

from pipeline.catalog import Catalog, CatalogEntry
from pipeline.ranging.distance import (
    IDENTITY_SCALE, MIN_SPREAD_REFS, DepthScale, FusedDistance, Truncation, depth_fit_spread, fit_depth_scale,
    fuse_distances, inverse_variance_weights, mask_median_depth, pooled_sigma, truncation,
)
from pipeline.ranging.fusion import Cue, Fused, fuse_cues
from pipeline.camera.geometry import Intrinsics
from pipeline.ranging.ground_contact import GroundModel, border_bound, ground_contact_cue
from pipeline.ranging.hidden_bottom import placed_centre
from pipeline.ranging.gravity_spread import gravity_sigma_z, widen_for_gravity
from pipeline.mapper_config import MIN_DEPTH_SIGMA, MapperConfig
from pipeline.ranging.measured_height import HeightEstimate, estimate_height
from pipeline.models.base import DepthMap, Detection
from pipeline.ranging.occlusion import contact_as_bound, mark_hidden_contacts
from pipeline.ranging.orientation import length_axis_from_points
from pipeline.ranging.placement import GeometricEstimate, centre_on_ray, geometric_estimate
from pipeline.regions import box_mask, region_box, region_centre, region_width
from pipeline.ranging.size_prior import half_depth_stats, size_prior_cue

@dataclass
class MappedObject:
    """The mapper's working record of one detection (for debugging and the benchmark).

    Distances are optical-axis depths of the object's centre [m]; ``center_cam`` in the camera frame.
    """

    detection: Detection
    mask: np.ndarray | None
    mask_area: int | None
    truncation: Truncation
    size: tuple[float, float, float]
    size_known: bool
    geometric: GeometricEstimate | None = None
    depth_value: float | None = None
    depth_z: float | None = None
    fused: FusedDistance | None = None
    center_cam: np.ndarray | None = None
    object_id: str | None = None
    skipped: str | None = None
    length_axis_cam: np.ndarray | None = None
    """Unit horizontal length axis (camera frame) fitted from the depth points, when it was."""
    on_floor: bool = False
    """The class stands on the floor (catalog ``on_floor``)."""
    spread: tuple[float, float, float] = (0.2, 0.2, 0.2)
    """The class's relative size spread (catalog ``spread``)."""
    cues: list[Cue] = field(default_factory=list)
    """The distance cues (``sigma`` fusion): size prior, ground contact, depth."""
    ground_center: np.ndarray | None = None
    depth_span: tuple[float, float] | None = None
    """Near and far depth-map values (2nd/98th percentile over the mask) of a box cut at a side."""
    """Centre from the floor contact (camera frame [m]), when there is one."""
    bound: tuple[float, float] | None = None
    """``(bound, sigma)`` [m] on the centre depth of a box cut by the bottom border (floor beyond it)."""
    fusion: Fused | None = None
    """The ``sigma`` fusion's result (distance, sigma, cues used and rejected)."""
    sigma_z: float | None = None
    """1-sigma [m] of the centre's optical-axis depth (``sigma`` fusion)."""
    height: HeightEstimate | None = None
    """How the height of a floor-standing object of known class was set (:mod:`pipeline.ranging.measured_height`)."""
    contact_hidden_by: str | None = None
    """Label of the detection that may hide this box's bottom edge (its floor contact then only bounds
    the distance, :mod:`pipeline.ranging.occlusion`)."""

    @property
    def geometric_z(self) -> float | None:
        return None if self.geometric is None else float(self.geometric.center[2])

    @property
    def cut_sides(self) -> tuple[str, ...]:
        """The sides of the box the image border cuts (``left``, ``top``, ``right``, ``bottom``)."""
        return tuple(n for n, c in zip(("left", "top", "right", "bottom"), self.truncation.sides) if c)

    def cue(self, name: str) -> Cue | None:
        """The cue called ``name``, if measured."""
        return next((c for c in self.cues if c.name == name), None)

    @property
    def sigma_along_ray(self) -> float | None:
        """1-sigma [m] of the centre along the camera ray, ``sigma_z * |centre| / z`` (written to the
        scene as the object's ``sigma``; a cut box's lateral uncertainty is not in it: the map fusion
        widens cut views itself, :mod:`pipeline.mapping.observation_sigma`)."""
        if self.sigma_z is None or self.center_cam is None or not float(self.center_cam[2]) > 0:
            return None
        return float(self.sigma_z * np.linalg.norm(self.center_cam) / float(self.center_cam[2]))


SAME_GROUND = object()
"""``Ranger.measure``'s default ``ground``: the ranger's own floor."""

EXACT_DEPTH_SIGMA = 0.085
"""Relative 1-sigma of a centre placed from exact depth (a simulator's render): exact at the visible
surface, the centre placement still errs (cut and occluded objects): ``bench/sim_mapping.py`` measured a
mean relative error of 6.8 %, i.e. a Gaussian sigma of ``0.068 / sqrt(2 / pi) = 8.5 %``."""


class Ranger:
    """The distance stage for one photo's settings (see the module docstring)."""

    def __init__(self, config: MapperConfig, catalog: Catalog, exact_depth: bool,
                 ground: GroundModel | None = None) -> None:
        self.config = config
        self.catalog = catalog
        self.exact_depth = exact_depth
        self.ground = ground

    def needs_mask(self, det: Detection, width: int, height: int) -> bool:
        """Whether the distance of ``det`` depends on its mask: unknown size, or a box the border cuts
        both vertically and horizontally (no size-prior distance: depth only)."""
        entry = self.catalog.lookup(det.label)
        if entry is None or entry.size is None:
            return True
        if not self.config.handle_truncation or det.width <= 0 or det.height <= 0:
            return False
        t = truncation(det.box, width, height, self.config.truncation_margin_px)
        return t.vertical_cut and t.horizontal_cut

    def measure(
        self,
        det: Detection,
        mask: np.ndarray | None,
        shape: tuple[int, ...],
        intr: Intrinsics,
        gravity: np.ndarray,
        depth_map: DepthMap | None,
        ground: GroundModel | None | object = SAME_GROUND,
    ) -> MappedObject:
        """Everything that does not need the depth scale: truncation, mask, geometric estimate, depth value.
        ``ground``: this object's floor (:mod:`pipeline.ranging.photo_floor`; default: the ranger's)."""
        cfg = self.config
        h, w = int(shape[0]), int(shape[1])
        box = det.box
        if det.width <= 0 or det.height <= 0:
            trunc = Truncation(True, True, True, True)
        elif cfg.handle_truncation:
            trunc = truncation(box, w, h, cfg.truncation_margin_px)
        else:
            trunc = Truncation()
        entry = self.catalog.lookup(det.label)
        size = entry.size if entry is not None else None
        obj = MappedObject(
            detection=det,
            mask=mask,
            mask_area=int(np.count_nonzero(mask)) if mask is not None else None,
            truncation=trunc,
            size=size if size is not None else (0.0, 0.0, 0.0),
            size_known=size is not None,
            on_floor=bool(entry.on_floor) if entry is not None else False,
            spread=tuple(entry.spread) if entry is not None else (0.2, 0.2, 0.2),  # type: ignore[arg-type]
        )
        if det.width <= 0 or det.height <= 0:
            obj.skipped = "empty box"
            return obj
        if size is not None:
            obj.geometric = geometric_estimate(
                box, size, intr, trunc, gravity, cfg.placement,
                size_sigma=cfg.size_sigma, horizontal_sigma_scale=cfg.horizontal_sigma_scale,
            )
        if depth_map is not None:
            # without a mask, the middle half of the box: mostly the object, little background
            depth_region = mask if mask is not None and mask.any() else box_mask(box, h, w, shrink=0.25)
            obj.depth_value = mask_median_depth(depth_map.values, depth_region)
            if trunc.horizontal_cut and mask is not None and mask.any():
                vals = np.asarray(depth_map.values, dtype=np.float64)[mask]
                vals = vals[np.isfinite(vals) & (vals > 0)]
                if vals.size:
                    obj.depth_span = (float(np.percentile(vals, 2)), float(np.percentile(vals, 98)))
        if cfg.fusion == "sigma":
            self._geometric_cues(obj, intr, h, self.ground if ground is SAME_GROUND else ground, gravity)  # type: ignore[arg-type]
        return obj

    def _geometric_cues(self, obj: MappedObject, intr: Intrinsics, image_height: int,
                        ground: GroundModel | None, gravity: np.ndarray) -> None:
        """The cues that need no depth map: size prior (widened by a fitted gravity's own uncertainty,
        :mod:`pipeline.ranging.gravity_spread`) and floor contact (or the border's bound)."""
        box, cfg = obj.detection.box, self.config
        if obj.geometric is not None:
            sp = size_prior_cue(obj.geometric, box, obj.truncation, obj.size, obj.spread, focal=(intr.fx, intr.fy))
            if ground is not None and ground.floor is not None:  # the gravity was fitted: it is uncertain
                sp = widen_for_gravity(sp, gravity_sigma_z(box, obj.size, intr, obj.truncation, gravity, ground.floor,
                                                           cfg.placement, size_sigma=cfg.size_sigma,
                                                           horizontal_sigma_scale=cfg.horizontal_sigma_scale))
            obj.cues.append(sp)
        if ground is None or not obj.on_floor or not self.config.ground_contact:
            return
        x1, y1, x2, y2 = box
        if obj.size_known:
            half, half_sigma = half_depth_stats(obj.size, obj.spread)
            hc = 0.5 * obj.size[1]
        else:  # unknown size: footprint and height from the box at the contact's distance
            first = ground_contact_cue(box, obj.truncation, ground, intr, 0.0, 0.0, 0.0)
            if first is None:
                return
            z0 = first[0].distance
            half = 0.5 * (x2 - x1) * z0 / intr.fx
            half_sigma = 0.5 * half
            hc = 0.5 * (y2 - y1) * z0 / intr.fy
        if obj.truncation.bottom:
            obj.bound = border_bound(box, image_height, ground, intr, half, half_sigma, hc)
            return
        got = ground_contact_cue(box, obj.truncation, ground, intr, half, half_sigma, hc)
        if got is not None:
            obj.cues.append(got[0])
            obj.ground_center = got[1]


    mark_hidden_contacts = staticmethod(mark_hidden_contacts)

    def depth_scale(self, objects: list[MappedObject], depth_map: DepthMap | None) -> DepthScale | None:
        """Metric conversion of the depth map, fitted from the objects of known size when configured."""
        if depth_map is None:
            return None
        values, surfaces = self._references(objects)
        if depth_map.kind == "metric":
            if self.exact_depth:
                return IDENTITY_SCALE
            if self.config.fit_depth and len(values) >= max(1, self.config.refit_metric_min_refs):
                return fit_depth_scale(values, surfaces, "metric") or IDENTITY_SCALE  # type: ignore[arg-type]
            return IDENTITY_SCALE
        if not self.config.fit_depth or not values:
            return None  # relative depth without references has no metric meaning
        return fit_depth_scale(values, surfaces, depth_map.kind)  # type: ignore[arg-type]

    def _references(self, objects: list[MappedObject]) -> tuple[list[float], list[float]]:
        """Depth-map values and the surface depths [m] the other cues give (``sigma`` fusion: size
        prior and floor contact fused; else the size prior) of the objects usable as references."""
        values: list[float] = []
        surfaces: list[float] = []
        for o in objects:
            if o.geometric is None or o.depth_value is None:
                continue
            z = float(o.geometric.center[2])
            if self.config.fusion == "sigma":
                pre = fuse_cues(o.cues, self.config.gate_sigmas, o.bound)
                if pre is None:
                    continue
                z = pre.distance
            values.append(float(o.depth_value))
            surfaces.append(z - o.geometric.surface_offset)
        return values, surfaces

    def place_all(self, objects: list[MappedObject], scale: DepthScale | None,
                  intr: Intrinsics) -> tuple[str, bool]:
        """Fuse and place every object; ``(fusion note, depth map trusted)``."""
        if self.config.fusion != "sigma":
            weights, note = self._fusion_weights(objects, scale)
            for obj in objects:
                self._place(obj, scale, intr, weights)
            return note, weights[3]
        rel, note, trusted = self._depth_sigma(objects, scale)
        for obj in objects:
            self._place_sigma(obj, scale, intr, rel)
        return note, trusted

    def _depth_sigma(self, objects: list[MappedObject], scale: DepthScale | None) -> tuple[float, str, bool]:
        """Relative 1-sigma of this photo's depth-map distances, a note, and whether the map is trusted
        (metric and agreeing with the other cues within ``trust_depth_spread``)."""
        cfg = self.config
        if scale is None:
            return cfg.depth_sigma, "sigma: no metric depth", False
        if self.exact_depth:
            return EXACT_DEPTH_SIGMA, f"sigma: exact depth ({EXACT_DEPTH_SIGMA:.1%}: the placement from it)", True
        values, surfaces = self._references(objects)
        # two references already show how far the map disagrees with them (one degree of freedom, pooled
        # with the prior below); with one, the scale fitted to it says nothing about the map's error
        spread = depth_fit_spread(values, surfaces, scale, min_refs=MIN_SPREAD_REFS)
        if spread is not None:  # the robust spread hides a tail (an indoor model saturating outdoors): RMS too
            z = np.asarray(scale.to_metric(np.asarray(values)), dtype=np.float64)
            ok = np.isfinite(z) & (z > 0)
            res = np.log(np.asarray(surfaces)[ok] / z[ok])
            spread = max(spread, float(np.sqrt(np.mean((res - np.median(res)) ** 2))))
        if spread is None:
            return cfg.depth_sigma, (f"sigma: depth map unverified ({len(values)} reference objects, "
                                     f"{MIN_SPREAD_REFS} needed): {cfg.depth_sigma:.0%}"), False
        refs = [o for o in objects if o.geometric is not None and o.depth_value is not None and o.cues]
        ref_rel = float(np.median([min(c.rel_sigma for c in o.cues) for o in refs])) if refs else cfg.geometric_sigma
        rel = pooled_sigma(math.sqrt(max(spread**2 - ref_rel**2, MIN_DEPTH_SIGMA**2)), len(values) - 1, cfg.depth_sigma)
        trusted = scale.kind == "metric" and spread <= cfg.trust_depth_spread and len(values) >= 3
        return rel, (f"sigma: depth map {rel:.0%} (spread {spread:.0%} against the other cues over "
                     f"{len(values)} reference objects)"), trusted

    def _depth_cue(self, obj: MappedObject, scale: DepthScale | None,
                   intr: Intrinsics) -> tuple[float | None, tuple[float, float]]:
        """The depth map's cue for ``obj``: sets ``obj.depth_z`` (camera-frame centre depth [m], side-cut
        corrected) when the scaled depth of its region is usable; returns that surface depth [m] (or
        ``None``) and the region's centre pixel ``(u, v)``."""
        surface = None
        if scale is not None and obj.depth_value is not None:
            z = scale.to_metric(obj.depth_value)
            surface = float(z) if math.isfinite(float(z)) and float(z) > 0 else None
        uv = region_centre(obj.mask, obj.detection.box)
        if surface is not None:
            if obj.geometric is not None:
                obj.depth_z = surface + obj.geometric.surface_offset
            else:
                obj.depth_z = float(centre_on_ray(uv, surface, self._half_depth(obj, surface, intr), intr)[2])
            obj.depth_z = self._side_cut_depth(obj, scale, obj.depth_z)
        return surface, uv

    def _place_sigma(self, obj: MappedObject, scale: DepthScale | None, intr: Intrinsics, depth_rel: float) -> None:
        """Depth cue, inverse-variance fusion (:func:`pipeline.ranging.fusion.fuse_cues`) and the centre."""
        if obj.skipped:
            return
        surface, uv = self._depth_cue(obj, scale, intr)
        if surface is not None:
            # the map sees the near surface: the centre is half a footprint of unknown yaw behind it
            if obj.size_known:
                offset_sd = half_depth_stats(obj.size, obj.spread)[1]
            else:
                offset_sd = 0.5 * self._half_depth(obj, surface, intr)
            obj.cues.append(Cue("depth", obj.depth_z, math.hypot(obj.depth_z * depth_rel, offset_sd),
                                f"depth map, {depth_rel:.0%}, surface to centre +-{offset_sd:.2f} m"))
        # exact depth (a simulator's render) decides where it has a reading; the other cues are kept for the record
        use = [c for c in obj.cues if c.name == "depth"] if self.exact_depth and obj.depth_z is not None else obj.cues
        bound = obj.bound
        if obj.contact_hidden_by is not None:
            use, hidden = contact_as_bound(use)
            if hidden is not None:
                bound = hidden if bound is None or hidden[0] < bound[0] else bound
            else:
                obj.contact_hidden_by = None  # the contact agrees with the other cues: measured
        fused = fuse_cues(use, self.config.gate_sigmas, bound)
        if fused is None:
            obj.skipped = "no distance: unknown size (or every dimension cut), no floor contact and no metric depth"
            return
        obj.fusion = fused
        obj.sigma_z = fused.sigma
        method = fused.method
        obj.fused = FusedDistance(fused.distance, method)  # type: ignore[arg-type]
        if obj.geometric is not None:
            c = obj.geometric.center
        elif obj.ground_center is not None:
            c = obj.ground_center
        else:
            c = centre_on_ray(uv, surface if surface is not None else fused.distance,
                              self._half_depth(obj, surface or fused.distance, intr), intr)
        obj.center_cam = c * (fused.distance / float(c[2]))
        obj.center_cam = placed_centre(obj, self.ground, intr)  # a lower part hidden: from the top edge
        if not obj.size_known:
            obj.size = self._measured_size(obj, surface if surface is not None else fused.distance, intr)
        elif obj.on_floor and self.ground is not None and self.config.measure_height:
            self._measure_height(obj, fused, intr)

    def _measure_height(self, obj: MappedObject, fused: Fused, intr: Intrinsics) -> None:
        """The height of an object whose top the border cuts: at least what the photo shows
        (:func:`pipeline.ranging.measured_height.estimate_height`), standing on the floor: its centre is put
        half that height above the floor (the box-centre ray of a cut box says nothing about it)."""
        assert self.ground is not None and obj.center_cam is not None
        if not obj.truncation.top:
            return
        w, h, l = obj.size
        est = estimate_height(obj.detection.box, True, obj.center_cam, fused.sigma / fused.distance,
                              half_depth_stats(obj.size, obj.spread)[0], h, obj.spread[1], intr,
                              self.ground.gravity_cam, self.ground.camera_height)
        obj.height = est
        obj.size = (w, est.height, l)
        g = np.asarray(self.ground.gravity_cam, dtype=np.float64)
        above_floor = self.ground.camera_height - float(obj.center_cam @ g)
        obj.center_cam = obj.center_cam + (above_floor - 0.5 * est.height) * g

    def _fusion_weights(
        self, objects: list[MappedObject], scale: DepthScale | None
    ) -> tuple[tuple[float, float, float | None, bool], str]:
        """``((w_geometric, w_depth, gate, nearer_depth_wins), description)`` for this image (see
        :attr:`MapperConfig.fusion`). ``nearer_depth_wins``: the map is metric and agrees with the size
        priors here (spread within ``trust_depth_spread``), so it beats a size prior read off a box cut
        short (image border or occluder; see :func:`~pipeline.ranging.distance.fuse_distances`)."""
        cfg = self.config
        if self.exact_depth and scale is not None:
            return (0.0, 1.0, None, False), "exact depth: the depth map decides, size priors only where it has no reading"
        note = f"fixed: w_geometric {cfg.w_geometric:g}, w_depth {cfg.w_depth:g}"
        if cfg.fusion == "fixed" or scale is None:
            return (cfg.w_geometric, cfg.w_depth, None, False), note
        values, surfaces = self._references(objects)
        spread = depth_fit_spread(values, surfaces, scale)
        sg = cfg.geometric_sigma
        if spread is None or cfg.w_depth == 0 or cfg.w_geometric == 0:
            # the depth error the fixed weights imply: w_g / w_d = sigma_d^2 / sigma_g^2
            sd = sg * math.sqrt(cfg.w_geometric / cfg.w_depth) if cfg.w_depth > 0 and cfg.w_geometric > 0 else sg
            wg, wd = cfg.w_geometric, cfg.w_depth
            why = f"{note} (adaptive needs 3 reference objects, {len(values)} here)"
        else:
            # the spread holds both errors; the depth map's own is what exceeds the size prior's
            sd = math.sqrt(max(spread**2 - sg**2, MIN_DEPTH_SIGMA**2))
            wg, wd = inverse_variance_weights(sg, sd)
            why = (f"adaptive: w_geometric {wg:.2f}, w_depth {wd:.2f} (depth vs size priors: spread {spread:.0%} "
                   f"over {len(values)} reference objects)")
        gate = cfg.gate_sigmas * math.sqrt(sg**2 + sd**2)
        trusted = scale.kind == "metric" and spread is not None and spread <= cfg.trust_depth_spread
        if trusted:
            why += "; a nearer metric depth beats a size prior beyond the gate"
        return (wg, wd, gate, trusted), f"{why}; depth dropped beyond x{math.exp(gate):.2f} from the size prior"

    def _place(self, obj: MappedObject, scale: DepthScale | None, intr: Intrinsics,
               weights: tuple[float, float, float | None, bool]) -> None:
        """Depth-map distance, fusion and the camera-frame centre of one object."""
        if obj.skipped:
            return
        x1, y1, x2, y2 = obj.detection.box
        surface, uv = self._depth_cue(obj, scale, intr)
        obj.fused = fuse_distances(obj.geometric_z, obj.depth_z, *weights)
        if obj.fused is None:
            obj.skipped = "no distance: unknown size (or every dimension cut) and no metric depth"
            return
        if obj.geometric is not None:
            c = obj.geometric.center
            obj.center_cam = c * (obj.fused.distance / float(c[2]))
        else:
            assert surface is not None
            half = self._half_depth(obj, surface, intr)
            c = centre_on_ray(uv, surface, half, intr)
            obj.center_cam = c * (obj.fused.distance / float(c[2]))
        if not obj.size_known:
            obj.size = self._measured_size(obj, surface if surface is not None else obj.fused.distance, intr)

    def yaw_from_depth(self, scale: DepthScale | None, trusted: bool) -> bool:
        """Whether objects get their yaw from the depth points (see :attr:`MapperConfig.yaw_from_depth`)."""
        if scale is None:
            return False
        if self.config.yaw_from_depth is not None:
            return self.config.yaw_from_depth
        return self.exact_depth or (trusted and scale.kind == "metric")

    @staticmethod
    def orient(objects: list[MappedObject], depth_map: DepthMap, scale: DepthScale, intr: Intrinsics,
                gravity: np.ndarray) -> None:
        """Fit the length axis (camera frame) of every placed known-size object with a mask from its
        back-projected depth points [m]."""
        todo = [o for o in objects if o.center_cam is not None and o.size_known and o.mask is not None
                and o.mask.any()]
        if not todo:
            return
        depth_m = np.asarray(scale.to_metric(depth_map.values), dtype=np.float64)
        for obj in todo:
            obj.length_axis_cam = length_axis_from_points(obj.mask, depth_m, intr, gravity, obj.size)  # type: ignore[arg-type]

    def _side_cut_depth(self, obj: MappedObject, scale: DepthScale | None, depth_z: float) -> float:
        """Centre depth [m] of a known-size box cut at its left or right side, from exact depth.

        The border hides the part of the object nearest the image's edge, which for an object off
        the optical axis is its near part: the visible surface's median plus half a footprint put
        such an object up to 0.8 m too far (``office_chair-2`` from the simulator's start pose). The
        centre is taken at the middle of the visible points' depth range, or at least half the
        footprint's short side beyond the nearest visible point (a box showing one face), and never
        beyond ``depth_z`` (the surface estimate). ``depth_z`` unchanged when not applicable (not
        exact depth, not cut at a side, unknown size)."""
        if (not self.exact_depth or scale is None or obj.depth_span is None or not obj.size_known
                or not obj.truncation.horizontal_cut):
            return depth_z
        near, far = (float(scale.to_metric(v)) for v in obj.depth_span)
        if not (math.isfinite(near) and math.isfinite(far) and 0 < near <= far):
            return depth_z
        w, _, l = obj.size
        return min(depth_z, max(0.5 * (near + far), near + 0.5 * min(w, l)))

    def _half_depth(self, obj: MappedObject, surface_z: float, intr: Intrinsics) -> float:
        """Half the object's depth [m] along the ray: for a known size, the expected half extent of
        its footprint at unknown yaw, ``(w + l) / pi``; for an unknown size, half its measured width
        (a square footprint seen at a random yaw shows about ``4/pi`` of its side)."""
        if obj.size_known:
            w, _, l = obj.size
            return (w + l) / math.pi
        wpx = region_width(obj.mask, obj.detection.box)
        return 0.5 * wpx * surface_z / intr.fx

    @staticmethod
    def _measured_size(obj: MappedObject, surface_z: float, intr: Intrinsics) -> tuple[float, float, float]:
        """Size ``(w, h, l)`` [m] of an unknown-size object from its mask extent at ``surface_z``; the
        footprint is taken square (``l = w``)."""
        x1, y1, x2, y2 = region_box(obj.mask, obj.detection.box)
        wm = max((x2 - x1) * surface_z / intr.fx, 0.05)
        hm = max((y2 - y1) * surface_z / intr.fy, 0.05)
        return (wm, hm, wm)


__all__ = ["EXACT_DEPTH_SIGMA", "MappedObject", "Ranger"]
