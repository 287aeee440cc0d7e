"""Peers at the limit: our Phong frame against Mesa llvmpipe and Open3D + Numba.

Run ``python -m benchmarks.bench_peers [--quick] [--repeats N]``. Four cases
(issue 16's table): an icosphere of 81,920 triangles and a noisy sphere of
1,310,720 triangles, each at 640x480 and 1920x1080; camera at ``(0, 0, 3)``
looking at the origin, fov 40 degrees; one point light (inverse square); the
Phong model with per-pixel interpolated, renormalised normals. Three
pipelines, each producing the (H, W, 3) float32 linear image:

``raycast_shade``
    ``rs.render(scene, "phong")``: Embree packets, hit buffer, Numba shading.
``llvmpipe``
    Mesa's software OpenGL rasterizer through moderngl on a headless EGL
    context (``GALLIUM_DRIVER=llvmpipe``, checked in ``GL_RENDERER``): one
    indexed draw into an RGBA32F framebuffer with a depth buffer, a GLSL
    per-fragment Phong shader that evaluates our equation (below), and the
    frame read back into NumPy (``glReadPixels``, part of its time) and
    flipped to y down (a view).
``open3d``
    Open3D's ``RaycastingScene.cast_rays`` over our camera rays (a Numba
    kernel), then our Numba Phong kernels on the hit buffer it returns.

Each case builds all three, warms each (JIT, BVH, shader compile) twice, then
times ``repeats`` rounds with the three interleaved (rotating order; fair
under bursts of load from other processes). Medians and minima; ratios
ours / peer of the medians; the system load average before and after each
case. The images are compared after the same 8-bit mapping (sRGB,
:func:`raycast_shade.output.tonemap.to_uint8`) on the pixels both cover: the
fraction within 2/255 in every channel, the largest difference, and the
count of pixels covered by one only (silhouettes).

The GLSL shader is our model term for term (see
:mod:`raycast_shade.shading.kernels`): the face oriented to the viewer
(``gl_FrontFacing``, the same test as ours), the interpolated normal
renormalised with the same sign, ``I = Ia ka + att Ii (kd n.s + ks (r.v)^t)``
with ``att = 1 / max(d, dmin)^2``; in float32 where ours is in float64. Our
reflection of a shading normal that points behind its face is left out by
default (``--gl-face-normals exact`` adds it, reading the face normal by
``gl_PrimitiveID`` from a storage buffer, about 20% slower). Pixel centres
at +0.5 in both; GL's rows are bottom up.

Outputs: ``benchmarks/results/peers.csv`` and ``docs/images/peers.png``; ``--quick`` (small meshes
and frames, 3 repeats) writes them under the git-ignored ``out/quick/`` (:mod:`benchmarks.outputs`).
``neighbour_rows`` is ``bench_limits --only openmp``: the frame next to another library's threads.

Needs the ``peers`` extra (``pip install 'raycast_shade[peers]'``: moderngl,
open3d) and, on Debian/Ubuntu, ``apt-get install -y libegl1 libegl-mesa0
libgl1-mesa-dri libgbm1 libusb-1.0-0``. A peer that cannot start is reported
(a CSV row with the reason) and skipped.
"""

from __future__ import annotations

import argparse
import csv
import functools
import json
import math
import os
import re
import subprocess
import sys
import time

import numpy as np

from benchmarks import outputs as where
from benchmarks.outputs import image_file, results_file

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)

FOV = 40.0
EYE = (0.0, 0.0, 3.0)
LIGHT = dict(position=(2.0, 3.0, 4.0), intensity=20.0, attenuation="inverse_square")
MATERIAL = dict(kd=(0.8, 0.3, 0.2), ks=0.5, shininess=40.0)

# (mesh, subdivision level, width, height)
CASES = [("icosphere", 6, 640, 480), ("icosphere", 6, 1920, 1080),
         ("noisy_sphere", 8, 640, 480), ("noisy_sphere", 8, 1920, 1080)]
QUICK_CASES = [("icosphere", 4, 320, 240), ("noisy_sphere", 5, 320, 240)]
PIPELINES = ("raycast_shade", "llvmpipe", "open3d")
KEYS = ["mesh", "triangles", "width", "height", "pipeline", "median_ms", "min_ms", "repeats", "setup_s",
        "ours_over_peer", "agree_2_255", "max_diff_255", "n_common", "coverage_mismatch", "load1_before",
        "load1_after", "note", "utc"]

# The aims for ours / llvmpipe (issue 41): at most this ratio, per (triangles, width, height).
AIMS = {(81920, 640, 480): 0.45, (81920, 1920, 1080): 0.75, (1310720, 640, 480): 0.30, (1310720, 1920, 1080): 0.30}
BEGIN, END = "<!-- peers:begin (benchmarks/bench_peers.py) -->", "<!-- peers:end -->"


# -- the scene ------------------------------------------------------------------------------------------

def noisy_sphere(subdivisions: int = 8, amplitude: float = 0.04):
    """An icosphere with its vertices moved radially by a smooth, deterministic
    noise (three octaves of products of sines): ``20 * 4**subdivisions``
    triangles, normals averaged from the faces, no two alike."""
    import raycast_shade as rs

    base = rs.shapes.icosphere(subdivisions)
    p = np.asarray(base.vertices)
    x, y, z = p[:, 0], p[:, 1], p[:, 2]
    noise = (np.sin(7.0 * x + 0.3) * np.sin(6.0 * y + 1.1) * np.sin(5.0 * z + 2.0)
             + 0.5 * np.sin(17.0 * x + 3.0) * np.sin(13.0 * y) * np.sin(19.0 * z + 1.0)
             + 0.25 * np.sin(41.0 * x + 0.7) * np.sin(37.0 * y + 2.3) * np.sin(43.0 * z))
    return rs.Mesh(p * (1.0 + amplitude * noise)[:, None], base.faces, name=f"noisy_sphere{subdivisions}")


@functools.lru_cache(maxsize=2)  # meshes are immutable; the two frame sizes share one
def make_mesh(kind: str, level: int):
    import raycast_shade as rs

    if kind == "icosphere":
        return rs.shapes.icosphere(level)
    if kind == "noisy_sphere":
        return noisy_sphere(level)
    raise ValueError(f"mesh: expected 'icosphere' or 'noisy_sphere', got {kind!r}")


def make_scene(mesh, width: int, height: int):
    """The benchmark scene: ``mesh``, the material, one point light, the camera."""
    import raycast_shade as rs

    return rs.Scene([rs.Model(mesh, rs.Material(**MATERIAL))], lights=[rs.PointLight(**LIGHT)],
                    camera=rs.Camera(eye=EYE, fov=FOV, width=width, height=height))


# -- llvmpipe ---------------------------------------------------------------------------------------------

_VERTEX = """
#version 430
uniform mat4 mvp;
in vec3 in_pos;
in vec3 in_nrm;
out vec3 v_pos;
out vec3 v_nrm;
void main() {
    v_pos = in_pos;
    v_nrm = in_nrm;
    gl_Position = mvp * vec4(in_pos, 1.0);
}
"""

# Our reflectance equation (raycast_shade.shading.kernels), one point light, inverse square.
# FACE_NORMALS selects how the geometric normal g is found: "facing" orients by
# gl_FrontFacing (the same test as ours, sign(g.v), for a perspective camera) and
# skips our reflection of a shading normal that points behind its face (it never
# fires on these meshes: the agreement column says so); "exact" reads g by
# gl_PrimitiveID from a storage buffer and does both, about 20% slower on llvmpipe.
_FRAGMENT = """
#version 430
#define EXACT_G @EXACT@
#if EXACT_G
layout(std430, binding = 0) readonly buffer FaceNormals { float fn[]; };
#endif
uniform vec3 eye;
uniform vec3 fwd;
uniform vec3 light_pos;
uniform vec3 light_rad;
uniform vec3 ambient;   // Ia * ka
uniform vec3 kd;
uniform vec3 ks;
uniform float shininess;
uniform float dmin;
in vec3 v_pos;
in vec3 v_nrm;
out vec4 color;
void main() {
    vec3 v = eye - v_pos;
    float vl = length(v);
    v = vl > 0.0 ? v / vl : -fwd;
#if EXACT_G
    int f = gl_PrimitiveID;
    vec3 g = vec3(fn[3 * f], fn[3 * f + 1], fn[3 * f + 2]);
    float sgn = 1.0;
    if (dot(g, v) < 0.0) { g = -g; sgn = -1.0; }
#else
    float sgn = gl_FrontFacing ? 1.0 : -1.0;
    vec3 g = v;  // only where the interpolated normal cancels
#endif
    float al = length(v_nrm);
    vec3 n = g;
    if (al >= 1e-6) {
        n = v_nrm * (sgn / al);
#if EXACT_G
        float c = dot(n, g);
        if (c < 0.0) n -= 2.0 * c * g;
#endif
    }
    vec3 col = ambient;
    vec3 d = light_pos - v_pos;
    float dist = length(d);
    if (dist > 0.0) {
        vec3 s = d / dist;
        float dd = max(dist, dmin);
        float att = 1.0 / (dd * dd);
        float nds = dot(n, s);
        if (nds > 0.0) {
            nds = min(nds, 1.0);
            vec3 r = 2.0 * nds * n - s;
            float c = dot(r, v);
            float spec = c > 0.0 ? pow(min(c, 1.0), shininess) : 0.0;
            col += att * light_rad * (kd * nds + ks * spec);
        }
    }
    color = vec4(col, 1.0);
}
"""
FACE_NORMALS = ("facing", "exact")


def _mvp(camera, origin, near, far):
    """(4, 4) float64 projection @ view for ``camera``, in the scene's re-centred frame."""
    right, up, fwd = camera.basis
    hw, hh = camera.half_extents()
    eye = camera.eye - origin
    view = np.eye(4)
    view[0, :3], view[1, :3], view[2, :3] = right, up, -fwd
    view[:3, 3] = -view[:3, :3] @ eye
    proj = np.zeros((4, 4))
    proj[0, 0] = 1.0 / hw
    proj[1, 1] = 1.0 / hh
    proj[2, 2] = -(far + near) / (far - near)
    proj[2, 3] = -2.0 * far * near / (far - near)
    proj[3, 2] = -1.0
    return proj @ view


def llvmpipe_context():
    """A headless moderngl context on Mesa's llvmpipe, or the reason there is none (str)."""
    os.environ["GALLIUM_DRIVER"] = "llvmpipe"  # read when Mesa loads its driver: before the first context
    try:
        import moderngl
    except ImportError as exc:
        return f"moderngl is not installed ({exc}): pip install 'raycast_shade[peers]'"
    try:
        ctx = moderngl.create_context(standalone=True, backend="egl")
    except Exception as exc:  # noqa: BLE001 - any EGL failure means: no peer, say why
        return (f"no EGL context ({exc}); on Debian: apt-get install -y libegl1 libegl-mesa0 libgl1-mesa-dri "
                "libgbm1")
    renderer = ctx.info["GL_RENDERER"]
    if "llvmpipe" not in renderer:
        ctx.release()
        return f"the EGL context is {renderer!r}, not llvmpipe"
    return ctx


def llvmpipe_pipeline(ctx, scene, camera, face_normals: str = "facing"):
    """(setup seconds, frame function) for the llvmpipe peer on ``ctx``.

    ``face_normals``: ``"facing"`` or ``"exact"`` (see ``FACE_NORMALS``).

    The frame function draws, reads the RGBA32F frame back and returns the
    (H, W, 3) float32 image (y down) and its (H, W) coverage (alpha)."""
    import moderngl

    t0 = time.perf_counter()
    geo = scene.geometry
    (light,) = scene.lights
    mat = geo.materials[0]
    w, h = camera.width, camera.height
    if face_normals not in FACE_NORMALS:
        raise ValueError(f"face_normals: expected one of {list(FACE_NORMALS)}, got {face_normals!r}")
    exact = face_normals == "exact"
    prog = ctx.program(vertex_shader=_VERTEX, fragment_shader=_FRAGMENT.replace("@EXACT@", "1" if exact else "0"))
    vbo_pos = ctx.buffer(np.ascontiguousarray(geo.vertices, np.float32).tobytes())
    vbo_nrm = ctx.buffer(np.ascontiguousarray(geo.normals, np.float32).tobytes())
    ibo = ctx.buffer(np.ascontiguousarray(geo.faces, np.uint32).tobytes())
    ssbo = ctx.buffer(np.ascontiguousarray(geo.face_normals, np.float32).tobytes()) if exact else None
    vao = ctx.vertex_array(prog, [(vbo_pos, "3f", "in_pos"), (vbo_nrm, "3f", "in_nrm")], index_buffer=ibo,
                           index_element_size=4)
    # Near and far planes around the bounding sphere of the re-centred scene.
    radius = float(np.linalg.norm(geo.vertices, axis=1).max())
    dist = float(np.linalg.norm(camera.eye - geo.origin))
    near, far = max(1e-3 * dist, 0.9 * (dist - radius)), 1.1 * (dist + radius)
    prog["mvp"].write(_mvp(camera, geo.origin, near, far).T.astype(np.float32).tobytes())  # column-major
    prog["eye"].value = tuple(camera.eye - geo.origin)
    prog["fwd"].value = tuple(camera.basis[2])
    prog["light_pos"].value = tuple(light.position - geo.origin)
    prog["light_rad"].value = tuple(light.radiance)
    prog["ambient"].value = tuple(np.asarray(scene.ambient) * mat[0:3])
    prog["kd"].value = tuple(mat[3:6])
    prog["ks"].value = tuple(mat[6:9])
    prog["shininess"].value = float(mat[9])
    prog["dmin"].value = 1e-6 * geo.scale
    fbo = ctx.framebuffer(color_attachments=[ctx.renderbuffer((w, h), 4, dtype="f4")],
                          depth_attachment=ctx.depth_renderbuffer((w, h)))
    ctx.enable(moderngl.DEPTH_TEST)
    ctx.disable(moderngl.CULL_FACE)  # two-sided, as ours
    bg = tuple(float(c) for c in scene.background)

    def frame():
        fbo.use()
        if ssbo is not None:
            ssbo.bind_to_storage_buffer(0)
        fbo.clear(bg[0], bg[1], bg[2], 0.0, depth=1.0)
        vao.render(moderngl.TRIANGLES)
        rgba = np.frombuffer(fbo.read(components=4, dtype="f4"), np.float32).reshape(h, w, 4)[::-1]
        return rgba[..., :3], rgba[..., 3] > 0.0

    frame()  # compiles the shader variant for this state
    return time.perf_counter() - t0, frame


# -- Open3D -------------------------------------------------------------------------------------------------

def open3d_pipeline(scene, camera):
    """(setup seconds, frame function) for Open3D's RaycastingScene + our Numba Phong kernels,
    or the reason it is unavailable (str)."""
    try:
        import open3d as o3d
    except ImportError as exc:
        return (f"open3d is not installed ({exc}): pip install 'raycast_shade[peers]' "
                "(on Debian also apt-get install -y libusb-1.0-0)")
    from raycast_shade.shading.shade import shade_hits
    from raycast_shade.visibility.hits import HitBuffer
    from raycast_shade.visibility.rays import generate_rays

    t0 = time.perf_counter()
    geo = scene.geometry
    o3 = o3d.t.geometry.RaycastingScene()
    o3.add_triangles(o3d.core.Tensor(geo.vertices.astype(np.float32)),
                     o3d.core.Tensor(geo.local_faces.astype(np.uint32)))
    o3.cast_rays(o3d.core.Tensor(np.array([[0, 0, 3, 0, 0, -1]], np.float32)))  # builds its BVH
    setup = time.perf_counter() - t0
    invalid = o3d.t.geometry.RaycastingScene.INVALID_ID
    h, w = camera.height, camera.width

    def frame():
        o, d = generate_rays(camera, geo.origin)
        ans = o3.cast_rays(o3d.core.Tensor(np.concatenate([o, d], axis=1)))
        prim = ans["primitive_ids"].numpy()
        uv = ans["primitive_uvs"].numpy()
        miss = (prim == invalid).reshape(h, w)
        prim = np.where(miss, -1, prim.reshape(h, w).astype(np.int32))
        hits = HitBuffer(prim=prim, geom=np.where(miss, -1, 0).astype(np.int32),
                         u=np.where(miss, 0.0, uv[:, 0].reshape(h, w)).astype(np.float32),
                         v=np.where(miss, 0.0, uv[:, 1].reshape(h, w)).astype(np.float32),
                         t=np.where(miss, np.inf, ans["t_hit"].numpy().reshape(h, w)).astype(np.float32))
        return shade_hits(scene, camera, hits, "phong"), ~miss

    return setup, frame


# -- a neighbour's thread pool in the same process (bench_limits --only openmp) --------------------------------

# Frames alone and right after a small call of the neighbour, interleaved: what slows the second is its idle workers.
NEIGHBOUR_CHILD = r"""
import json, os, re, sys, time
import numpy as np
neighbour, order, kind, level, w, h, repeats = sys.argv[1:3] + [sys.argv[3]] + [int(a) for a in sys.argv[4:]]
def load_neighbour():
    if neighbour == "none":  # no neighbour: the reference frame
        return (lambda: None), "none"
    if neighbour == "open3d":
        import open3d as o3d  # its runtime loads here, before ours unless ours_first
        from raycast_shade.scene.shapes import icosphere
        sc, ico = o3d.t.geometry.RaycastingScene(), icosphere(4)
        sc.add_triangles(o3d.core.Tensor(ico.vertices.astype(np.float32)), o3d.core.Tensor(ico.faces.astype(np.uint32)))
        rays = o3d.core.Tensor(np.tile(np.array([[0, 0, 3, 0, 0, -1]], np.float32), (4096, 1)))
        return lambda: sc.cast_rays(rays), o3d.__version__
    if neighbour == "flip_spinning":  # its runtime loads spinning (as Intel's or LLVM's 200 ms blocktime would)
        os.environ["OMP_WAIT_POLICY"] = "ACTIVE"
    import flip_evaluator
    if neighbour == "flip_spinning":
        os.environ.pop("OMP_WAIT_POLICY")
    a = np.random.default_rng(0).random((48, 64, 3)).astype(np.float32)
    call = lambda: flip_evaluator.evaluate(a, np.clip(a + 0.01, 0, 1).astype(np.float32), "LDR")
    call()  # loads its OpenMP runtime now, under the wait policy of the moment
    return call, neighbour
if order == "neighbour_first":
    call, version = load_neighbour()
import raycast_shade as rs, numba
if order == "ours_first":
    call, version = load_neighbour()
from benchmarks.bench_peers import make_mesh, make_scene
scene = make_scene(make_mesh(kind, level), w, h)
for _ in range(2):
    rs.render(scene, "phong"), call()
times = {"alone": [], "after": [], "neighbour": []}
for r in range(repeats):
    for k in (("alone", "after") if r % 2 == 0 else ("after", "alone")):
        time.sleep(0.3)  # the neighbour's workers, if any still spin, go idle (or keep spinning)
        if k == "after":
            t0 = time.perf_counter(), call()
            times["neighbour"].append(time.perf_counter() - t0[0])
        t0 = time.perf_counter(), rs.render(scene, "phong")
        times[k].append(time.perf_counter() - t0[0])
libs = sorted({os.path.basename(line.split()[-1]) for line in open("/proc/self/maps")
               if re.search(r"lib(gomp|iomp5|omp|tbb)[^/]*\.so", line)})
print(json.dumps(dict(layer=numba.threading_layer(), version=version, runtimes=libs, load=os.getloadavg()[0],
                      wait=os.environ.get("OMP_WAIT_POLICY", ""), **{k: float(np.median(v)) for k, v in times.items()})))
"""


# (neighbour, import order, environment): none, Open3D, FLIP's own GNU OpenMP (a second runtime), the same
# loaded spinning before us (os.environ set and restored around its import), the remedy: the user's policy.
OPENMP_VARIANTS = [("none", "ours_first", {}), ("open3d", "ours_first", {}), ("open3d", "neighbour_first", {}),
                   ("flip", "ours_first", {}), ("flip", "neighbour_first", {}), ("flip_spinning", "neighbour_first", {}),
                   ("flip", "neighbour_first", {"OMP_WAIT_POLICY": "PASSIVE"})]


def neighbour_rows(cases, repeats, root=ROOT):
    """Rows of ``bench_limits --only openmp``: the frame alone and right after a call of another library
    with its own thread pool, one child per variant (a runtime reads its wait policy when it loads)."""
    rows, times = [], ("alone", "after", "neighbour")  # the frame, the frame after a call, the call
    for kind, level, w, h in cases:
        for neighbour, order, extra in OPENMP_VARIANTS:
            env = dict(os.environ, PYTHONPATH=root + os.pathsep + os.environ.get("PYTHONPATH", ""))
            env = {k: v for k, v in env.items() if k not in ("OMP_WAIT_POLICY", "GOMP_SPINCOUNT", "KMP_BLOCKTIME")}
            env.update(extra)
            res = subprocess.run([sys.executable, "-c", NEIGHBOUR_CHILD, neighbour, order, kind, str(level), str(w),
                                  str(h), str(repeats)], cwd=root, env=env, capture_output=True, text=True)
            variant = f"{neighbour} {order}" + "".join(f" {k}={v}" for k, v in extra.items())
            if res.returncode != 0:
                print(f"limits: openmp {variant} skipped: {res.stderr.strip().splitlines()[-1:]}", file=sys.stderr)
                continue
            out = json.loads(res.stdout.strip().splitlines()[-1])
            base = dict(section="openmp", mesh=f"{kind}{level}", triangles=20 * 4 ** level, width=w, height=h,
                        variant=f"{variant} ({out['version']}; {out['layer']}; {' '.join(out['runtimes'])})",
                        load1=round(out["load"], 2))
            rows += [dict(base, metric=f"{k}_ms", value=round(1e3 * out[k], 2), unit="ms") for k in times]
            rows.append(dict(base, metric="after_over_alone", value=round(out["after"] / out["alone"], 3), unit="x"))
            print(f"limits: openmp {kind}{level} {w}x{h} {variant:45} alone {1e3 * out['alone']:.1f} ms, after "
                  f"{1e3 * out['after']:.1f} ms ({out['layer']}, {out['runtimes']}, load {out['load']:.1f})",
                  file=sys.stderr)
    return rows


# -- the run ----------------------------------------------------------------------------------------------

def agreement(img, cover, ref, ref_cover, tol: int = 2):
    """Compare two linear images after the 8-bit sRGB mapping.

    Returns
    -------
    dict
        ``agree_2_255``: fraction of the pixels both cover whose channels all
        differ by at most ``tol``/255; ``max_diff_255``; ``n_common``;
        ``coverage_mismatch``: pixels covered by exactly one of the two.
    """
    from raycast_shade.output.tonemap import to_uint8

    common = cover & ref_cover
    a = to_uint8(np.ascontiguousarray(img, np.float32)).astype(np.int16)
    b = to_uint8(np.ascontiguousarray(ref, np.float32)).astype(np.int16)
    diff = np.abs(a - b).max(axis=2)[common]
    n = int(common.sum())
    return dict(agree_2_255=round(float(np.mean(diff <= tol)), 6) if n else math.nan,
                max_diff_255=int(diff.max()) if n else 0, n_common=n,
                coverage_mismatch=int(np.count_nonzero(cover != ref_cover)))


def bench_case(kind, level, width, height, repeats, ctx, progress=True, face_normals="facing"):
    """Rows (see ``KEYS``) for one mesh and frame size."""
    import raycast_shade as rs

    load_before, started = os.getloadavg()[0], time.time()
    mesh = make_mesh(kind, level)
    scene = make_scene(mesh, width, height)
    cam = scene.camera
    t0 = time.perf_counter()
    first = rs.render(scene, "phong")  # BVH and JIT
    ours_setup = first.timings.get("build", time.perf_counter() - t0)

    def ours():
        f = rs.render(scene, "phong")
        return f.image, f.mask

    fns = {"raycast_shade": (ours_setup, ours)}
    notes = {}
    if isinstance(ctx, str):
        notes["llvmpipe"] = f"skipped: {ctx}"
    else:
        fns["llvmpipe"] = llvmpipe_pipeline(ctx, scene, cam, face_normals)
        notes["llvmpipe"] = f"{ctx.info['GL_RENDERER']}; face normals: {face_normals}"
    o3 = open3d_pipeline(scene, cam)
    if isinstance(o3, str):
        notes["open3d"] = f"skipped: {o3}"
    else:
        fns["open3d"] = o3
    out = {}
    for _ in range(2):  # warm-up: JIT, caches, page faults of the first frames
        out = {name: fn() for name, (_, fn) in fns.items()}
    names = list(fns)
    times = {name: [] for name in names}
    for r in range(repeats):
        for name in names[r % len(names):] + names[:r % len(names)]:
            fn = fns[name][1]
            ts = time.perf_counter()
            out[name] = fn()
            times[name].append(time.perf_counter() - ts)
    load_after = os.getloadavg()[0]
    tri = len(scene.geometry.faces)
    base = dict(mesh=f"{kind}{level}", triangles=tri, width=width, height=height, repeats=repeats,
                load1_before=round(load_before, 2), load1_after=round(load_after, 2),
                utc=time.strftime("%Y-%m-%d %H:%M", time.gmtime(started)))
    ours_med = float(np.median(times["raycast_shade"]))
    ref_img, ref_cover = out["raycast_shade"]
    rows = []
    for name in PIPELINES:
        if name not in fns:
            rows.append(dict(base, pipeline=name, median_ms=math.nan, min_ms=math.nan, setup_s=math.nan,
                             ours_over_peer=math.nan, agree_2_255=math.nan, max_diff_255=-1, n_common=0,
                             coverage_mismatch=-1, note=notes.get(name, "")))
            continue
        med = float(np.median(times[name]))
        img, cover = out[name]
        rows.append(dict(base, pipeline=name, median_ms=round(1e3 * med, 3),
                         min_ms=round(1e3 * float(np.min(times[name])), 3), setup_s=round(fns[name][0], 4),
                         ours_over_peer=round(ours_med / med, 3), note=notes.get(name, ""),
                         **agreement(img, cover, ref_img, ref_cover)))
    if progress:
        for row in rows:
            print(f"peers: {row['mesh']:14} {width:>4}x{height:<4} {row['pipeline']:14} "
                  f"{row['median_ms']:>9} ms  ours/peer {row['ours_over_peer']:>6}  "
                  f"agree {row['agree_2_255']}  load {base['load1_before']}->{base['load1_after']}",
                  file=sys.stderr)
    return rows


def run(quick: bool = False, repeats: int | None = None, progress: bool = True, face_normals: str = "facing"):
    ctx = llvmpipe_context()
    if isinstance(ctx, str):
        print(f"peers: llvmpipe skipped: {ctx}", file=sys.stderr)
    cases = QUICK_CASES if quick else CASES
    repeats = repeats or (3 if quick else 9)
    rows = []
    for kind, level, w, h in cases:
        rows += bench_case(kind, level, w, h, repeats, ctx, progress, face_normals)
    return rows


# -- output -------------------------------------------------------------------------------------------------

def write_csv(rows, path):
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "w", newline="") as fh:
        wr = csv.DictWriter(fh, fieldnames=KEYS)
        wr.writeheader()
        wr.writerows(rows)


def chart(rows, path):
    """Grouped bars: median ms per pipeline and case, ours/peer ratios written above."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cases = list(dict.fromkeys((r["mesh"], r["triangles"], r["width"], r["height"]) for r in rows))
    labels = {"raycast_shade": "ours (Embree + Numba)", "llvmpipe": "Mesa llvmpipe (moderngl, EGL)",
              "open3d": "Open3D cast_rays + Numba Phong"}
    colors = {"raycast_shade": "tab:blue", "llvmpipe": "tab:orange", "open3d": "tab:green"}
    fig, ax = plt.subplots(figsize=(9.5, 4.8))
    bw = 0.8 / len(PIPELINES)
    x = np.arange(len(cases))
    for k, name in enumerate(PIPELINES):
        vals = []
        for c in cases:
            m = [r["median_ms"] for r in rows if (r["mesh"], r["triangles"], r["width"], r["height"]) == c
                 and r["pipeline"] == name]
            vals.append(m[0] if m else math.nan)
        bars = ax.bar(x + (k - 1) * bw, vals, bw, label=labels[name], color=colors[name])
        if name != "raycast_shade":
            for b, c in zip(bars, cases):
                ratio = [r["ours_over_peer"] for r in rows if (r["mesh"], r["triangles"], r["width"],
                                                               r["height"]) == c and r["pipeline"] == name]
                if ratio and np.isfinite(ratio[0]):
                    ax.annotate(f"{ratio[0]:.2f}", (b.get_x() + b.get_width() / 2, b.get_height()),
                                ha="center", va="bottom", fontsize=8)
    ax.set_xticks(x)
    ax.set_xticklabels([f"{re.sub(r'[0-9]+$', '', m).replace('_', ' ')} {tri:,} tris\n{w}x{h}"
                        for m, tri, w, h in cases])
    ax.set_ylabel("median ms per Phong frame")
    loads = [r["load1_before"] for r in rows] + [r["load1_after"] for r in rows]
    ax.set_title(f"One Phong frame on {os.cpu_count()} cores, pipelines interleaved "
                 f"(load average {min(loads):.1f}-{max(loads):.1f}); above bars: ours / peer", fontsize=10)
    ax.legend(fontsize=8)
    fig.tight_layout()
    os.makedirs(os.path.dirname(path), exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _num(x) -> float:
    """A row's number, from :func:`bench_case` or from the CSV (text; empty or ``nan``: NaN)."""
    return float(x) if x not in ("", None) else math.nan


def _mesh_label(mesh: str, tri) -> str:
    return f"{re.sub(r'[0-9]+$', '', mesh).replace('_', ' ')}, {int(_num(tri)):,} tris"


def _span(first: str, last: str) -> str:
    """``2026-12-06 10:49–10:50`` (one day) or ``first to last``, from two ``YYYY-MM-DD HH:MM`` stamps."""
    if first == last:
        return first
    if first[:10] == last[:10]:
        return f"{first}–{last[11:]}"
    return f"{first} to {last}"


def table(rows) -> str:
    """The markdown table of ``rows`` (one run: :func:`run`'s or the CSV's) and, per case, the ratio
    ours / llvmpipe against its aim (:data:`AIMS`): what ``docs/performance.md`` shows between its
    ``peers`` markers."""
    cases = list(dict.fromkeys((r["mesh"], int(_num(r["triangles"])), int(_num(r["width"])), int(_num(r["height"])))
                               for r in rows))
    get = {(r["mesh"], int(_num(r["width"])), int(_num(r["height"])), r["pipeline"]): r for r in rows}

    def ms(row, bold=False):
        v = _num(row["median_ms"])
        if not math.isfinite(v):
            return "skipped"
        return f"**{v:.1f} ms**" if bold else f"{v:.1f} ms"

    def ratio(row):
        v = _num(row["ours_over_peer"])
        return f"{v:.2f}" if math.isfinite(v) else "-"

    out = ["| mesh | size | ours | llvmpipe | Open3D + Numba | ours / llvmpipe | ours / Open3D "
           "| within 2/255 of ours (llvmpipe) |", "|---|---|---|---|---|---|---|---|"]
    verdicts = []
    for mesh, tri, w, h in cases:
        ours, gl, o3 = (get[(mesh, w, h, name)] for name in PIPELINES)
        agree = _num(gl["agree_2_255"])
        within = f"{100 * agree:.4f}".rstrip("0").rstrip(".") + f"% (max {int(_num(gl['max_diff_255']))}/255)" \
            if math.isfinite(agree) else "-"
        out.append(f"| {_mesh_label(mesh, tri)} | {w}×{h} | {ms(ours, True)} | {ms(gl)} | {ms(o3)} | "
                   f"**{ratio(gl)}** | {ratio(o3)} | {within} |")
        aim, got = AIMS.get((tri, w, h)), _num(gl["ours_over_peer"])
        if aim is not None and math.isfinite(got):
            verdicts.append(f"{_mesh_label(mesh, tri)} at {w}×{h}: {got:.3f} (aim ≤ {aim:.2f}: "
                            f"{'met' if got <= aim else 'not met'})")
    loads = [_num(r[k]) for r in rows for k in ("load1_before", "load1_after")]
    when = sorted({r.get("utc") or "" for r in rows} - {""})
    out += ["", f"Medians of {int(_num(rows[0]['repeats']))} interleaved rounds, load average "
            f"{min(loads):.1f}–{max(loads):.1f}" + (f", {_span(when[0], when[-1])} UTC" if when else "") + "."]
    if verdicts:
        out += ["", "Ours / llvmpipe against the aims: " + "; ".join(verdicts) + "."]
    return "\n".join(out) + "\n"


def readme_quote(rows) -> str:
    """The README's sentence of figures from ``rows`` (the CSV's): ours over llvmpipe at both sizes
    of both meshes and the range over Open3D, each rounded half up to two places."""
    from decimal import ROUND_HALF_UP, Decimal

    def r2(x):
        return Decimal(str(x)).quantize(Decimal("0.01"), ROUND_HALF_UP)

    by = {(int(_num(r["triangles"])), int(_num(r["width"])), r["pipeline"]): _num(r["ours_over_peer"]) for r in rows}
    gl = [r2(by[(t, w, "llvmpipe")]) for t in (81920, 1310720) for w in (640, 1920)]
    o3 = [by[k] for k in by if k[2] == "open3d" and math.isfinite(by[k])]
    return (f"{gl[0]}× and {gl[1]}× its frame time at 81,920 triangles (640×480, 1080p), {gl[2]}× and {gl[3]}× "
            f"at 1.31 M; against Open3D's ray casting with the same shading, {r2(min(o3))}–{r2(max(o3))}×")


def write_table(rows, quick: bool) -> str:
    """Put :func:`table` between the markers of ``docs/performance.md`` (quick: ``out/quick/results/peers.md``)."""
    return where.write_table(table(rows), "peers.md", BEGIN, END, quick)


def outputs(quick: bool) -> list[str]:
    """The CSV and the chart :func:`main` writes (see :mod:`benchmarks.outputs`)."""
    return [results_file("peers.csv", quick), image_file("peers.png", quick)]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="small meshes and frames, 3 repeats; untracked output")
    ap.add_argument("--repeats", type=int, default=None, help="timed rounds per case (default 9, quick 3)")
    ap.add_argument("--gl-face-normals", choices=FACE_NORMALS, default="facing",
                    help="llvmpipe shader: orient by gl_FrontFacing (default) or read face normals (exact)")
    ap.add_argument("--table", action="store_true", help="only redo the docs table from the CSV")
    args = ap.parse_args(argv)
    csv_path, png_path = outputs(args.quick)
    if args.table:
        with open(csv_path, newline="") as fh:
            rows = list(csv.DictReader(fh))
        write_table(rows, args.quick)
        return rows
    rows = run(args.quick, args.repeats, face_normals=args.gl_face_normals)
    write_csv(rows, csv_path)
    chart(rows, png_path)
    write_table(rows, args.quick)
    return rows


if __name__ == "__main__":
    main()
