"""Draw every figure of the docs: ``python -m docs.figures [--quick | --check] [--only NAME ...] [--list]``.

Each registered script is a module of this package with ``main(argv)``, called with
``["--quick"]`` in quick mode, which writes into the git-ignored quick/ folders
instead of ``docs/images/`` and ``benchmarks/results/`` (:mod:`benchmarks.outputs`).
One that fails is reported without stopping the others. ``--check`` draws in quick
mode and compares every picture with the tracked one of the same name, pixel by pixel:
the pictures of the docs are current when nothing differs. Exit status: 0 when every
script ran (and, with ``--check``, every picture matched), 1 otherwise. The measured
benchmarks are ``python -m benchmarks``.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
import time
import traceback

from benchmarks.outputs import images_dir

# name, module, the page whose pictures it draws
FIGURES = [
    dict(name="architecture", module="docs.figures.architecture", page="architecture.md"),
    dict(name="failure_cases", module="docs.figures.failure_cases", page="failure-cases.md"),
    dict(name="surfaces", module="docs.figures.surfaces", page="surfaces.md"),
    dict(name="textures", module="docs.figures.textures", page="textures.md"),
    dict(name="alpha", module="docs.figures.alpha", page="textures.md"),
    dict(name="normalmaps", module="docs.figures.normalmaps", page="textures.md"),
    dict(name="aa", module="docs.figures.aa", page="antialiasing.md"),
    dict(name="raster", module="docs.figures.raster", page="raster.md"),
    dict(name="vision", module="docs.figures.vision", page="vision.md"),
    dict(name="bop", module="docs.figures.bop", page="vision.md"),
    dict(name="motion", module="docs.figures.motion", page="vision.md"),
    dict(name="labels", module="docs.figures.labels", page="vision.md"),
    dict(name="teaching", module="docs.figures.teaching", page="teaching.md"),
    dict(name="gallery", module="docs.figures.gallery", page="gallery.md"),
    dict(name="animation", module="docs.figures.animation", page="animation.md"),
    dict(name="contract", module="docs.figures.contract", page="contract.md"),
    dict(name="gradients", module="docs.figures.gradients", page="gradients.md"),
    dict(name="normal_gradients", module="docs.figures.normal_gradients", page="gradients.md"),
    dict(name="photometric", module="docs.figures.photometric", page="gradients.md"),  # skipped without a mesh
    dict(name="gradients_edges", module="docs.figures.gradients_edges", page="gradients.md"),
    dict(name="gradients_shadow_edges", module="docs.figures.gradients_shadow_edges", page="gradients.md"),
    dict(name="pbr", module="docs.figures.pbr", page="pbr.md"),  # skipped without the Khronos samples
    dict(name="samples", module="docs.figures.samples", page="files.md"),  # skipped without the Khronos samples
]


def differing(new_dir, old_dir):
    """Pictures of ``new_dir`` whose pixels differ from the file of that name in ``old_dir``
    (or that ``old_dir`` lacks): ``[(name, why)]``."""
    import imageio.v3 as iio
    import numpy as np

    out = []
    for name in sorted(os.listdir(new_dir)):
        new, old = os.path.join(new_dir, name), os.path.join(old_dir, name)
        if not name.endswith((".png", ".gif")):
            continue
        if not os.path.exists(old):
            out.append((name, "not in " + os.path.relpath(old_dir)))
            continue
        a, b = iio.imread(new, index=None), iio.imread(old, index=None)
        if a.shape != b.shape:
            out.append((name, f"shape {a.shape} against {b.shape}"))
        elif not np.array_equal(a, b):
            d = np.abs(a.astype(np.int64) - b)
            out.append((name, f"max difference {d.max()}, in {np.count_nonzero(d.reshape(-1, d.shape[-1]).max(axis=1))} "
                              "pixel(s)"))
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m docs.figures", description="Draw the figures of the docs.")
    ap.add_argument("--quick", action="store_true", help="write into the git-ignored quick/ folders")
    ap.add_argument("--only", nargs="+", metavar="NAME", choices=[f["name"] for f in FIGURES],
                    help="draw only these")
    ap.add_argument("--list", action="store_true", help="list the scripts and their pages, draw nothing")
    ap.add_argument("--check", action="store_true", help="draw in quick mode and compare with docs/images")
    args = ap.parse_args(argv)
    args.quick = args.quick or args.check
    if args.list:
        for f in FIGURES:
            print(f"{f['name']:<14} {f['module']:<30} docs/{f['page']}")
        return 0
    code = 0
    for f in FIGURES:
        if args.only and f["name"] not in args.only:
            continue
        print(f"== {f['name']} (docs/{f['page']})", file=sys.stderr, flush=True)
        t0 = time.perf_counter()
        try:
            importlib.import_module(f["module"]).main(["--quick"] if args.quick else [])
        except Exception as exc:  # noqa: BLE001 - one failing script must not stop the others
            traceback.print_exc()
            print(f"   failed: {type(exc).__name__}: {exc}", file=sys.stderr)
            code = 1
            continue
        print(f"   done in {time.perf_counter() - t0:.1f} s", file=sys.stderr, flush=True)
    if args.check:
        diff = differing(images_dir(True), images_dir(False))
        for name, why in diff:
            print(f"docs/images/{name}: {why}")
        print(f"{len(diff)} picture(s) differ from docs/images", file=sys.stderr)
        code = max(code, 1 if diff else 0)
    return code


if __name__ == "__main__":
    sys.exit(main())
