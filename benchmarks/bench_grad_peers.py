"""Gradients beside a peer: ``rs.grad`` against Mitsuba 3's ``llvm_ad_rgb`` on one diffuse scene.

Run ``python -m benchmarks.bench_grad_peers [--quick]``. The scene, the same for both: an icosphere
of 5,120 triangles (``rs.shapes.icosphere(4)``, handed to Mitsuba as an OBJ file of the same
vertices and faces), a diffuse material (kd 0.6, no specular lobe), one inverse-square point
light, a 45-degree perspective camera at 640x480, one sample per pixel, direct illumination only,
no shadows to cast. Interleaved in one process, after a warm-up call of each:

* ``rs forward``: ``rs.render(scene, "phong")``; ``rs grad``: ``rs.grad`` of ``sum(W * I)`` with
  respect to kd (and, in ``rs grad all``, every material, ambient and light parameter) over the
  frame's hits; ``rs forward+grad``: the frame and its kd gradient, what Mitsuba's row below does;
* ``mitsuba forward``: ``mi.render`` with the ``prb`` integrator at ``max_depth=2`` (direct light
  only: Mitsuba's reverse-mode integrator; its ``direct`` integrator gives the same image), the
  image evaluated; ``mitsuba forward+backward``: the same render with the reflectance's gradient
  enabled, a loss ``sum(W * I)`` and ``dr.backward`` to ``dr.grad`` of the reflectance, evaluated.

Each ``ratio`` is over its own renderer's forward median: the issue's budget is the gradient in
at most 3x the forward frame. Rows carry the 1-minute load average. Mitsuba's first calls compile
its kernels (LLVM), ours load Numba's cache or compile: those are the ``first ...`` rows. Mitsuba
not installed (it is in the ``[peers]`` extra), or its LLVM back end not found, is a row saying so;
drjit 1.5 needs libLLVM 16 or newer (Debian 12: ``apt-get install libllvm19``), which the benchmark
points ``DRJIT_LIBLLVM_PATH`` at unless it is set. The ``agreement`` row compares the two images
(ours divided by pi: Mitsuba's diffuse BSDF is ``rho/pi``, the lecture's Lambert term ``kd``) over
the pixels both light: the median relative difference, Mitsuba's one jittered sample per pixel
against our pixel centres. PyTorch3D is not measured: it needs PyTorch, and PyPI has no PyTorch3D
distribution for Linux and Python 3.11 (see docs/gradients.md). Results:
``benchmarks/results/grad_peers.csv``; ``--quick`` runs 160x120 with
3 repeats into the git-ignored ``out/quick/results/``.
"""

from __future__ import annotations

import argparse
import glob
import os
import re
import statistics
import tempfile
import time

import numpy as np

from benchmarks.outputs import results_file, write_csv

FIELDS = ["benchmark", "case", "width", "height", "repeats", "ms_median", "ratio", "load", "note"]
KD, INTENSITY, LIGHT, EYE, FOV = 0.6, 20.0, (2.0, 3.0, 4.0), (0.0, 0.0, 4.0), 45.0


def _rs_scene(width, height):
    import raycast_shade as rs

    return rs.Scene([rs.Model(rs.shapes.icosphere(4), rs.Material(kd=KD, ka=0.0, ks=0.0))],
                    lights=[rs.PointLight(LIGHT, intensity=INTENSITY, attenuation="inverse_square")],
                    camera=rs.Camera(eye=EYE, target=(0.0, 0.0, 0.0), fov=FOV, width=width, height=height),
                    ambient=0.0)


def _timed(fn):
    t0 = time.perf_counter()
    fn()
    return (time.perf_counter() - t0) * 1e3


def _load():
    return round(os.getloadavg()[0], 2)


def _newest_llvm() -> bool:
    """Set ``DRJIT_LIBLLVM_PATH`` (unless set) to the newest system libLLVM of major version 16 or more:
    drjit 1.5's kernels use ``llvm.minimum``, which LLVM 15's x86 back end cannot select (it aborts
    the process: "LLVM ERROR: Cannot select ... fminimum"), and drjit may find 15 first. Returns
    whether a path is set (False: none found, and drjit must not be loaded)."""
    if "DRJIT_LIBLLVM_PATH" in os.environ:
        return True
    found = []
    for path in glob.glob("/usr/lib/*/libLLVM*.so*") + glob.glob("/usr/lib/llvm-*/lib/libLLVM*.so*"):
        m = re.search(r"libLLVM(?:-|\.so\.)(\d+)", os.path.basename(path))
        if m and int(m.group(1)) >= 16:
            found.append((int(m.group(1)), path))
    if found:
        os.environ["DRJIT_LIBLLVM_PATH"] = max(found)[1]
    return bool(found)


def _mitsuba_cases(mesh, width, height, weights, folder):
    """``{case: callable}`` for Mitsuba 3's llvm_ad_rgb, or a string saying why it cannot run."""
    if not _newest_llvm():  # an older LLVM would abort the whole process inside drjit, not raise
        return ("drjit needs libLLVM 16 or newer and none was found (apt-get install libllvm19, or set "
                "DRJIT_LIBLLVM_PATH)")
    try:
        import drjit as dr
        import mitsuba as mi
    except ImportError as exc:
        return f"mitsuba is not installed ({exc}): pip install 'raycast_shade[peers]' (or pip install mitsuba)"
    try:
        mi.set_variant("llvm_ad_rgb")
    except Exception as exc:  # noqa: BLE001 - drjit says why LLVM is missing; the row quotes it
        return f"llvm_ad_rgb unavailable: {type(exc).__name__}: {exc} (apt-get install libllvm19; DRJIT_LIBLLVM_PATH)"
    obj = os.path.join(folder, "sphere.obj")
    with open(obj, "w") as fh:
        fh.writelines(f"v {x:.17g} {y:.17g} {z:.17g}\n" for x, y, z in mesh.vertices)
        fh.writelines(f"vn {x:.17g} {y:.17g} {z:.17g}\n" for x, y, z in mesh.normals)
        fh.writelines(f"f {a}//{a} {b}//{b} {c}//{c}\n" for a, b, c in mesh.faces + 1)
    scene = mi.load_dict({
        "type": "scene",
        "integrator": {"type": "prb", "max_depth": 2},
        "sensor": {"type": "perspective", "fov": FOV, "fov_axis": "y",
                   "to_world": mi.ScalarTransform4f().look_at(origin=list(EYE), target=[0, 0, 0], up=[0, 1, 0]),
                   "film": {"type": "hdrfilm", "width": width, "height": height, "rfilter": {"type": "box"},
                            "pixel_format": "rgb"},
                   "sampler": {"type": "independent", "sample_count": 1}},
        "sphere": {"type": "obj", "filename": obj, "face_normals": False,
                   "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": [KD, KD, KD]}}},
        "light": {"type": "point", "position": list(LIGHT), "intensity": {"type": "rgb", "value": [INTENSITY] * 3}},
    })
    params = mi.traverse(scene)
    key = "sphere.bsdf.reflectance.value"
    w = mi.TensorXf(weights.astype(np.float32))

    def forward():
        img = mi.render(scene, params, spp=1, seed=0)
        dr.eval(img)
        dr.sync_thread()
        return img

    def backward():
        dr.enable_grad(params[key])
        params.update()
        img = mi.render(scene, params, spp=1, seed=0)
        dr.backward(dr.sum(img * w, axis=None))
        g = dr.grad(params[key])
        dr.eval(g)
        dr.sync_thread()
        dr.disable_grad(params[key])
        params.update()
        return g

    return {"mitsuba forward": forward, "mitsuba forward+backward": backward}


def run(quick: bool = False):
    import raycast_shade as rs
    from raycast_shade.gradients import DEFAULT_WRT

    w, h = (160, 120) if quick else (640, 480)
    repeats = 3 if quick else 15
    scene = _rs_scene(w, h)
    weights = np.random.default_rng(0).standard_normal((h, w, 3))
    frame = rs.render(scene, "phong")
    cases = {"rs forward": lambda: rs.render(scene, "phong"),
             "rs grad": lambda: rs.grad(scene, weights, ("kd",), frame=frame),
             "rs grad all": lambda: rs.grad(scene, weights, DEFAULT_WRT, frame=frame),
             "rs forward+grad": lambda: rs.grad(scene, weights, ("kd",), frame=rs.render(scene, "phong"))}
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        peer = _mitsuba_cases(scene.models[0].mesh, w, h, weights, folder)
        if not isinstance(peer, str):
            ours = frame.image.astype(np.float64) / np.pi
            theirs = np.asarray(peer["mitsuba forward"](), np.float64)[..., :3]
            both = (ours[..., 1] > 1e-3) & (theirs[..., 1] > 1e-3)
            rel = float(np.median(np.abs(theirs[both] - ours[both]) / ours[both]))
            rows.append(dict(benchmark="grad_peers", case="agreement", width=w, height=h, repeats=1, ms_median="",
                             ratio=round(rel, 4), load=_load(),
                             note=f"median |mitsuba - rs/pi| / (rs/pi) over {int(both.sum())} pixels both lit"))
            print(f"images: median relative difference {rel:.4f} over {int(both.sum())} pixels")
        if isinstance(peer, str):
            print(peer)
            rows.append(dict(benchmark="grad_peers", case="mitsuba", width=w, height=h, repeats=0, ms_median="",
                             ratio="", load=_load(), note=peer))
        else:
            cases.update(peer)
        rows += [dict(benchmark="grad_peers", case=f"first {name}", width=w, height=h, repeats=1,
                      ms_median=round(_timed(fn), 1), ratio="", load=_load(), note="compile or cache load included")
                 for name, fn in cases.items()]
        times = {name: [] for name in cases}
        for _ in range(repeats):  # interleaved: each repeat times every case once
            for name, fn in cases.items():
                times[name].append(_timed(fn))
    notes = {"rs forward": "render(): cast and shade", "rs grad": "dL/dkd over the frame's hits",
             "rs grad all": "every material, ambient and light parameter",
             "rs forward+grad": "render() then dL/dkd: Mitsuba's forward+backward's like",
             "mitsuba forward": "llvm_ad_rgb, prb max_depth=2, 1 spp",
             "mitsuba forward+backward": "the render with AD on, dr.backward to the reflectance"}
    for name, ms in times.items():
        med = statistics.median(ms)
        base = statistics.median(times["mitsuba forward" if name.startswith("mitsuba") else "rs forward"])
        rows.append(dict(benchmark="grad_peers", case=name, width=w, height=h, repeats=repeats,
                         ms_median=round(med, 2), ratio=round(med / base, 2), load=_load(), note=notes[name]))
        print(f"{name:26s} {w}x{h}: median {med:8.2f} ms  ({med / base:.2f} x its forward)")
    return rows


def outputs(quick: bool) -> list[str]:
    """The CSV :func:`main` writes (see :mod:`benchmarks.outputs`)."""
    return [results_file("grad_peers.csv", quick)]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="160x120, 3 repeats; untracked output")
    args = ap.parse_args(argv)
    rows = run(args.quick)
    path, = outputs(args.quick)
    write_csv(path, rows, FIELDS)
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
