"""A fixed set of renders and their hashes: the bit-identity check of refactors.

Every shading mode (and ``auto``, and one method per model), both backends,
both interpolations, both casters, shadows, mirrors (0 and 5 bounces), Blinn,
every attenuation law, bump maps and an orthographic camera; per render the
image, the hit buffer, the shading normals and the depth are hashed.

The last bits of a render follow the machine's vector instruction set: Embree
runs its 16-wide AVX-512 or 8-wide AVX2 kernels, and LLVM vectorises the shading
kernels for the host, so one set of hashes serves one instruction set
(:func:`isa`). ``tests/data/golden_hashes.json`` (AVX-512) was written by this
module on the code before the stage-package refactor (8314fb5),
``golden_hashes.avx2.json`` by the same module on f316368 on an AVX2 machine,
before the one-evaluator change; a change that moves code must leave every hash
as it is. Regenerate them (``python -m tests.render.golden_renders --write``,
on a machine of each set) only for a change that means to alter images, and say
which and why in its commit.
"""

from __future__ import annotations

import hashlib
import json
import pathlib
import sys
import warnings

import numpy as np

import raycast_shade as rs
from raycast_shade.apps.demo import demo_scene



def isa() -> str:
    """The vector instruction set Embree and LLVM use here: ``"avx512"`` (Embree's AVX512 target
    needs F, CD, BW, DQ and VL), ``"avx2"``, or ``"other"`` (read from /proc/cpuinfo)."""
    try:
        text = pathlib.Path("/proc/cpuinfo").read_text()
    except OSError:
        return "other"
    flags = set()
    for line in text.splitlines():
        if line.startswith("flags"):
            flags = set(line.split(":", 1)[1].split())
            break
    if {"avx512f", "avx512cd", "avx512bw", "avx512dq", "avx512vl"} <= flags:
        return "avx512"
    return "avx2" if "avx2" in flags else "other"


_DATA = pathlib.Path(__file__).parents[1] / "data"
HASHES = _DATA / {"avx512": "golden_hashes.json"}.get(isa(), f"golden_hashes.{isa()}.json")


def digest(*arrays) -> str:
    m = hashlib.sha256()
    for a in arrays:
        a = np.ascontiguousarray(a)
        m.update(str(a.dtype).encode())
        m.update(str(a.shape).encode())
        m.update(a.tobytes())
    return m.hexdigest()[:16]


def scenes():
    yield "demo", demo_scene(160, 90)
    mesh = rs.shapes.icosphere(2)
    cam = rs.Camera(eye=(0.3, 0.5, 3.2), width=96, height=72, fov=40)
    yield "sphere_blinn_att", rs.Scene(
        [rs.Model(mesh, rs.Material(kd=(0.8, 0.3, 0.2), ks=0.5, shininess=40, specular="blinn"))],
        lights=[rs.PointLight((2, 3, 4), intensity=20, attenuation="inverse_square"),
                rs.PointLight((-2, 1, 3), intensity=2, attenuation="heuristic", k=0.5),
                rs.DirectionalLight((-1, -1, -1), intensity=0.3, color=(0.2, 0.4, 1.0))], camera=cam, ambient=0.1)
    yield "torus_noatt_nospec", rs.Scene(
        [rs.Model(rs.shapes.torus(1.0, 0.35, 24, 12), rs.Material(kd=0.7))],
        lights=[rs.PointLight((1, 2, 3), intensity=1.0)], camera=rs.Camera(eye=(0, 1.5, 3), width=80, height=64),
        ambient=0.05)
    ortho = rs.Camera(eye=(0.2, 0.4, 4), width=72, height=60, projection="orthographic", ortho_height=2.6)
    yield "ortho_shadow", rs.Scene(
        [rs.Model(rs.shapes.uv_sphere(rings=10, segments=16, radius=0.6), rs.Material(kd=0.8, ks=0.4, shininess=20)),
         rs.Model(rs.shapes.plane(size=3, subdivisions=4, center=(0, 0, -0.8), normal="+z"),
                  rs.Material(kd=0.5, reflectivity=0.3))],
        lights=[rs.PointLight((1, 1, 3), intensity=10, attenuation="inverse_square", shadows=True),
                rs.DirectionalLight((0.3, 0.2, -1), intensity=0.4, shadows=True)], camera=ortho, ambient=0.1)


def configurations(scene):
    cfgs = [dict(shading=mode, backend=backend, interpolation=interp)
            for mode in ("flat", "gouraud", "phong", "auto")
            for backend in ("raycast", "raster") for interp in ("perspective", "screen")]
    cfgs += [dict(shading="phong", caster="embreex"), dict(shading="gouraud", caster="embreex"),
             dict(shading=["flat", "gouraud", "phong", "phong", "gouraud"][:len(scene.models)]),
             dict(shading="phong", max_depth=0), dict(shading="phong", max_depth=5)]
    return cfgs


def render_hashes(keys=None) -> dict:
    """``{key: {image, hits, normal, depth}}`` for every (or the given) render."""
    out = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the demo's flat and Gouraud panels ignore its bump map on purpose
        for name, scene in scenes():
            for cfg in configurations(scene):
                key = name + ":" + json.dumps(cfg, sort_keys=True)
                if keys is not None and key not in keys:
                    continue
                f = rs.render(scene, **cfg)
                hb = f.hits
                out[key] = dict(image=digest(f.image), hits=digest(hb.prim, hb.geom, hb.u, hb.v, hb.t),
                                normal=digest(f.normal), depth=digest(f.depth))
    return out


if __name__ == "__main__":
    if sys.argv[1:] == ["--write"]:
        HASHES.write_text(json.dumps(render_hashes(), indent=1, sort_keys=True) + "\n")
    else:
        sys.exit("usage: python -m tests.render.golden_renders --write")
