"""Make ``docs/images/light_orbit.gif``: Gouraud against Phong under a moving light.

A point light circles a coarse sphere (an icosphere of 320 triangles with a
sharp Phong highlight). Left, Gouraud shading: the highlight is computed at
the vertices only, so it jumps from vertex to vertex, swells and fades.
Right, Phong shading: the normal is interpolated and the highlight glides.

Run ``python -m docs.figures.animation [--workers N] [-o PATH] [--quick]``.
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

from benchmarks.outputs import ROOT, image_file

OUTPUT = image_file("light_orbit.gif", False)


def orbit_scenes(frames: int = 24, width: int = 160, height: int = 120):
    """The light orbit: one scene per frame, sharing one mesh set.

    The light circles the view axis, in front of the sphere, so the
    highlight travels around the visible face.

    Returns
    -------
    list of Scene
    """
    import raycast_shade as rs
    from raycast_shade.apps.animate import orbit_light

    scene = rs.Scene(
        [rs.Model(rs.shapes.icosphere(2), rs.Material(kd=(0.75, 0.28, 0.18), ks=0.8, shininess=60))],
        lights=[rs.PointLight((1.6, 0.0, 2.6), intensity=6.0, attenuation="inverse_square")],
        camera=rs.Camera(eye=(0.0, 0.0, 3.4), fov=40.0, width=width, height=height),
        ambient=0.06,
    )
    return orbit_light(scene, frames, light_index=0, axis=(0.0, 0.0, 1.0), center=(0.0, 0.0, 0.0))


def side_by_side(left, right, labels=("GOURAUD", "PHONG"), gap: int = 2) -> np.ndarray:
    """Two linear float panels, left | right, labelled, with a black gap."""
    from raycast_shade.apps.demo import draw_text

    panels = []
    for img, label in zip((left, right), labels):
        img = np.array(img, np.float32)
        draw_text(img, label, 3, 3, max(1, img.shape[0] // 80))
        panels.append(img)
    sep = np.zeros((left.shape[0], gap, 3), np.float32)
    return np.concatenate([panels[0], sep, panels[1]], axis=1)


def make(output: str = OUTPUT, frames: int = 24, width: int = 160, height: int = 120, fps: float = 12.0,
         workers: int | None = None) -> dict:
    """Render both shadings of the orbit and write the GIF.

    Parameters
    ----------
    output : str
        A ``.gif`` (or video) path.
    frames : int
    width, height : int
        Size of each panel.
    fps : float
    workers : int, optional
        Render on a local Dask cluster of this many workers (one cluster
        for both shadings).

    Returns
    -------
    dict
        ``output``, ``frames``, ``bytes``, ``seconds``.
    """
    from raycast_shade.apps.animate import write_animation
    from raycast_shade.apps.batch import RunOptions, local_cluster, render_batch

    t0 = time.perf_counter()
    scenes = orbit_scenes(frames, width, height)
    if workers:
        with local_cluster(workers) as client:
            gouraud = render_batch(scenes, shading="gouraud", run=RunOptions(scheduler=client))
            phong = render_batch(scenes, shading="phong", run=RunOptions(scheduler=client))
    else:
        gouraud = render_batch(scenes, shading="gouraud")
        phong = render_batch(scenes, shading="phong")
    count = write_animation((side_by_side(g, p) for g, p in zip(gouraud, phong)), output, fps=fps)
    return {"output": output, "frames": count, "bytes": os.path.getsize(output),
            "seconds": time.perf_counter() - t0}


def main(argv=None):
    """Command line; returns the dict of :func:`make`."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("-o", "--output", default=OUTPUT, help=f"GIF to write (default: {os.path.relpath(OUTPUT, ROOT)})")
    ap.add_argument("--frames", type=int, default=24)
    ap.add_argument("--width", type=int, default=160, help="panel width")
    ap.add_argument("--height", type=int, default=120, help="panel height")
    ap.add_argument("--fps", type=float, default=12.0)
    ap.add_argument("--workers", type=int, default=None, help="render on a local Dask cluster")
    ap.add_argument("--quick", action="store_true", help="write into the git-ignored out/quick/images/")
    args = ap.parse_args(argv)
    if args.quick and args.output == OUTPUT:
        args.output = image_file("light_orbit.gif", True)
    os.makedirs(os.path.dirname(os.path.abspath(args.output)), exist_ok=True)
    out = make(args.output, args.frames, args.width, args.height, args.fps, args.workers)
    print(f"wrote {out['output']}: {out['frames']} frames, {out['bytes'] / 1024:.0f} KiB, {out['seconds']:.1f} s")
    return out


if __name__ == "__main__":
    main()
