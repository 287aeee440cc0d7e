"""What the renderer tells about a scene and a frame: the automatic choice of shading method
(:mod:`.auto`) and a pixel's reflectance equation with its numbers (:mod:`.explain`).

Features that :func:`raycast_shade.render` and the frame use; the oracles they are checked
against (the exact renderer, the NumPy twins, the metrics) are in :mod:`raycast_shade.study`."""
