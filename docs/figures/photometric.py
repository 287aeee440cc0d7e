"""Figure for docs/gradients.md: photometric stereo on a real mesh.

``python -m docs.figures.photometric MESH [--quick]`` (or ``RS_PHOTOMETRIC_MESH=MESH``) writes
``photometric_stereo.png`` into ``docs/images/``: the mesh (any file ``rs.Mesh.load`` reads; the
docs' picture is trimesh's ``models/bunny.ply``, the Stanford bunny, which the repository does
not ship) rendered Lambertian (kd 0.7, no ambient, no specular lobe) under four directional
lights, then each pixel's normal recovered by least squares from the lights that reach it
(``I_i = rho s_i . n``: three or more needed, else "cannot tell", grey); the angular error
against the renderer's own shading normal (the ``normal`` buffer) with the images exact, and
with Gaussian noise of standard deviation 0.01 added (a camera's; the brightest
pixels are about 0.7); median and 95th percentile in degrees in the titles.
Without a mesh it says so and draws nothing (exit status 2), as ``python -m docs.figures`` expects.
"""

from __future__ import annotations

import os
import sys
import warnings

import numpy as np

import raycast_shade as rs

from benchmarks.outputs import images_dir

DIRECTIONS = [(-0.5, -0.3, -1.0), (0.5, -0.3, -1.0), (0.0, 0.55, -1.0), (0.1, -0.6, -0.8)]
NOISE = 0.01


def frames(mesh, width, height):
    """The four renders (with the ``normal`` buffer) of ``mesh`` framed by the camera."""
    lights = [rs.DirectionalLight(d) for d in DIRECTIONS]
    base = rs.Scene([rs.Model(mesh, rs.Material(kd=0.7, ka=0.0, ks=0.0))], lights=lights[:1],
                    camera=rs.Camera.fit(mesh, direction=(0.0, 0.0, -1.0), width=width, height=height), ambient=0.0)
    with warnings.catch_warnings():  # a scan's sharp folds: its averaged normals are what is wanted here
        warnings.simplefilter("ignore", rs.CreaseWarning)
        return [rs.render(base.replace(lights=(light,)), "phong", buffers=("normal",)) for light in lights]


def solve(images, threshold=1e-4):
    """Per-pixel least-squares normals from ``images`` (H, W, K) under :data:`DIRECTIONS`.

    Returns the unit normals (H, W, 3) (0 where fewer than three lights reach a pixel) and that
    mask (H, W): the pixels it can tell."""
    S = -np.array([d / np.linalg.norm(d) for d in DIRECTIONS])  # rows: towards the lights
    lit = images > threshold
    out = np.zeros(images.shape[:2] + (3,))
    told = lit.sum(axis=-1) >= 3
    for pattern in np.unique(lit[told], axis=0):  # one solve per subset of lights
        sel = told & np.all(lit == pattern, axis=-1)
        g, *_ = np.linalg.lstsq(S[pattern], images[sel][:, pattern].T, rcond=None)
        out[sel] = (g / np.linalg.norm(g, axis=0)).T
    return out, told


def angular_error(n, truth):
    return np.degrees(np.arccos(np.clip(np.sum(n * truth, axis=-1), -1.0, 1.0)))


def main(argv=None):
    argv = sys.argv[1:] if argv is None else list(argv)
    paths = [a for a in argv if not a.startswith("-")] or [os.environ.get("RS_PHOTOMETRIC_MESH", "")]
    if not os.path.isfile(paths[0]):
        print("docs.figures.photometric: skipped, it needs a mesh: python -m docs.figures.photometric MESH [--quick] "
              "or RS_PHOTOMETRIC_MESH=MESH (the docs' picture: trimesh's models/bunny.ply)", file=sys.stderr)
        return 2
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    quick = "--quick" in argv
    mesh = rs.Mesh.load(paths[0])
    fs = frames(mesh, 400, 300)  # the same in quick mode (its own folder), so that --check compares like with like
    images = np.stack([f.image[..., 1].astype(np.float64) for f in fs], -1)
    truth = fs[0].buffers["normal"].astype(np.float64)
    hit = fs[0].hits.prim >= 0
    noisy = images + NOISE * np.random.default_rng(0).standard_normal(images.shape) * hit[..., None]
    fig, axes = plt.subplots(1, 4, figsize=(18, 4.0), gridspec_kw=dict(width_ratios=[2, 1.3, 1.3, 1]))
    axes[0].imshow(np.concatenate([rs.to_uint8(f.image) for f in fs[:2]], axis=1)); axes[0].axis("off")
    axes[0].set_title("two of the four renders")
    for ax, (label, imgs) in zip(axes[1:3], (("exact images", images), (f"noise sd {NOISE}", noisy))):
        n, told = solve(imgs)
        err = np.where(told & hit, angular_error(n, truth), np.nan)
        med, p95 = np.nanmedian(err), np.nanpercentile(err, 95)
        shown = ax.imshow(err, cmap="magma", vmin=0.0, vmax=max(p95, 1e-3))
        ax.set_facecolor("0.6"); ax.axis("off")
        ax.set_title(f"angular error, {label}\nmedian {med:.2g} deg, 95th pct {p95:.2g} deg")
        fig.colorbar(shown, ax=ax, fraction=0.04, label="degrees")
        print(f"{label}: {int((told & hit).sum())} of {int(hit.sum())} pixels told; median {med:.3g} deg, "
              f"95th percentile {p95:.3g} deg")
        if label.startswith("exact"):
            normals, known = n, told & hit
    axes[3].imshow(np.where(known[..., None], 0.5 + 0.5 * normals, 0.6)); axes[3].axis("off")
    axes[3].set_title("recovered normals\n(grey: fewer than 3 lights)")
    fig.suptitle(f"Photometric stereo on {os.path.basename(paths[0])}: least squares per pixel, 4 directional lights")
    plt.tight_layout()
    out = images_dir(quick)
    os.makedirs(out, exist_ok=True)
    path = os.path.join(out, "photometric_stereo.png")
    fig.savefig(path, dpi=80)
    print("wrote", path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
