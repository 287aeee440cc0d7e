"""The output arrays a view set renders into, slot by slot (:func:`raycast_shade.apps.views.render_views`).

A view's image and buffers are written into the arrays of the view that used the slot before
(``render(out=..., buffers_out=...)``): a set of views of one size page-faults its outputs in once,
not once per view (the default buffers and image are about 75 MB at 1080p).
"""

from __future__ import annotations

import numpy as np

__all__ = ["ViewSlots", "view_conventions", "two_frames_fit"]


class ViewSlots:
    """``count`` slots of output arrays for the present camera size, handed out in turn (new ones
    when the size changes): each slot's image array and the buffers of the last view rendered into
    it. With two, a view renders into one slot while the previous view's files are written from the
    other; no view pays for a fresh 24 MB image (1080p), its buffers and their page faults."""

    def __init__(self, count: int):
        self.count, self.images, self.buffers, self.turn, self.shape = count, [], [], 0, None

    def next(self, camera) -> "ViewSlots":
        """The next slot (this object, turned), reallocated when the camera's size changed."""
        shape = (int(camera.height), int(camera.width), 3)
        if shape != self.shape:
            self.shape = shape
            self.images = [np.empty(shape, np.float32) for _ in range(self.count)]
            self.buffers = [{} for _ in range(self.count)]
        self.turn = (self.turn + 1) % self.count
        return self

    def arrays(self, camera, names) -> tuple:
        """``(image, buffers_out)`` of the present slot: the earlier view's buffers that are asked for
        again (``render``'s ``buffers_out``), none when the camera's size differs."""
        if (int(camera.height), int(camera.width), 3) != self.shape:
            return None, None
        kept = self.buffers[self.turn]
        return self.images[self.turn], {k: v for k, v in kept.items() if k in names}

    def keep(self, buffers) -> None:
        """The present slot's view was rendered into these buffers: the next view of the slot reuses them."""
        self.buffers[self.turn] = dict(buffers)


def view_conventions(depth_scale: float) -> dict:
    """The index's ``conventions``: what the numbers in the files mean."""
    return {"camera": "OpenCV: x right, y down, z forward; x_cam = R x_world + t",
            "pixels": "centre of pixel (i, j) at (u, v) = (i, j)",
            "zdepth": "camera-space z", "depth": "distance along the ray",
            "depth_png": f"uint16 zdepth * {depth_scale:g}, 0 = none",
            "distance_png": f"uint16 depth * {depth_scale:g}, 0 = none",
            "mask_png": "255 on a surface, 0 on the background", "labels": "labels.json",
            "ids": "-1 on the background (EXR: id + 1, 0 on the background)"}


def two_frames_fit(jobs, memory) -> bool:
    """Whether two of the largest frame (the one writing, the next rendering) fit in the memory limit
    that :meth:`~raycast_shade.scene.camera.Camera.check_frame_memory` holds one frame to."""
    from ..common.validate import memory_limit
    from ..scene.framememory import frame_bytes_per_pixel

    pixels = max((float(j.camera.width) * float(j.camera.height) for j in jobs), default=0.0)
    return 2.0 * pixels * frame_bytes_per_pixel(**memory) <= memory_limit()
