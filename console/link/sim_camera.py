"""The simulated robot's photos: a render of the hidden world, or a photo from a folder, as a capture.

A render becomes a :class:`~console.link.base.CaptureResult` with its ground truth (the hidden
objects, the ones visible with their 2D boxes, depth and instance masks); a photo from a
``--captures`` folder keeps its own camera mount and ground truth when it has them.

Frames: the camera pose is ``world <- camera`` (OpenCV optical frame), the robot pose
``world <- robot``; boxes are pixels ``(u0, v0, u1, v1)``, ``u1`` / ``v1`` exclusive.
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from pipeline.camera.geometry import CameraMount, Intrinsics, Pose, camera_pose_in_world
from pipeline.scene import Scene

from console.link.base import CaptureResult, GroundTruth, VisibleObject
from console.link.captures import FolderPhoto
from console.link.render import RenderResult


def visible_objects(r: RenderResult, min_pixels: int) -> tuple[VisibleObject, ...]:
    """The objects of a render covering at least ``min_pixels`` pixels, with their 2D boxes and
    whether the image border cuts them."""
    visible = []
    H, W = r.instances.shape
    ids, counts = np.unique(r.instances, return_counts=True)
    for idx, count in zip(ids, counts):
        if idx < 0 or count < min_pixels:
            continue
        vs, us = np.nonzero(r.instances == idx)
        box = (float(us.min()), float(vs.min()), float(us.max() + 1), float(vs.max() + 1))
        cut = box[0] <= 0 or box[1] <= 0 or box[2] >= W or box[3] >= H
        visible.append(VisibleObject(int(idx), r.object_ids[idx], r.labels[idx], box, int(count), cut))
    return tuple(visible)


def render_capture(r: RenderResult, world: Scene, intrinsics: Intrinsics, camera: Pose, robot: Pose,
                   mount: CameraMount, name: str, min_visible_pixels: int) -> CaptureResult:
    """A render of ``world`` from ``camera`` as a capture (source ``sim-render``) with its ground truth."""
    truth = GroundTruth(world.objects, visible_objects(r, min_visible_pixels), r.depth, r.instances)
    return CaptureResult(r.rgb, intrinsics, camera, robot, mount, time.time(), "sim-render", name, truth)


def folder_capture(photo: FolderPhoto, robot: Pose, mount: CameraMount) -> CaptureResult:
    """A photo from a folder (or a live source) taken at ``robot``; the photo's own mount wins. Without
    one, the robot's mount is only a stand-in (:attr:`CameraMount.assumed`): the mapper fits the camera's
    pitch, roll and height from the photo, the robot's mount height its prior."""
    mount = dataclasses.replace(mount, assumed=True) if photo.mount is None else photo.mount
    camera = camera_pose_in_world(robot, mount)
    return CaptureResult(photo.image, photo.intrinsics, camera, robot, mount, time.time(),
                         "captures-folder", photo.name, photo.ground_truth)


__all__ = ["render_capture", "folder_capture", "visible_objects"]
