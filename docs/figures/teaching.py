"""Pictures for docs/teaching.md: the equation's terms, the shadow mask, the explorer's frame.

Run ``python -m docs.figures.teaching [--quick]``; writes ``docs/images/teaching_*.png`` and prints
the ``explain()`` text that docs/teaching.md quotes.
"""

from __future__ import annotations

import os
import sys

import numpy as np

from benchmarks.outputs import images_dir

IMAGES = images_dir(False)


def room(width=320, height=240):
    import raycast_shade as rs

    return rs.Scene([rs.Model(rs.shapes.icosphere(3), rs.Material(kd=(0.8, 0.3, 0.2), ks=0.5, shininess=40)),
                     rs.Model(rs.shapes.plane(6.0, subdivisions=12, center=(0.0, -1.0, 0.0), normal="+y"),
                              rs.Material(kd=0.6, reflectivity=0.4))],
                    lights=[rs.PointLight((2.0, 3.0, 2.0), 25.0, attenuation="inverse_square", shadows=True),
                            rs.DirectionalLight((-0.6, -0.5, -0.6), intensity=0.3)],
                    camera=rs.Camera(eye=(0.0, 1.2, 4.0), target=(0.0, -0.3, 0.0), width=width, height=height),
                    ambient=0.1)


def main(argv=None):
    """Draw the figures; ``--quick`` writes them into the git-ignored ``out/quick/images/``."""
    global IMAGES
    argv = sys.argv[1:] if argv is None else list(argv)
    quick = "--quick" in argv
    IMAGES = images_dir(quick)
    import raycast_shade as rs
    from raycast_shade.apps.explore import SIDE_BY_SIDE, Explorer
    from raycast_shade.output.imagefile import write_png

    os.makedirs(IMAGES, exist_ok=True)
    frame = rs.render(room(), "phong", terms="per_light")
    t = frame.terms
    grey = lambda m: np.repeat(m[..., None], 3, axis=-1)  # noqa: E731
    fig = rs.figures.montage([t["ambient"], t["diffuse"], t["specular"], grey(t["shadow"][0]), t["reflected"],
                              frame.image],
                             ["ambient  Ia ka", "diffuse  sum att Ii kd (n.s)", "specular  sum att Ii Ks (r.v)^t",
                              "shadow mask, lamp (lit = 1)", "reflected  rho x mirror ray", "image"],
                             columns=3, panel_width=3.2)
    fig.savefig(os.path.join(IMAGES, "teaching_terms.png"), dpi=100)
    fig = rs.figures.montage([t["diffuse_per_light"][0], t["diffuse_per_light"][1], t["specular_per_light"][0],
                              t["specular_per_light"][1]],
                             ["diffuse, lamp", "diffuse, fill light", "specular, lamp", "specular, fill light"],
                             columns=4, panel_width=2.6)
    fig.savefig(os.path.join(IMAGES, "teaching_per_light.png"), dpi=100)
    gouraud = rs.render(room(), "gouraud", terms=True)
    fig = rs.figures.montage([grey(frame.terms["shadow"][0]), grey(gouraud.terms["shadow"][0])],
                             ["shadow mask, Phong (per pixel)", "shadow mask, Gouraud (vertices interpolated)"],
                             panel_width=4.5)
    fig.savefig(os.path.join(IMAGES, "teaching_shadow_mask.png"), dpi=100)
    ex = Explorer(room(240, 180))
    ex.controls["shading"].value = SIDE_BY_SIDE
    ex.controls["wireframe"].value = True
    write_png(os.path.join(IMAGES, "teaching_explorer.png"), ex.picture())
    x, y = 140, 100
    print(frame.explain(x, y))
    ys, xs = np.nonzero(gouraud.hits.geom == 0)
    print(gouraud.explain(int(xs[len(xs) // 3]), int(ys[len(ys) // 3])))
    print(list(ex.controls))
    return 0


if __name__ == "__main__":
    main()
