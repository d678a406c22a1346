"""Cameras: intrinsics, frames and poses, camera files, assumed cameras, calibration, image loading, pose checks.
Frames: camera OpenCV (x right, y down, z forward), robot (x forward, y left, z up), world (z up) [m, rad].
"""
