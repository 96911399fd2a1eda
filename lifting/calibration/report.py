"""Human-readable lines about cameras, for ``platypose calib check``."""

from __future__ import annotations

import math

import numpy as np

from platypose.lifting.camera import CODEC_BLOCK, Camera, codec_padded


def viewing_direction(camera: Camera) -> np.ndarray:
    """Unit optical axis in world coordinates (3,): the camera's +z."""
    return camera.R[2].copy()


def describe_camera(camera: Camera) -> str:
    """One line: name, size, focal, centre, viewing direction with azimuth/elevation, time offset."""
    d = viewing_direction(camera)
    azimuth = math.degrees(math.atan2(d[1], d[0]))
    elevation = math.degrees(math.asin(float(np.clip(d[2], -1.0, 1.0))))
    x, y, z = camera.center
    line = (
        f"{camera.name}: {camera.width}x{camera.height} px, focal {camera.K[0, 0]:.1f}/{camera.K[1, 1]:.1f} px, "
        f"at ({x:.3f}, {y:.3f}, {z:.3f}) m, looking ({d[0]:.2f}, {d[1]:.2f}, {d[2]:.2f}) "
        f"azimuth {azimuth:.0f} deg elevation {elevation:.0f} deg"
    )
    return line + (f", time offset {camera.time_offset_s:+.3f} s" if camera.time_offset_s else "")


def size_mismatch(camera: Camera, video_size: tuple[int, int], video_name: str) -> str | None:
    """A warning when the video's (height, width) differs from the calibrated size, a note when only by the codec's
    padding to a multiple of 16 (:func:`lifting.camera.codec_padded`: the same pixels), else None."""
    if tuple(video_size) == camera.size:
        return None
    h, w = video_size
    said = f"camera {camera.name} is calibrated for {camera.width}x{camera.height} px"
    if codec_padded(camera.size, video_size):
        return (
            f"{said}, {video_name} is {w}x{h} px: the codec's padding to a multiple of {CODEC_BLOCK}, the same pixels"
        )
    return f"warning: {said} but {video_name} is {w}x{h} px"
