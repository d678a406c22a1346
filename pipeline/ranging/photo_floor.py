"""The floor of one photo for ground-contact ranging: given, checked, or found in the photo.

The mapper measures every object once with the camera pose it was given (or, with no pose given, a
level camera and no floor), then calls :func:`decide_floor` with those measurements:

- **pose given**: the floor is fitted again from the photo with a wide prior around the given pose
  (:func:`pipeline.camera.floor_fit.fit_floor`: the floor-standing objects' contacts at their size-prior
  depths, and the depth map's floor plane when the map is trusted). When the two disagree by more than
  :data:`DISAGREE_SIGMAS` (Mahalanobis over pitch, roll and log height), the warning names the numbers
  and the ground-contact sigma is widened by the difference (the given pose is kept: no object moves
  because of the check);
- **pose not given**: the fitted floor is used: gravity for the 3D box fit and, for each object, a
  ground model fitted *without that object's own contact* (leave one out), whose covariance the
  ground-contact sigma carries (:func:`pipeline.camera.floor_fit.contact_sigma`).

Camera frame (OpenCV: x right, y down, z forward) [m].
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np
from scipy.stats import chi2

from pipeline.camera.floor_fit import (
    UNKNOWN_POSE_PRIOR, Contact, DepthPlane, FloorEstimate, FloorPrior, disagreement, fit_floor, plane_from_depth,
)
from pipeline.camera.geometry import Intrinsics
from pipeline.ranging.ground_contact import GroundModel
from pipeline.ranging.occlusion import bottom_occluders
from pipeline.ranging.size_prior import half_depth_stats

DISAGREE_SIGMAS = 3.4
"""The photo's floor and the given pose disagree beyond this many sigmas (chi-square, 3 degrees of
freedom, 99 %: sqrt(11.34)) -> warning, ground contact widened."""


MIN_CONTACT_SCORE = 0.5
"""Detections scoring less do not tell where the floor is: on the dev photos every contact under 0.5 that
disagreed with the given floor by more than 3 sigma was a false detection (a 'car' 17 px wide, a 'person'
on a wall, a 'toilet' on a desk)."""


@dataclass
class FloorDecision:
    """What the photo's floor changes.

    Attributes:
        gravity: Gravity (camera frame) to measure the objects with; ``None``: unchanged.
        grounds: One ground model per object (index into the measured objects; ``None``: no floor cue).
        estimate: The floor fitted from the photo (``None``: not enough evidence).
        note: One line for the capture's record.
        warning: The given pose disagrees with the photo (``None``: it does not, or no pose was given).
        remeasure: The objects must be measured again with ``gravity`` / ``grounds``.
    """

    gravity: np.ndarray | None
    grounds: list[GroundModel | None]
    estimate: FloorEstimate | None
    note: str
    warning: str | None = None
    remeasure: bool = False
    contacts: list[int] = field(default_factory=list)


def contacts_of(objects: Sequence[object]) -> tuple[list[Contact], list[int]]:
    """The floor contacts of measured objects (:class:`pipeline.ranging.ranger.MappedObject`): those of
    a floor-standing class of known size whose box bottom the border does not cut and that have a
    size-prior cue; the contact depth is the size prior's centre depth less the half footprint, its
    relative sigma the size prior's and the footprint's over ``sqrt(score)``.
    A box whose bottom edge a nearer detection may hide (:func:`pipeline.ranging.occlusion.bottom_occluders`)
    gives no contact: its visible bottom is not where it meets the floor (a desk behind a compressor).
    Returns the contacts and the objects' indices."""
    out: list[Contact] = []
    idx: list[int] = []
    live = [i for i, o in enumerate(objects) if not o.skipped]  # type: ignore[attr-defined]
    occluded = {i for i, occ in zip(live, bottom_occluders([objects[i].detection.box for i in live]))  # type: ignore[attr-defined]
                if occ is not None}
    for i, o in enumerate(objects):
        sp = o.cue("size_prior") if not o.skipped else None  # type: ignore[attr-defined]
        if sp is None or not o.on_floor or not o.size_known or o.truncation.bottom:  # type: ignore[attr-defined]
            continue
        if i in occluded:
            continue
        if float(o.detection.score) < MIN_CONTACT_SCORE:  # type: ignore[attr-defined]
            continue
        half, half_sigma = half_depth_stats(o.size, o.spread)  # type: ignore[attr-defined]
        t = sp.distance - half
        if t <= 0.3:
            continue
        x1, _, x2, y2 = o.detection.box  # type: ignore[attr-defined]
        # a detection of score p is taken as p times the evidence (a false box's contact is anywhere)
        p = min(max(float(o.detection.score), 0.05), 1.0)  # type: ignore[attr-defined]
        out.append(Contact((0.5 * (x1 + x2), y2), t, math.hypot(sp.sigma, half_sigma) / t / math.sqrt(p),
                           o.detection.label))  # type: ignore[attr-defined]
        idx.append(i)
    return out, idx


def depth_plane(depth_m: np.ndarray | None, intr: Intrinsics, prior_gravity: Sequence[float],
                boxes: Sequence[Sequence[float]]) -> DepthPlane | None:
    """The floor plane of a metric depth map outside the detected ``boxes`` (``None`` without a map)."""
    if depth_m is None:
        return None
    excl = np.zeros((intr.height, intr.width), dtype=bool)
    for x1, y1, x2, y2 in boxes:
        excl[max(int(y1), 0):max(int(math.ceil(y2)), 0), max(int(x1), 0):max(int(math.ceil(x2)), 0)] = True
    return plane_from_depth(depth_m, intr, prior_gravity, excl)


def _ground(base: GroundModel | None, floor: FloorEstimate, sigma_floor: float, sigma_px: float,
            widened: str = "") -> GroundModel:
    return GroundModel(floor.gravity_cam, floor.camera_height, sigma_floor=sigma_floor, sigma_px=sigma_px,
                       floor=floor, widened=widened, **({} if base is None else {"sigma_pitch": base.sigma_pitch,
                                                                                  "sigma_height": base.sigma_height}))


def floor_spread(contacts: Sequence[Contact], gravity_cam: Sequence[float], camera_height: float,
                 intr: Intrinsics) -> float:
    """How far [m] (1-sigma) the ground under the objects lies off the plane ``g . X = H``, judged from the
    contacts; 0 when their sizes explain them. Each contact's log ratio ``e_i`` of its size-prior depth to
    the plane's depth at its pixel holds its own size error (``s_i``) and the local floor offset over
    ``H``. Only when ``sum(e_i^2 / s_i^2)`` exceeds the 99 % chi-square quantile of ``n`` degrees of freedom
    (at least :data:`MIN_SPREAD_CONTACTS` contacts: one or two objects cannot tell a raised floor from
    their own sizes) is the offsets' spread ``H sqrt(mean(e_i^2 - s_i^2))`` returned."""
    if len(contacts) < MIN_SPREAD_CONTACTS:
        return 0.0
    g = np.asarray(gravity_cam, dtype=np.float64)
    p = intr.undistort_pixels(np.array([c.uv for c in contacts], dtype=np.float64))
    rays = np.stack([(p[:, 0] - intr.cx) / intr.fx, (p[:, 1] - intr.cy) / intr.fy, np.ones(len(p))], axis=1)
    gr = rays @ g
    ok = gr > 1e-3
    n = int(ok.sum())
    if n < MIN_SPREAD_CONTACTS:
        return 0.0
    e = np.log(np.array([c.depth for c in contacts])[ok] * gr[ok] / camera_height)
    s = np.array([c.rel_sigma for c in contacts])[ok]
    if float(np.sum(e**2 / s**2)) <= float(chi2.ppf(0.99, n)):
        return 0.0
    var = float(np.mean(e**2 - s**2))
    return camera_height * math.sqrt(var) if var > 0 else 0.0


MIN_SPREAD_CONTACTS = 3
"""Contacts needed to judge the ground under the objects (:func:`floor_spread`)."""


def decide_floor(objects: Sequence[object], intr: Intrinsics, given: GroundModel | None, pose_given: bool,
                 assumed_gravity: Sequence[float], assumed_height: float | None, depth_m: np.ndarray | None,
                 sigma_floor: float) -> FloorDecision:
    """See the module docstring. ``given``: the ground model of the given pose (``None`` when the
    camera is not above the floor or ground contact is off); ``assumed_gravity`` / ``assumed_height``:
    the pose the objects were measured with when none is given (a height <= 0.05 m counts as unknown:
    :data:`pipeline.camera.floor_fit.UNKNOWN_POSE_PRIOR`'s 1.5 m); ``depth_m``: the metric depth map
    when it is trusted for a floor plane, else ``None``."""
    contacts, idx = contacts_of(objects)
    n = len(objects)
    boxes = [o.detection.box for o in objects if not o.skipped]  # type: ignore[attr-defined]
    if pose_given:
        if given is None:
            return FloorDecision(None, [None] * n, None, "camera pose given; no floor (camera not above it)")
        g0 = tuple(float(v) for v in given.gravity_cam)
        wide = FloorPrior(g0, given.camera_height, UNKNOWN_POSE_PRIOR["sigma_pitch"],  # type: ignore[arg-type]
                          UNKNOWN_POSE_PRIOR["sigma_roll"], UNKNOWN_POSE_PRIOR["sigma_log_height"])
        plane = depth_plane(depth_m, intr, g0, boxes)
        if not contacts and plane is None:
            return FloorDecision(None, [given] * n, None, "camera pose given (no floor evidence in the photo to check it)")
        fit = fit_floor(wide, contacts, intr, plane)
        given_prior = FloorPrior(g0, given.camera_height, max(given.sigma_pitch, 1e-4),  # type: ignore[arg-type]
                                 max(given.sigma_pitch, 1e-4), max(math.hypot(given.sigma_height, given.sigma_floor)
                                                                   / given.camera_height, 1e-4))
        dis = disagreement(given_prior, fit)
        given_pitch = math.degrees(math.atan2(g0[2], math.hypot(g0[0], g0[1])))
        if dis <= DISAGREE_SIGMAS:
            local = floor_spread(contacts, given.gravity_cam, given.camera_height, intr)
            if local <= given.sigma_floor:
                return FloorDecision(None, [given] * n, fit,
                                     f"camera pose given; the photo agrees ({dis:.1f} sigma): {fit.note}")
            wider = GroundModel(given.gravity_cam, given.camera_height, given.sigma_pitch, given.sigma_height,
                                local, given.sigma_px,
                                widened=f"the ground under the photo's objects is +-{local:.2f} m off its plane")
            return FloorDecision(None, [wider] * n, fit, (
                f"camera pose given; the photo agrees ({dis:.1f} sigma), but the ground under the objects is "
                f"+-{local:.2f} m off its plane: ground-contact sigma widened ({fit.note})"), remeasure=True, contacts=idx)
        # keep the given floor, widen its uncertainty by the disagreement: nothing moves because of the check
        dp, dr = fit.angles
        dlh = math.log(fit.camera_height / given.camera_height)
        cov = np.diag([given_prior.sigma_pitch**2 + dp**2, given_prior.sigma_roll**2 + dr**2,
                       (given.sigma_height / given.camera_height) ** 2 + dlh**2])
        widened = FloorEstimate(g0, given.camera_height, g0, (0.0, 0.0),  # type: ignore[arg-type]
                                tuple(tuple(float(v) for v in row) for row in cov), fit.n_contacts, fit.plane,  # type: ignore[arg-type]
                                "given pose, widened by its disagreement with the photo")
        warning = (f"the photo's floor disagrees with the given camera pose by {dis:.1f} sigma: pitch "
                   f"{fit.pitch_deg:.1f} deg (given {given_pitch:.1f}), camera {fit.camera_height:.2f} m above the "
                   f"floor (given {given.camera_height:.2f} m), from {fit.n_contacts} object contact"
                   f"{'s' if fit.n_contacts != 1 else ''}{' and the depth map' if fit.plane else ''}; "
                   "ground contact down-weighted")
        ground = _ground(given, widened, given.sigma_floor, given.sigma_px,
                         f"the photo's floor disagrees with the given camera pose by {dis:.1f} sigma")
        return FloorDecision(None, [ground] * n, fit, f"camera pose given; {warning}", warning, remeasure=True,
                             contacts=idx)
    # --- no pose: the photo's floor ----------------------------------------------------------------
    g0 = tuple(float(v) for v in np.asarray(assumed_gravity, dtype=np.float64) / np.linalg.norm(assumed_gravity))
    h0 = assumed_height if assumed_height is not None and assumed_height > 0.05 else UNKNOWN_POSE_PRIOR["camera_height"]
    prior = FloorPrior(g0, float(h0), UNKNOWN_POSE_PRIOR["sigma_pitch"], UNKNOWN_POSE_PRIOR["sigma_roll"],  # type: ignore[arg-type]
                       UNKNOWN_POSE_PRIOR["sigma_log_height"])
    plane = depth_plane(depth_m, intr, g0, boxes)
    if not contacts and plane is None:
        return FloorDecision(None, [None] * n, None, "camera pose not given: level camera assumed, no floor contact "
                                                  "(no object stands on the floor in the photo)")
    fit = fit_floor(prior, contacts, intr, plane)
    grounds: list[GroundModel | None] = [_ground(None, fit, sigma_floor, 1.5)] * n
    for k, i in enumerate(idx):  # each object's contact judged against the floor of the others
        grounds[i] = _ground(None, fit_floor(prior, contacts, intr, plane, leave_out=k), sigma_floor, 1.5)
    return FloorDecision(np.asarray(fit.gravity_cam), grounds, fit, f"camera pose not given: {fit.note}",
                         remeasure=True, contacts=idx)




def trusted_depth(ranger: object, objects: Sequence[object], depth_map: object, scale: object) -> np.ndarray | None:
    """The metric depth map [m] when it may show the floor plane: exact depth only (a simulator's render).
    FastDepth's floor plane on the 13 dev photos was off by 2-12 deg in pitch indoors and 5-37 deg
    outdoors, its height by a factor 0.3-8, also where the map agreed with the objects within
    ``trust_depth_spread``: a learned depth model's floor is not used until one is measured to be right."""
    if depth_map is None or scale is None or not getattr(ranger, "exact_depth", False):
        return None
    return np.asarray(scale.to_metric(depth_map.values), dtype=np.float64)  # type: ignore[attr-defined]


def floor_pass(ranger: object, detections: Sequence[object], masks: Sequence[object], objects: list, shape: tuple,
               intr: Intrinsics, gravity: np.ndarray, depth_map: object, scale: object, pose_given: bool,
               assumed_height: float | None) -> tuple[list, object, np.ndarray, FloorDecision]:
    """Decide the photo's floor (:func:`decide_floor`) and, when it changes anything, measure the objects
    again with it (:class:`pipeline.ranging.ranger.Ranger`); returns ``(objects, depth scale, gravity,
    decision)``."""
    cfg = ranger.config  # type: ignore[attr-defined]
    decision = decide_floor(objects, intr, ranger.ground, pose_given, gravity, assumed_height,  # type: ignore[attr-defined]
                            trusted_depth(ranger, objects, depth_map, scale), cfg.sigma_floor)
    if not decision.remeasure:
        return objects, scale, gravity, decision
    if decision.gravity is not None:
        gravity = decision.gravity
    if not pose_given and decision.estimate is not None:  # the photo's floor for heights and border bounds
        ranger.ground = _ground(None, decision.estimate, cfg.sigma_floor, 1.5)  # type: ignore[attr-defined]
    objects = [ranger.measure(d, m, shape, intr, gravity, depth_map, ground=g)  # type: ignore[attr-defined]
               for d, m, g in zip(detections, masks, decision.grounds)]
    ranger.mark_hidden_contacts(objects)  # type: ignore[attr-defined]
    return objects, ranger.depth_scale(objects, depth_map), gravity, decision  # type: ignore[attr-defined]


__all__ = ["DISAGREE_SIGMAS", "FloorDecision", "contacts_of", "decide_floor", "depth_plane", "floor_pass",
           "trusted_depth"]
