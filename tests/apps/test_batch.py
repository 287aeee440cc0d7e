"""Batch rendering and animations: serial and on a 2-worker Dask cluster.

One local cluster (two single-threaded worker processes) serves the whole
module. Images are tiny (48x36) so that the file is dominated by the
cluster's start-up, not by rendering.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import pickle
import tempfile

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.visibility.accel import embree_accel, embreex_scene, has_embree_accel
from raycast_shade.apps import animate
from raycast_shade.apps import batch
from raycast_shade.output.imagefile import write_image

distributed = pytest.importorskip("distributed")  # a test dependency: only skipped where it is missing

W, H = 48, 36


def _scene():
    return rs.Scene(
        [rs.Model(rs.shapes.icosphere(2), rs.Material(kd=(0.8, 0.35, 0.2), ks=0.6, shininess=30)),
         rs.Model(rs.shapes.icosphere(1), rs.Material(kd=(0.2, 0.5, 0.8)))],
        lights=[rs.PointLight((2.0, 3.0, 4.0), intensity=20.0, attenuation="inverse_square"),
                rs.DirectionalLight((-1.0, -0.5, -1.0), intensity=0.3)],
        camera=rs.Camera(eye=(0.3, 0.5, 4.0), width=W, height=H),
    )


@pytest.fixture(scope="module")
def scene():
    s = _scene()
    for shading in ("flat", "gouraud", "phong"):  # JIT (or load the cache) here, before the workers start
        rs.render(s, shading)
    return s


@pytest.fixture(scope="module")
def client(scene):
    with batch.local_cluster(2, numba_threads=1) as c:
        yield c


def _serial(scenes, cameras, shading="phong"):
    return [rs.render(s, shading, camera=c).image for s, c in zip(scenes, cameras)]


def _worker_totals(client):
    stats = batch.worker_stats(client)
    return {k: sum(s[k] for s in stats.values()) for k in ("builds", "renders", "skipped")}, stats


# -- pickling and planning -------------------------------------------------------------------------------


def test_scene_pickles_without_geometry(scene):
    s = scene.replace()  # shares the built geometry and BVH
    assert has_embree_accel(s.geometry)
    data = pickle.dumps(s)
    back = pickle.loads(data)
    assert not back.has_geometry
    assert batch.scene_key(back) == batch.scene_key(s)
    # Unpickled arrays are writeable: re-validate the camera so that Numba reuses the read-only specialisation.
    back = back.replace(camera=dataclasses.replace(back.camera), ambient=back.ambient)
    assert np.array_equal(rs.render(back, "phong").image, rs.render(s, "phong").image)
    geom = pickle.loads(pickle.dumps(s.geometry))
    assert not has_embree_accel(geom) and np.array_equal(geom.vertices, s.geometry.vertices)


def test_meshes_do_not_travel_with_frames(scene):
    bases, jobs = batch.plan_batch(scene, cameras=animate.orbit_cameras(scene.camera, 5))
    assert len(bases) == 1 and [j.index for j in jobs] == list(range(5))
    bases, jobs = batch.plan_batch(animate.orbit_light(scene, 5))
    assert len(bases) == 1 and len({j.key for j in jobs}) == 1
    job_size = max(len(pickle.dumps(j)) for j in jobs)
    assert job_size < 4000
    assert len(pickle.dumps(scene)) > 10 * job_size


def test_scene_key_is_content_not_identity(scene):
    a, b = _scene(), _scene()
    assert batch.scene_key(a) == batch.scene_key(b) == batch.scene_key(a.replace(lights=[]))
    other = rs.Scene([rs.shapes.icosphere(1)], camera=a.camera)
    assert batch.scene_key(other) != batch.scene_key(a)
    mat = rs.Scene([rs.Model(rs.shapes.icosphere(1), rs.Material(kd=0.5))], camera=a.camera)
    assert batch.scene_key(mat) != batch.scene_key(other)


def test_bad_input_names_the_field(scene):
    cams = animate.orbit_cameras(scene.camera, 3)
    with pytest.raises(ValueError, match="lights"):
        batch.render_batch(scene, cams, lights=[[scene.lights[0]]] * 2, run=rs.RunOptions(progress=False))
    with pytest.raises(TypeError, match=r"scenes\[1\]"):
        batch.render_batch([scene, "x"], run=rs.RunOptions(progress=False))
    with pytest.raises(TypeError, match=r"cameras\[0\]"):
        batch.render_batch(scene, cameras=["x"], run=rs.RunOptions(progress=False))
    with pytest.raises(TypeError, match=r"lights\[0\]\[0\]"):
        batch.render_batch(scene, lights=[[1.0]], run=rs.RunOptions(progress=False))
    with pytest.raises(ValueError, match="shading"):
        batch.render_batch(scene, shading="toon", run=rs.RunOptions(progress=False))
    with pytest.raises(TypeError, match="bogus"):
        batch.render_batch(scene, bogus=1, run=rs.RunOptions(progress=False))
    with pytest.raises(ValueError, match="backend"):
        batch.render_batch(scene, backend="gpu", run=rs.RunOptions(progress=False))
    with pytest.raises(ValueError, match="pattern"):
        batch.render_batch(scene, cams, out_dir="unused", pattern="frame.png", run=rs.RunOptions(progress=False))
    with pytest.raises(ValueError, match="pattern"):
        batch.render_batch(scene, out_dir="unused", pattern="sub/frame_{:03d}.png", run=rs.RunOptions(progress=False))
    with pytest.raises(ValueError, match=r"pattern: 'frame_000.exr': .exr is not written"):
        batch.render_batch(scene, out_dir="unused", pattern="frame_{:03d}.exr", run=rs.RunOptions(progress=False))
    with pytest.raises(ValueError, match="exposure"):
        batch.render_batch(scene, tone={"exposure": -1.0}, run=rs.RunOptions(progress=False))
    no_cam = rs.Scene(scene.models)
    with pytest.raises(ValueError, match="cameras"):
        batch.render_batch(no_cam, run=rs.RunOptions(progress=False))


# -- serial -------------------------------------------------------------------------------------------------


def test_serial_batch_in_order_and_builds_once():
    s = _scene()  # fresh: nothing built yet
    cams = animate.orbit_cameras(s.camera, 6)
    cache = batch.SceneCache()  # the run's cache and counters, owned by the caller
    images = batch.render_batch(s, cams, shading="gouraud", run=rs.RunOptions(progress=False), cache=cache)
    assert cache.stats()["builds"] == 1 and cache.stats()["renders"] == 6
    ref = _serial([s] * 6, cams, "gouraud")
    assert all(np.array_equal(a, b) for a, b in zip(images, ref))
    assert not np.array_equal(images[0], images[1])  # frames differ, so order is checked


def test_serial_runs_own_their_cache():
    """No state outlives a call: each run counts in its own cache (a new one unless one is passed)."""
    s = _scene()
    cams = animate.orbit_cameras(s.camera, 2)
    first, second = batch.SceneCache(), batch.SceneCache()
    batch.render_batch(s, cams, run=rs.RunOptions(progress=False), cache=first)
    batch.render_batch(s, cams, run=rs.RunOptions(progress=False))  # its own cache: touches neither
    batch.render_batch(s, cams, run=rs.RunOptions(progress=False), cache=second)
    assert first.stats() == {"builds": 1, "renders": 2, "skipped": 0, "cached": 1}
    assert second.stats() == {"builds": 0, "renders": 2, "skipped": 0, "cached": 1}  # geometry kept on the scene
    with pytest.raises(TypeError, match="cache"):
        batch.render_batch(s, run=rs.RunOptions(progress=False), cache={})


def test_serial_broadcasts_and_zips(scene):
    cams = animate.orbit_cameras(scene.camera, 3)
    light_sets = [[rs.PointLight((x, 2.0, 3.0), intensity=15.0)] for x in (-2.0, 0.0, 2.0)]
    images = batch.render_batch(scene, cams, light_sets, run=rs.RunOptions(progress=False))
    ref = [rs.render(scene.replace(lights=ls), "phong", camera=c).image for c, ls in zip(cams, light_sets)]
    assert all(np.array_equal(a, b) for a, b in zip(images, ref))
    one = batch.render_batch(scene, run=rs.RunOptions(progress=False))
    assert len(one) == 1 and np.array_equal(one[0], rs.render(scene, "phong").image)


# -- on the cluster -------------------------------------------------------------------------------------


def test_cluster_workers_are_single_threaded(client):
    env = client.run(lambda: (os.environ.get("NUMBA_NUM_THREADS"), __import__("threading").active_count() > 0))
    assert len(env) == 2 and all(v[0] == "1" for v in env.values())
    assert all(w["nthreads"] == 1 for w in client.scheduler_info()["workers"].values())


def test_cluster_matches_serial_bitwise(scene, client):
    batch.reset_worker_stats(client)
    cams = animate.orbit_cameras(scene.camera, 8)
    got = batch.render_batch(scene, cams, shading="phong", run=rs.RunOptions(scheduler=client, progress=False))
    ref = _serial([scene] * 8, cams, "phong")
    assert len(got) == 8
    for a, b in zip(got, ref):
        assert a.dtype == np.float32 and np.array_equal(a, b)
    totals, per_worker = _worker_totals(client)
    assert totals["renders"] == 8
    assert all(s["builds"] <= 1 for s in per_worker.values())  # once per worker and mesh set

    # A light orbit is a list of scenes sharing one mesh set: still one build per worker.
    scenes = animate.orbit_light(scene, 6)
    batch.reset_worker_stats(client)
    got = batch.render_batch(scenes, shading="gouraud", run=rs.RunOptions(scheduler=client, progress=False, window=3))
    ref = _serial(scenes, [scene.camera] * 6, "gouraud")
    assert all(np.array_equal(a, b) for a, b in zip(got, ref))
    totals, per_worker = _worker_totals(client)
    assert totals["renders"] == 6 and totals["builds"] == 0  # the workers kept the geometry from above


def test_cluster_takes_auto_and_one_method_per_model(scene, client):
    cams = animate.orbit_cameras(scene.camera, 3)
    for shading in ("Auto", ("flat", "Phong")):
        got = batch.render_batch(scene, cams, shading=shading, run=rs.RunOptions(scheduler=client, progress=False),
                                 tolerance=0.02)
        canonical = shading.lower() if isinstance(shading, str) else tuple(m.lower() for m in shading)
        ref = [rs.render(scene, canonical, camera=c, tolerance=0.02).image for c in cams]
        assert all(np.array_equal(a, b) for a, b in zip(got, ref))
    with pytest.raises(ValueError, match="cache"):
        batch.render_batch(scene, run=rs.RunOptions(scheduler=client, progress=False), cache=batch.SceneCache())


def test_cluster_streams_in_order(scene, client):
    cams = animate.orbit_cameras(scene.camera, 7)
    ref = _serial([scene] * 7, cams, "flat")
    out = list(batch.iter_batch(scene, cams, shading="flat", run=rs.RunOptions(scheduler=client, progress=False,
                                                                               window=2)))
    assert len(out) == 7 and all(np.array_equal(a, b) for a, b in zip(out, ref))
    # Several frames per task (a chunk never mixes mesh sets): same frames, same order.
    other = rs.Scene([rs.shapes.icosphere(1)], lights=scene.lights, camera=scene.camera)
    scenes = [scene] * 4 + [other] * 3
    ref = _serial(scenes, cams, "flat")
    for per_task, window in ((3, None), (3, 4), (2, 1)):
        out = list(batch.iter_batch(scenes, cams, shading="flat", run=rs.RunOptions(scheduler=client, progress=False,
                                                                                    per_task=per_task, window=window)))
        assert len(out) == 7 and all(np.array_equal(a, b) for a, b in zip(out, ref))


def test_cluster_images_come_back_through_a_folder_or_dask(scene, client, tmp_path, monkeypatch):
    # A local cluster sees this process's temporary folder: by default the workers save images there.
    root = tmp_path / "tmp"
    root.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(root))
    cams = animate.orbit_cameras(scene.camera, 5)
    ref = _serial([scene] * 5, cams)
    assert batch.cluster.is_local(client) and not batch.cluster.is_local(object())
    for transfer, spooled in (("auto", True), ("DISK", True), ("dask", False)):
        frames = batch.iter_batch(scene, cams, run=rs.RunOptions(scheduler=client, progress=False, transfer=transfer,
                                                                 per_task=2))
        first = next(frames)
        assert len(os.listdir(root)) == int(spooled)  # the folder lives while the batch runs
        got = [first] + list(frames)
        assert os.listdir(root) == []  # and is removed with every image read from it
        assert all(a.dtype == np.float32 and a.flags.writeable and np.array_equal(a, b) for a, b in zip(got, ref))
    # Frames written by the workers need no folder.
    paths = batch.render_batch(scene, cams, run=rs.RunOptions(scheduler=client, progress=False, transfer="disk"),
                               out_dir=tmp_path / "out",
                               pattern="f_{:02d}.npy")
    assert os.listdir(root) == [] and all(np.array_equal(np.load(p), b) for p, b in zip(paths, ref))


def test_serial_runs_take_and_ignore_the_dask_options(scene):
    # RunOptions checks transfer, per_task and window (tests/apps/test_run_options.py); None is the default
    # (automatic) for per_task and window, and a run in this process ignores all three.
    out = batch.render_batch(scene, run=rs.RunOptions(per_task=None, transfer="Dask", progress=False))
    assert np.array_equal(out[0], rs.render(scene, "phong").image)


def test_auto_frames_per_task():
    from raycast_shade.apps.batch.dask_driver import TASK_PIXELS, auto_frames_per_task

    def jobs(w, h, n):
        s = rs.Scene([rs.shapes.icosphere(1)], camera=rs.Camera(eye=(0, 0, 4), width=w, height=h))
        return batch.plan_batch(s, animate.orbit_cameras(s.camera, n))[1]

    assert TASK_PIXELS // (640 * 480) == 13
    assert auto_frames_per_task(jobs(640, 480, 96), 2) == 12  # 4 tasks per worker at least: 96 // 8
    assert auto_frames_per_task(jobs(640, 480, 400), 2) == 13  # about TASK_PIXELS a task
    assert auto_frames_per_task(jobs(1920, 1080, 96), 2) == 1
    assert auto_frames_per_task(jobs(16, 12, 10), 1) == 2
    assert auto_frames_per_task(jobs(16, 12, 3), 4) == 1
    assert auto_frames_per_task([], 2) == 1


def test_match_numba_threads_is_per_thread(monkeypatch):
    import threading

    import numba

    from raycast_shade.apps.batch.cluster import match_numba_threads

    before = numba.get_num_threads()

    def in_thread():
        out = {}
        t = threading.Thread(target=lambda: out.update(set=match_numba_threads(), now=numba.get_num_threads()))
        t.start()
        t.join()
        return out

    monkeypatch.setenv("NUMBA_NUM_THREADS", "1")
    assert in_thread() == {"set": 1, "now": 1}
    monkeypatch.setenv("NUMBA_NUM_THREADS", "999")  # capped at the threads Numba launched
    assert in_thread() == {"set": numba.config.NUMBA_NUM_THREADS, "now": numba.config.NUMBA_NUM_THREADS}
    monkeypatch.delenv("NUMBA_NUM_THREADS")
    assert in_thread()["now"] == numba.config.NUMBA_NUM_THREADS  # unset: Numba's default stands
    assert numba.get_num_threads() == before  # this thread untouched


def test_cluster_error_propagates(scene, client):
    # A bump map on a mesh without UVs fails when the worker packs the geometry; after its retries the
    # error reaches the caller, named as usual.
    bumpy = rs.Material(bump=rs.HeightMap(np.zeros((4, 4))))
    ball = rs.shapes.icosphere(1)
    bad = rs.Scene([rs.Model(rs.Mesh(ball.vertices, ball.faces), bumpy)], camera=scene.camera)
    with pytest.raises(ValueError, match="UVs"):
        batch.render_batch(bad, run=rs.RunOptions(scheduler=client, progress=False, retries=1))


def _names(folder):
    return sorted(os.listdir(folder))


def test_resume_renders_only_missing_frames(scene, client, tmp_path):
    cams = animate.orbit_cameras(scene.camera, 6)
    out = tmp_path / "frames"
    paths = batch.render_batch(scene, cams, out_dir=out, pattern="f_{:03d}.npy", run=rs.RunOptions(progress=False))
    assert paths == [str(out / f"f_{i:03d}.npy") for i in range(6)]
    ref = _serial([scene] * 6, cams)
    assert all(np.array_equal(np.load(p), r) for p, r in zip(paths, ref))
    stamps = {p: os.stat(p).st_mtime_ns for p in paths}

    os.remove(paths[1])
    os.remove(paths[4])
    stale = out / ".f_001.npy.0123456789ab.tmp.npy"  # what a writer killed mid-file leaves behind
    stale.write_bytes(b"half a fi")
    batch.reset_worker_stats(client)
    again = batch.render_batch(scene, cams, out_dir=out, pattern="f_{:03d}.npy", run=rs.RunOptions(scheduler=client,
                                                                                                   progress=False))
    assert again == paths
    totals, _ = _worker_totals(client)
    assert totals["renders"] == 2
    assert _names(out) == [f"f_{i:03d}.npy" for i in range(6)]  # stale temp removed, nothing else
    for i, p in enumerate(paths):
        assert np.array_equal(np.load(p), ref[i])
        if i not in (1, 4):
            assert os.stat(p).st_mtime_ns == stamps[p]  # untouched

    # Serial resume too; resume=False re-renders everything.
    os.remove(paths[0])
    cache = batch.SceneCache()
    batch.render_batch(scene, cams, out_dir=out, pattern="f_{:03d}.npy", run=rs.RunOptions(progress=False), cache=cache)
    assert cache.stats()["renders"] == 1
    cache.reset_stats()
    batch.render_batch(scene, cams, out_dir=out, pattern="f_{:03d}.npy", run=rs.RunOptions(progress=False,
                                                                                           resume=False), cache=cache)
    assert cache.stats()["renders"] == 6


def test_png_frames_are_tone_mapped(scene, tmp_path):
    import imageio.v3 as iio

    paths = batch.render_batch(scene, animate.orbit_cameras(scene.camera, 2), out_dir=tmp_path,
                               run=rs.RunOptions(progress=False), tone={"exposure": 2.0})
    assert [os.path.basename(p) for p in paths] == ["frame_00000.png", "frame_00001.png"]
    first = iio.imread(paths[0])
    assert first.shape == (H, W, 3)
    assert np.array_equal(first, rs.to_uint8(rs.render(scene, "phong").image, exposure=2.0))


def test_write_is_atomic(tmp_path, monkeypatch):
    import raycast_shade.output.tonemap as tm

    target = tmp_path / "img.pfm"
    image = np.full((4, 5, 3), 0.5, np.float32)
    write_image(target, image, atomic=True)
    before = target.read_bytes()
    real = tm.write_pfm

    def dies_half_way(path, img):
        with open(path, "wb") as fh:
            fh.write(b"PF\n5 4\n")
        raise OSError("disk full")

    monkeypatch.setattr(tm, "write_pfm", dies_half_way)
    with pytest.raises(OSError, match="disk full"):
        write_image(target, image * 2, atomic=True)
    assert target.read_bytes() == before  # the old frame, whole
    assert _names(tmp_path) == ["img.pfm"]  # no temporary left
    monkeypatch.setattr(tm, "write_pfm", real)
    write_image(target, image * 2, atomic=True)
    assert np.array_equal(rs.read_pfm(target), image * 2) and _names(tmp_path) == ["img.pfm"]


def _kill_once_plugin(marker, log, kill_at):
    from distributed.diagnostics.plugin import WorkerPlugin

    class KillOnce(WorkerPlugin):
        """Kills the worker process that first starts frame ``kill_at``; logs every render."""

        def setup(self, worker):
            from raycast_shade.apps.batch import cache as b

            original = b.__dict__.get("_unpatched_render_image", b.render_image)
            b._unpatched_render_image = original

            def render_image(job, base, options, cache):
                if job.index == kill_at:
                    try:
                        fd = os.open(marker, os.O_CREAT | os.O_EXCL | os.O_WRONLY)
                    except FileExistsError:
                        pass
                    else:
                        os.close(fd)
                        os._exit(1)  # the worker dies mid-batch, its task unfinished
                image = original(job, base, options, cache)
                with open(log, "a") as fh:
                    fh.write(f"{job.index}\n")
                return image

            b.render_image = render_image

        def teardown(self, worker):
            from raycast_shade.apps.batch import cache as b

            b.render_image = b.__dict__.pop("_unpatched_render_image", b.render_image)

    return KillOnce()


def test_killed_worker_frames_rerun_elsewhere(scene, client, tmp_path):
    n = 10
    cams = animate.orbit_cameras(scene.camera, n)
    marker, log = tmp_path / "killed", tmp_path / "renders.log"
    out = tmp_path / "frames"
    client.register_plugin(_kill_once_plugin(str(marker), str(log), kill_at=3), name="kill-once")
    try:
        paths = batch.render_batch(scene, cams, out_dir=out, pattern="f_{:02d}.npy",
                                   run=rs.RunOptions(scheduler=client, progress=False, retries=1))
    finally:
        client.unregister_worker_plugin("kill-once")
        client.wait_for_workers(2, timeout=60)
    assert marker.exists()  # a worker did die
    assert paths == [str(out / f"f_{i:02d}.npy") for i in range(n)]
    assert _names(out) == [f"f_{i:02d}.npy" for i in range(n)]  # every frame, no temporaries
    renders = sorted(int(line) for line in log.read_text().split())
    assert renders == list(range(n))  # each frame rendered exactly once, frame 3 on its second attempt
    ref = _serial([scene] * n, cams)
    assert all(np.array_equal(np.load(p), r) for p, r in zip(paths, ref))


def test_workers_argument_starts_a_local_cluster(scene):
    cams = animate.orbit_cameras(scene.camera, 3)
    got = batch.render_batch(scene, cams, run=rs.RunOptions(workers=2, progress=False))
    assert all(np.array_equal(a, b) for a, b in zip(got, _serial([scene] * 3, cams)))


# -- animations ---------------------------------------------------------------------------------------------


def test_orbit_cameras_turn_about_the_target(scene):
    cams = animate.orbit_cameras(scene.camera, 4)
    c0 = scene.camera
    r0 = np.linalg.norm(c0.eye - c0.target)
    for i, c in enumerate(cams):
        assert np.allclose(c.target, c0.target) and np.isclose(np.linalg.norm(c.eye - c.target), r0)
        assert np.isclose(c.eye[1], c0.eye[1])  # about the up axis (y)
        assert (c.width, c.height) == (W, H)
    assert np.allclose(cams[2].eye[[0, 2]], -c0.eye[[0, 2]])
    assert np.allclose(cams[0].eye, c0.eye)
    with pytest.raises(ValueError, match="frames"):
        animate.orbit_cameras(c0, 0)
    with pytest.raises(TypeError, match="camera"):
        animate.orbit_cameras(scene, 3)


def test_orbit_light_moves_one_light_and_shares_geometry(scene):
    scenes = animate.orbit_light(scene, 4, light_index=0, center=(0.0, 0.0, 0.0))
    p0 = scene.lights[0].position
    for s in scenes:
        assert all(a is b for a, b in zip(s.models, scene.models)) and s.lights[1] is scene.lights[1]
        assert np.isclose(np.linalg.norm(s.lights[0].position), np.linalg.norm(p0))
    assert np.allclose(scenes[2].lights[0].position, [-p0[0], p0[1], -p0[2]])
    d = animate.orbit_light(scene, 2, light_index=1)[1].lights[1].direction
    assert np.allclose(d, [-scene.lights[1].direction[0], scene.lights[1].direction[1], -scene.lights[1].direction[2]])
    with pytest.raises(ValueError, match="light_index"):
        animate.orbit_light(scene, 4, light_index=2)
    with pytest.raises(ValueError, match="light_index"):
        animate.orbit_light(scene.replace(lights=[]), 4)


def test_animation_outputs(scene, tmp_path):
    import imageio.v2 as iio2
    import imageio.v3 as iio

    gif = animate.animate(scene, tmp_path / "a.gif", orbit="light", frames=4, shading="gouraud",
                          run=rs.RunOptions(progress=False))
    assert gif["frames"] == 4 and iio.imread(tmp_path / "a.gif").shape == (4, H, W, 3)
    mp4 = animate.animate(scene, tmp_path / "a.mp4", orbit="camera", frames=5, run=rs.RunOptions(progress=False))
    reader = iio2.get_reader(tmp_path / "a.mp4")
    assert mp4["frames"] == 5 and reader.count_frames() == 5 and reader.get_meta_data()["size"] == (W, H)
    reader.close()
    seq = animate.animate(scene, str(tmp_path / "seq") + os.sep, frames=3, run=rs.RunOptions(progress=False))
    assert seq["kind"] == "frames" and _names(tmp_path / "seq") == [f"frame_{i:05d}.png" for i in range(3)]
    assert _names(tmp_path) == ["a.gif", "a.mp4", "seq"]  # no temporaries
    with pytest.raises(ValueError, match="output"):
        animate.animate(scene, tmp_path / "a.bmpx", frames=2, run=rs.RunOptions(progress=False))
    with pytest.raises(ValueError, match="orbit"):
        animate.animate(scene, tmp_path / "b.gif", orbit="sun", frames=2, run=rs.RunOptions(progress=False))
    with pytest.raises(ValueError, match="fps"):
        animate.write_animation([np.zeros((2, 2, 3), np.uint8)], tmp_path / "c.gif", fps=0)


SCENE_TOML = """
ambient = 0.05
[camera]
eye = [0.0, 0.5, 4.0]
width = 40
height = 30
[[object]]
shape = "icosphere"
subdivisions = 1
[object.material]
ks = 0.5
[[light]]
type = "point"
position = [2.0, 3.0, 4.0]
intensity = 20.0
attenuation = "inverse_square"
"""


def test_cli_animate(tmp_path, capsys):
    pytest.importorskip("raycast_shade.scene.scenefile")
    path = tmp_path / "ball.toml"
    path.write_text(SCENE_TOML)
    parser = argparse.ArgumentParser(prog="raycast-shade")
    animate.register_cli(parser.add_subparsers(dest="command"))
    out = tmp_path / "ball.gif"
    args = parser.parse_args(["animate", str(path), "--orbit", "light", "--frames", "3", "--width", "32",
                              "--height", "24", "-o", str(out), "--no-progress", "--shading", "gouraud"])
    assert animate.run_cli(args) == 0
    assert iio_shape(out) == (3, 24, 32, 3)
    assert "3 frames, 32x24, gouraud, light orbit" in capsys.readouterr().out
    args = parser.parse_args(["animate", str(path), "--orbit", "light", "--light-index", "1", "-o", str(out)])
    with pytest.raises(ValueError, match="--light-index"):
        animate.run_cli(args)


def iio_shape(path):
    import imageio.v3 as iio

    return iio.imread(path).shape


def test_cli_animate_tone_options(tmp_path):
    """--gamma and --exposure parse through the real raycast-shade parser and
    change the written frames (linear gamma darkens mid-tones against sRGB)."""
    import imageio.v3 as iio

    from raycast_shade.apps.cli import main

    path = tmp_path / "ball.toml"
    path.write_text(SCENE_TOML)
    common = ["animate", str(path), "--frames", "2", "--width", "32", "--height", "24", "--no-progress"]
    assert main(common + ["-o", str(tmp_path / "srgb.gif")]) == 0
    assert main(common + ["--gamma", "1", "--exposure", "1.0", "-o", str(tmp_path / "lin.gif")]) == 0
    srgb = iio.imread(tmp_path / "srgb.gif").astype(int)
    lin = iio.imread(tmp_path / "lin.gif").astype(int)
    assert srgb.shape == lin.shape and srgb.sum() > lin.sum()
    assert main(common + ["--gamma", "bright", "-o", str(tmp_path / "bad.gif")]) == 2
