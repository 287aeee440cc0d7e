"""The direct Embree binding: buffer lifetimes, the library version, what works
without the binding, concurrent first renders, and cast_rays' hit buffer."""

from __future__ import annotations

import ast
import gc
import pathlib
import pickle
import re
import subprocess
import sys
import textwrap
import threading
import time

import numpy as np
import pytest
from numba import njit

import raycast_shade as rs
from raycast_shade.scene import scene as scene_mod
from raycast_shade.visibility import accel as accel_mod
from raycast_shade.visibility import embree
from raycast_shade.visibility.accel import embree_accel, has_embree_accel

VISIBILITY = pathlib.Path(embree.__file__).parent


def _sphere_scene(shadows=False, mirror=False, width=48, height=36):
    sphere = rs.shapes.icosphere(3, radius=0.8)
    floor = rs.shapes.plane(size=4.0, subdivisions=2, center=(0.0, 0.0, -0.9), normal="+z")
    models = [rs.Model(rs.Mesh(sphere.vertices, sphere.faces, normals=sphere.normals),
                       rs.Material(kd=(0.8, 0.3, 0.2), ks=0.5, shininess=30)),
              rs.Model(floor, rs.Material(kd=0.6, reflectivity=0.4 if mirror else 0.0))]
    lights = [rs.PointLight((2.0, 3.0, 4.0), 20.0, attenuation="inverse_square", shadows=shadows),
              rs.DirectionalLight((1.0, -1.0, -1.0), 0.3)]
    cam = rs.Camera(eye=(0.3, 1.0, 4.0), target=(0.0, 0.0, 0.0), width=width, height=height)
    return rs.Scene(models, lights=lights, camera=cam, ambient=0.1)


# -- buffer lifetimes --------------------------------------------------------------------------------

# Run under glibc's free-poisoning (no thread cache, so every free is poisoned): a kernel
# handing Embree the address of an array Numba has already freed reads 0xA5 bytes (the
# RTCIntersectArguments' context and filter pointers become 0xA5A5...), and crashes or
# loses hits. Measured before the fix: the parallel camera kernel segfaulted here.
_POISONED = textwrap.dedent("""
    import ctypes, sys
    import numpy as np
    import numba

    libc = ctypes.CDLL(None)
    libc.malloc.restype = ctypes.c_void_p
    libc.malloc.argtypes = [ctypes.c_size_t]
    libc.free.argtypes = [ctypes.c_void_p]
    p = libc.malloc(96)
    ctypes.memset(p, 0, 96)
    libc.free(p)
    if ctypes.string_at(p + 32, 48) != b"\\xa5" * 48:
        print("NOPOISON")
        sys.exit(0)

    import raycast_shade as rs
    from raycast_shade.visibility import cast, embree
    from raycast_shade.visibility.accel import embree_accel
    from raycast_shade.visibility.rays import camera_frame, generate_rays

    sys.path.insert(0, sys.argv[2])
    from test_embree_binding import _sphere_scene

    scene = _sphere_scene()
    geo = scene.geometry
    handle = embree_accel(geo).handle
    cam = camera_frame(scene.camera, geo.origin)
    h, w = scene.camera.height, scene.camera.width
    out = {}
    for name, kernel in (("par", cast._cast_camera_parts), ("ser", cast._cast_camera_parts.serial)):
        hits = [np.empty((h, w), dt) for dt in (np.int32, np.int32, np.float32, np.float32, np.float32)]
        kernel(handle, cam, *hits, 0, 0, 0, h, np.full(h, -1, np.int64), 1e-3)
        out.update({f"cam_{name}_{i}": a for i, a in enumerate(hits)})
    o, d = generate_rays(scene.camera, geo.origin)
    o, d = o.astype(np.float64), d.astype(np.float64)
    n = len(o)
    for name, kernel in (("par", cast.cast_rays_kernel), ("ser", cast.cast_rays_kernel.serial)):
        hits = [np.empty(n, dt) for dt in (np.int32, np.int32, np.float32, np.float32, np.float32)]
        kernel(handle, o, d, np.zeros(n), np.full(n, np.inf), *hits)
        out.update({f"rays_{name}_{i}": a for i, a in enumerate(hits)})

    @numba.njit
    def blocked(handle, o, d):
        res = np.empty(len(o), np.bool_)
        for i in range(len(o)):
            buf = np.empty(20, np.float32)
            off = ((16 - buf.ctypes.data % 16) % 16) // 4
            ib = buf.view(np.uint32)
            for j in range(3):
                buf[off + j] = o[i, j]
                buf[off + 4 + j] = d[i, j]
            buf[off + 3] = 0.0
            buf[off + 7] = 0.0
            buf[off + 8] = np.inf
            ib[off + 9] = 0xFFFFFFFF
            ib[off + 10] = 0
            ib[off + 11] = 0
            embree.occluded1_ray(handle, buf[off:])
            res[i] = buf[off + 8] < 0.0
        return res

    out["blocked"] = blocked(handle, o, d)
    np.savez(sys.argv[1], **out)
    print("OK")
""")


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's malloc tunables")
def test_kernels_keep_their_embree_buffers_alive_when_frees_are_poisoned(tmp_path):
    """Every array whose address reaches Embree (the ray packet, the valid mask, the
    RTCIntersectArguments, the single-ray buffers) is alive during the call: the camera
    kernel in parts on two threads and whole in one, ``cast_rays_kernel`` both ways, and
    ``occluded1_ray``, all under poisoned frees, give exactly the hits of an ordinary run in
    this process."""
    import os

    env = dict(os.environ, GLIBC_TUNABLES="glibc.malloc.tcache_count=0:glibc.malloc.perturb=165")
    out = tmp_path / "hits.npz"
    proc = subprocess.run([sys.executable, "-c", _POISONED, str(out), str(pathlib.Path(__file__).parent)],
                          env=env, capture_output=True, text=True, timeout=900)
    if "NOPOISON" in proc.stdout:
        pytest.skip("this libc does not poison freed memory")
    assert proc.returncode == 0 and "OK" in proc.stdout, proc.stderr[-3000:]
    got = np.load(out)
    scene = _sphere_scene()
    geo = scene.geometry
    from raycast_shade.visibility import cast
    from raycast_shade.visibility.rays import camera_frame, generate_rays

    h, w = scene.camera.height, scene.camera.width
    ref = [np.empty((h, w), dt) for dt in (np.int32, np.int32, np.float32, np.float32, np.float32)]
    cast._cast_camera_kernel(embree_accel(geo).handle, camera_frame(scene.camera, geo.origin), *ref, 0, 0, 0, h,
                             np.empty(h, np.int64), 1e-3)
    assert (ref[0] >= 0).mean() > 0.3
    for name in ("par", "ser"):
        for i, a in enumerate(ref):
            np.testing.assert_array_equal(got[f"cam_{name}_{i}"], a)
    o, d = generate_rays(scene.camera, geo.origin)
    rays = rs.cast_rays(geo, o.astype(np.float64) + geo.origin, d.astype(np.float64))
    for name in ("par", "ser"):
        for i, a in enumerate(rays):
            np.testing.assert_array_equal(got[f"rays_{name}_{i}"], a)
    # Every camera ray that hits something is blocked, and only those.
    np.testing.assert_array_equal(got["blocked"], rays.prim >= 0)


_IR_ORDER = textwrap.dedent("""
    import re
    import numpy as np
    from numba import njit
    from raycast_shade.visibility import embree

    @njit
    def one(scene):
        buf = np.zeros(32, np.float32)
        embree.intersect1_ray(scene, buf[4:])

    @njit
    def packet(scene):
        buf = np.zeros(256, np.float32)
        valid = np.zeros(16, np.int32)
        args = np.zeros(embree.ARGS_SLOTS + 2, np.uint32)
        embree.intersect8_packet(valid[8:], scene, buf[8:], args[2:])

    @njit
    def packet16(scene):
        buf = np.zeros(512, np.float32)
        valid = np.zeros(32, np.int32)
        args = np.zeros(embree.ARGS_SLOTS + 2, np.uint32)
        embree.intersect16_packet(valid[16:], scene, buf[16:], args[2:])

    @njit
    def shadow(scene):
        buf = np.zeros(32, np.float32)
        embree.occluded1_ray(scene, buf[4:])

    @njit
    def shadow16(scene):
        buf = np.zeros(16 + 16 * embree.RAYHIT_SLOTS, np.float32)
        valid = np.zeros(32, np.int32)
        args = np.zeros(embree.ARGS_SLOTS + 2, np.uint32)
        embree.occluded16_packet(valid[16:], scene, buf[16:], args[2:])

    for fn, sym in ((one, "rtcIntersect1"), (packet, "rtcIntersect8"), (packet16, "rtcIntersect16"),
                    (shadow, "rtcOccluded1"), (shadow16, "rtcOccluded16")):
        fn.compile("(uintp,)")
        ir = fn.inspect_llvm()[fn.signatures[0]]
        body = ir[ir.index("define"):]
        body = body[:body.index("\\n}\\n")]
        events = re.findall(r"@" + sym + r"\\b|@NRT_decref", body)
        print(fn.__name__, " ".join(events))
""")


def test_the_wrappers_release_their_arrays_only_after_embree_returns():
    """In the LLVM IR Numba emits (with its refcount-pruning pass off, which would
    otherwise hide the order), no array is released before the Embree call that
    reads it. The same check on ``intersect1(scene, buf.ctypes.data, 0)`` written
    inline shows the decref *before* the call."""
    import os

    env = dict(os.environ, NUMBA_LLVM_REFPRUNE_PASS="0")
    proc = subprocess.run([sys.executable, "-c", _IR_ORDER], env=env, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    lines = dict(line.split(" ", 1) for line in proc.stdout.strip().splitlines())
    assert set(lines) == {"one", "packet", "packet16", "shadow", "shadow16"}
    for name, events in lines.items():
        events = events.split()
        call = [i for i, e in enumerate(events) if e != "@NRT_decref"]
        assert len(call) == 1, (name, events)
        assert "@NRT_decref" in events and "@NRT_decref" not in events[:call[0]], (name, events)


def _calls_to(tree, names):
    for node in ast.walk(tree):
        if isinstance(node, ast.Call):
            f = node.func
            name = f.attr if isinstance(f, ast.Attribute) else getattr(f, "id", None)
            if name in names:
                yield node


WRAPPERS = ("intersect1_ray", "intersect8_packet", "intersect16_packet", "occluded1_ray", "occluded16_packet")


RAW = {"intersect1", "intersect8", "intersect16", "occluded1", "occluded16"}
# What lays out or reads Embree's structs: only visibility/ may name these.
STRUCT_NAMES = {"write_ray", "reset_hit", "read_hit", "RAY_ORG", "RAY_DIR", "RAY_TFAR", "RAY_TNEAR", "RAY_TIME",
                "RAY_MASK", "RAY_ID", "RAY_FLAGS", "RAY16_SLOTS", "RAYHIT_SLOTS", "RAY_SLOTS", "HIT_GEOM_ID",
                "HIT_PRIM_ID", "HIT_U", "HIT_V", "ARGS_SLOTS"} | RAW


def test_no_raw_address_reaches_embree_outside_the_array_wrappers_and_the_query():
    """Only embree.py's wrappers and secondary.py (the query for secondary rays) call the raw
    ``rtcIntersect1/8/16`` / ``rtcOccluded1/16`` symbols; each pointer a wrapper passes is
    ``<parameter>.ctypes.data``: the kernels in visibility/ hand over arrays, which the call
    itself keeps alive (secondary.py's calls: the test below)."""
    bad = []
    for path in sorted(VISIBILITY.glob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        if path.name == "secondary.py":
            continue
        if path.name != "embree.py":
            bad += [f"{path.name}:{c.lineno}" for c in _calls_to(tree, RAW)]
            continue
        wrappers = {f.name: f for f in tree.body if isinstance(f, ast.FunctionDef)}
        for name in WRAPPERS:
            fn = wrappers[name]
            params = {a.arg for a in fn.args.args}
            (call,) = list(_calls_to(fn, RAW))
            for arg in call.args:
                if isinstance(arg, ast.Attribute) and arg.attr == "data":
                    ok = (isinstance(arg.value, ast.Attribute) and arg.value.attr == "ctypes"
                          and isinstance(arg.value.value, ast.Name) and arg.value.value.id in params)
                    if not ok:
                        bad.append(f"embree.py:{arg.lineno}")
                elif not (isinstance(arg, ast.Name) and arg.id == "scene") and not (
                        isinstance(arg, ast.Constant) and arg.value == 0):
                    bad.append(f"embree.py:{arg.lineno}: {ast.unparse(arg)}")
        others = [c for f in tree.body if isinstance(f, ast.FunctionDef) and f.name not in WRAPPERS
                  for c in _calls_to(f, RAW)]
        bad += [f"embree.py:{c.lineno}" for c in others]
    assert not bad, "raw Embree calls outside the array wrappers: " + ", ".join(bad)


def _address_of_live_array(arg) -> bool:
    """``X.ctypes.data`` or ``X.ctypes.data + offset``: an address taken from array ``X`` in the
    very expression that calls Embree (never an address kept in a variable past its array)."""
    if isinstance(arg, ast.BinOp) and isinstance(arg.op, ast.Add):
        arg = arg.left
    return (isinstance(arg, ast.Attribute) and arg.attr == "data" and isinstance(arg.value, ast.Attribute)
            and arg.value.attr == "ctypes" and isinstance(arg.value.value, ast.Name))


def _held_by_caller(fn) -> set:
    """The parameters of ``fn`` and the names unpacked from one (``buf, ib, off = S``): arrays
    whose caller holds them across the call."""
    params = {a.arg for a in fn.args.args}
    held = set(params)
    for node in ast.walk(fn):
        if (isinstance(node, ast.Assign) and isinstance(node.value, ast.Name) and node.value.id in params
                and isinstance(node.targets[0], ast.Tuple)):
            held |= {e.id for e in node.targets[0].elts if isinstance(e, ast.Name)}
    return held


def test_the_query_for_secondary_rays_takes_addresses_from_live_arrays():
    """secondary.py calls ``rtcOccluded1/16`` and ``rtcIntersect16`` directly (slicing an array
    per tile for a wrapper costs atomic reference counts): every pointer is computed from its
    array in the call expression itself, from an array the caller holds (a parameter, or unpacked
    from one) or that is read again after the call (so it is live while Embree uses the
    pointer); the scene handle is a name, the context 0."""
    tree = ast.parse((VISIBILITY / "secondary.py").read_text(encoding="utf-8"))
    bad, seen = [], 0
    for fn in [n for n in ast.walk(tree) if isinstance(n, ast.FunctionDef)]:
        held = _held_by_caller(fn)
        for call in _calls_to(fn, RAW):
            seen += 1
            where = f"secondary.py:{call.lineno}"
            for arg in call.args:
                if _address_of_live_array(arg):
                    name = (arg.left if isinstance(arg, ast.BinOp) else arg).value.value.id
                    later = [n for n in ast.walk(fn) if isinstance(n, ast.Name) and n.id == name
                             and n.lineno > call.end_lineno]
                    if not later and name not in held:
                        bad.append(f"{where}: {name} is neither held by the caller nor read after the call")
                elif not (isinstance(arg, ast.Name) and arg.id in ("handle", "scene")) and not (
                        isinstance(arg, ast.Constant) and arg.value == 0):
                    bad.append(f"{where}: {ast.unparse(arg)}")  # e.g. an address kept in a variable
    assert seen == 3, f"expected the query's three raw calls (occluded1, occluded16, intersect16), found {seen}"
    assert not bad, "raw Embree addresses not taken from a live array: " + ", ".join(bad)


def test_no_stage_above_visibility_lays_out_an_embree_struct():
    """The shading stage (and every other package but visibility/) asks
    :mod:`raycast_shade.visibility.secondary` for its rays' answers: it never names a struct
    slot, writes or reads a ray or hit, or calls Embree itself."""
    package = VISIBILITY.parent
    bad = []
    for path in sorted(package.rglob("*.py")):
        if path.parent == VISIBILITY:
            continue
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            name = node.attr if isinstance(node, ast.Attribute) else (
                node.id if isinstance(node, ast.Name) else None)
            if name in STRUCT_NAMES:
                bad.append(f"{path.relative_to(package)}:{node.lineno}: {name}")
            if isinstance(node, ast.ImportFrom) and node.module and node.module.endswith("embree"):
                bad += [f"{path.relative_to(package)}:{node.lineno}: imports {a.name}" for a in node.names
                        if a.name in STRUCT_NAMES]
    assert not bad, "Embree structs laid out outside visibility/: " + ", ".join(bad)


def test_the_accelerator_holds_the_buffers_embree_points_into():
    """Embree keeps raw pointers into the vertex and index arrays for the scene's
    lifetime: the accelerator holds those very arrays, whatever the caller drops."""
    geo = _sphere_scene().geometry
    v4, faces, voff, foff = _accel_inputs(geo)
    acc = accel_mod.EmbreeAccel(v4, faces, voff, foff)
    held_v, held_f = acc._arrays
    assert held_v is v4 and held_f is faces
    assert held_v.base is None and held_f.base is None  # owners, not views of something else


def _accel_inputs(geo):
    v4 = np.zeros((len(geo.vertices), 4), np.float32)
    v4[:, :3] = geo.vertices
    return v4, np.ascontiguousarray(geo.local_faces, dtype=np.uint32), geo.vertex_offsets, geo.face_offsets


# -- the library's version -----------------------------------------------------------------------------
@pytest.fixture
def version(monkeypatch):
    """Make the binding read another library version; restored (and re-read) afterwards."""

    def use(v):
        monkeypatch.setattr(embree, "_read_version", lambda lib, dev: v)
        embree._load.cache_clear()

    yield use
    monkeypatch.undo()
    embree._load.cache_clear()
    assert embree.available()


def test_the_binding_reads_embree_4():
    lib, _ = embree._open()
    v = embree._read_version(lib, embree._device())
    assert v // 10000 == 4
    assert embree.embree_version() == f"{v // 10000}.{(v // 100) % 100}.{v % 100}"
    assert embree.available() and embree.unavailable_reason() is None


def test_another_major_version_makes_the_direct_caster_unavailable(version):
    path = embree.library_path()
    scene = _sphere_scene()
    version(31305)
    assert not embree.available()
    why = embree.unavailable_reason()
    assert why.startswith(f"Embree 3.13.5 found in {path}; the kernels hard-code Embree 4's struct layouts")
    with pytest.raises(RuntimeError, match=r"caster 'embree' is unavailable: Embree 3\.13\.5 found in "):
        rs.cast_camera(scene, scene.camera, caster="embree")
    with pytest.raises(RuntimeError, match=r"direct Embree binding is unavailable: Embree 3\.13\.5"):
        accel_mod.EmbreeAccel(*_accel_inputs(scene.geometry))
    assert not has_embree_accel(scene.geometry)
    version(40001)  # any Embree 4 has the layouts
    assert embree.available()


# -- without the binding -------------------------------------------------------------------------------
_WHY = "libembree4 disabled by the test"


def _unbind(monkeypatch):
    monkeypatch.setattr(embree, "_load", lambda: (None, _WHY))
    assert not embree.available()


def test_without_the_binding_camera_rays_fall_back_to_embreex(monkeypatch):
    """A frame that traces camera rays alone renders through embreex: the very
    image of ``caster="embreex"`` with the binding present, for both backends."""
    scene = _sphere_scene()
    want = rs.render(scene, "phong", caster="embreex")
    want_raster = rs.render(scene, "gouraud", backend="raster")
    want_hits = rs.cast_camera(scene, scene.camera, caster="embreex")
    fresh = _sphere_scene()
    _unbind(monkeypatch)
    got = rs.render(fresh, "phong")
    np.testing.assert_array_equal(got.image, want.image)
    np.testing.assert_array_equal(got.hits.prim, want.hits.prim)
    np.testing.assert_array_equal(rs.render(fresh, "gouraud", backend="raster").image, want_raster.image)
    hits = rs.cast_camera(fresh, fresh.camera)
    for a, b in zip(hits, want_hits):
        np.testing.assert_array_equal(a, b)
    assert not has_embree_accel(fresh.geometry)
    # A mirror with no bounce traced needs no secondary ray either.
    assert rs.render(_sphere_scene(mirror=True), "phong", max_depth=0).hits.mask.any()


@pytest.mark.parametrize("kwargs, needs", [
    (dict(shadows=True), r"shadow rays \(scene\.lights\[0\]\)"),
    (dict(mirror=True), r"mirror rays \(scene\.models\[1\]\)"),
])
@pytest.mark.parametrize("backend", ["raycast", "raster"])
def test_without_the_binding_shadows_and_mirrors_are_refused_before_any_kernel(monkeypatch, kwargs, needs, backend):
    render_mod = sys.modules["raycast_shade.render"]  # the package's ``render`` attribute is the function

    scene = _sphere_scene(**kwargs)
    _unbind(monkeypatch)
    ran = []
    monkeypatch.setattr(render_mod, "cast_camera", lambda *a, **k: ran.append("cast"))
    monkeypatch.setattr(render_mod.bands, "cast_bands", lambda *a, **k: ran.append("bands"))
    monkeypatch.setattr(render_mod, "SampleShading", lambda *a, **k: ran.append("shade"))
    for caster in ("auto", "embreex"):
        with pytest.raises(RuntimeError, match=needs + r".* need the direct Embree binding .*unavailable: " + _WHY):
            rs.render(scene, "phong", backend=backend, caster=caster)
    assert ran == []


def test_without_the_binding_the_direct_paths_say_why(monkeypatch):
    scene = _sphere_scene()
    _unbind(monkeypatch)
    with pytest.raises(RuntimeError, match="caster 'embree' is unavailable: " + _WHY):
        rs.render(scene, "phong", caster="embree")
    with pytest.raises(RuntimeError, match="caster 'embree' is unavailable: " + _WHY):
        rs.cast_camera(scene, scene.camera, caster="embree")
    with pytest.raises(RuntimeError, match="cast_rays needs the direct Embree binding, which is unavailable: " + _WHY):
        rs.cast_rays(scene, [[0.0, 0.0, 5.0]], [[0.0, 0.0, -1.0]])
    with pytest.raises(ValueError, match="directions: row 0 is the zero vector"):  # bad input first, as ever
        rs.cast_rays(scene, [[0.0, 0.0, 5.0]], [[0.0, 0.0, 0.0]])
    with pytest.raises(RuntimeError, match="direct Embree binding is unavailable: " + _WHY):
        embree_accel(scene.geometry)


def test_secondary_rays_name_what_needs_the_binding():
    from raycast_shade.visibility.cast import secondary_rays

    assert secondary_rays(_sphere_scene(), 3) == ()
    assert secondary_rays(_sphere_scene(shadows=True, mirror=True), 3) == (
        "shadow rays (scene.lights[0])", "mirror rays (scene.models[1])")
    assert secondary_rays(_sphere_scene(mirror=True), 0) == ()


# -- concurrent first renders --------------------------------------------------------------------------
def test_threads_rendering_a_new_scene_share_one_geometry_and_one_bvh(monkeypatch):
    """Eight threads render one fresh Scene at once. The builds are slowed down so that,
    without the scene's lock, every thread would start its own: there is one geometry, one
    BVH, never released while the threads use it, and eight identical images."""
    geometries, accels, released = [], [], []

    class SlowGeometry(scene_mod.SceneGeometry):
        def __init__(self, models):
            time.sleep(0.05)
            super().__init__(models)
            geometries.append(self)

    class CountedAccel(embree.EmbreeAccel):
        def __init__(self, *args):
            time.sleep(0.05)
            super().__init__(*args)
            accels.append(self.handle)

        def __del__(self):
            released.append(self.handle)
            super().__del__()

    monkeypatch.setattr(scene_mod, "SceneGeometry", SlowGeometry)
    monkeypatch.setattr(accel_mod, "EmbreeAccel", CountedAccel)
    scene = _sphere_scene(shadows=True, mirror=True)
    n = 8
    barrier = threading.Barrier(n)
    frames, seen, errors = [None] * n, [None] * n, []

    def work(i):
        try:
            barrier.wait()
            frames[i] = rs.render(scene, "phong")
            seen[i] = scene.geometry
        except Exception as exc:  # pragma: no cover - reported below
            errors.append(exc)

    pool = [threading.Thread(target=work, args=(i,)) for i in range(n)]
    for th in pool:
        th.start()
    for th in pool:
        th.join()
    assert not errors, errors
    assert len(geometries) == 1 and all(g is geometries[0] for g in seen)
    assert len(accels) == 1 and released == []
    assert frames[0].hits.mask.mean() > 0.3
    for f in frames[1:]:
        np.testing.assert_array_equal(f.image, frames[0].image)
    serial = rs.render(_sphere_scene(shadows=True, mirror=True), "phong")
    np.testing.assert_array_equal(frames[0].image, serial.image)
    assert len(accels) == 2
    # The one BVH is released exactly once, with its scene.
    handle = accels[0]
    del scene, frames, seen, geometries, f, pool, work
    gc.collect()
    assert released.count(handle) == 1


def test_a_pickled_scene_gets_a_lock_and_builds_its_geometry_again():
    scene = _sphere_scene()
    geo = scene.geometry
    state = scene.__getstate__()
    assert "_geometry" not in state and "_geometry_lock" not in state
    back = pickle.loads(pickle.dumps(scene))
    assert not back.has_geometry
    assert back.geometry is back.geometry and back.geometry is not geo
    np.testing.assert_array_equal(back.geometry.vertices, geo.vertices)
    moved = scene.replace(camera=rs.Camera(eye=(0.0, 0.5, 4.0), width=8, height=6))
    assert moved.geometry is geo and moved._geometry_lock is not scene._geometry_lock


# -- cast_rays' record ---------------------------------------------------------------------------------
def test_cast_rays_returns_a_hit_buffer_of_rays():
    """Rays down onto a cube of side 2 at the origin meet its top face z = 1 at t = 6 - 1."""
    scene = rs.Scene([rs.shapes.cube(size=2.0)])
    hits = rs.cast_rays(scene, [[0.1, 0.2, 6.0], [0.1, 0.2, 6.0], [0.3, -0.4, 6.0]],
                        [[0.0, 0.0, -1.0], [0.0, 0.0, 1.0], [0.0, 0.0, -2.0]])
    assert isinstance(hits, rs.HitBuffer) and hits.shape == (3,)
    assert [a.dtype for a in hits] == [np.int32, np.int32, np.float32, np.float32, np.float32]
    np.testing.assert_array_equal(hits.mask, [True, False, True])
    np.testing.assert_allclose(hits.t[[0, 2]], [5.0, 2.5], rtol=1e-6)
    prim, geom, u, v, t = hits
    assert prim is hits.prim and t is hits.t and geom[1] == -1 and np.isinf(t[1])


def test_the_array_wrappers_trace_from_a_user_kernel():
    """``intersect1_ray`` writes the hit into the array it is given (and the packet
    wrapper is the camera kernel's, checked above)."""
    scene = rs.Scene([rs.shapes.cube(size=2.0)])
    handle = embree_accel(scene.geometry).handle

    @njit
    def down(handle, z):
        buf = np.empty(28, np.float32)
        off = ((16 - buf.ctypes.data % 16) % 16) // 4
        ib = buf.view(np.uint32)
        buf[off:off + 8] = np.array([0.1, 0.2, z, 0.0, 0.0, 0.0, -1.0, 0.0], np.float32)
        buf[off + 8] = np.inf
        ib[off + 9] = 0xFFFFFFFF
        ib[off + 10] = 0
        ib[off + 11] = 0
        ib[off + 18] = 0xFFFFFFFF
        embree.intersect1_ray(handle, buf[off:])
        return buf[off + 8], ib[off + 18]

    t, g = down(handle, 5.0)
    assert g == 0 and abs(t - 4.0) < 1e-6  # the top face is at z = 1
    t, g = down(handle, -5.0)
    assert g == embree.INVALID_ID and np.isinf(t)
