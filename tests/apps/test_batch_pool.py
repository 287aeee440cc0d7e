"""Batch rendering on a pool of single-threaded processes of this machine (apps/batch/pool.py).

Frames are tiny (48x36): the file is dominated by worker start-up. One pool
serves most tests; the tests of shutdown start their own.
"""

from __future__ import annotations

import os
import signal

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.apps import animate, batch
from raycast_shade.apps.batch import driver, pool as pool_module

psutil = pytest.importorskip("psutil")  # comes with dask[distributed], a test dependency

W, H = 48, 36


def _scene(**camera):
    return rs.Scene(
        [rs.Model(rs.shapes.icosphere(2), rs.Material(kd=(0.8, 0.35, 0.2), ks=0.6, shininess=30)),
         rs.Model(rs.shapes.icosphere(1), rs.Material(kd=(0.2, 0.5, 0.8)))],
        lights=[rs.PointLight((2.0, 3.0, 4.0), intensity=20.0, attenuation="inverse_square"),
                rs.DirectionalLight((-1.0, -0.5, -1.0), intensity=0.3)],
        camera=rs.Camera(eye=(0.3, 0.5, 4.0), width=camera.get("width", W), height=camera.get("height", H)),
    )


def _bad_scene(camera):
    # A bump map on a mesh without UVs fails when the worker packs the geometry.
    ball = rs.shapes.icosphere(1)
    bumpy = rs.Material(bump=rs.HeightMap(np.zeros((4, 4))))
    return rs.Scene([rs.Model(rs.Mesh(ball.vertices, ball.faces), bumpy)], camera=camera)


@pytest.fixture(scope="module")
def scene():
    s = _scene()
    for shading in ("flat", "gouraud", "phong"):  # JIT (or load the cache) here, before the workers start
        rs.render(s, shading)
    return s


@pytest.fixture(scope="module")
def pool(scene):
    with batch.ProcessPool(2) as p:
        yield p


def _serial(scenes, cameras, shading="phong"):
    return [rs.render(s, shading, camera=c).image for s, c in zip(scenes, cameras)]


def _segments() -> set:
    return {n for n in os.listdir("/dev/shm") if n.startswith("psm_")} if os.path.isdir("/dev/shm") else set()


def _pool_children() -> list:
    out = []
    for p in psutil.Process().children(recursive=True):
        try:
            if "raycast_shade.apps.batch.pool" in " ".join(p.cmdline()) and p.status() != psutil.STATUS_ZOMBIE:
                out.append(p.pid)
        except psutil.NoSuchProcess:
            pass
    return out


def test_pool_workers_have_one_numba_thread(pool):
    assert len(pool.pids) == 2 and pool.numba_threads == max(1, pool_module.cores() // 2)
    for pid in pool.pids:
        env = psutil.Process(pid).environ()
        assert env["NUMBA_NUM_THREADS"] == str(pool.numba_threads)
        assert env["OMP_NUM_THREADS"] == "1"


def test_pool_matches_serial_bitwise_in_order(scene, pool):
    n = 7
    cams = animate.orbit_cameras(scene.camera, n)
    other = scene.replace(models=(scene.models[1],))  # a second mesh set in the same batch
    scenes = [scene if i % 3 else other for i in range(n)]
    for shading in ("phong", "gouraud", ("flat", "phong")):
        shading_ = shading if isinstance(shading, str) else "phong"
        if isinstance(shading, tuple):
            scenes_, ref = [scene] * n, [rs.render(scene, shading, camera=c).image for c in cams]
        else:
            scenes_, ref = scenes, _serial(scenes, cams, shading_)
        got = batch.render_batch(scenes_, cams, shading=shading, run=rs.RunOptions(executor=pool, progress=False))
        assert len(got) == n
        for a, b in zip(got, ref):
            assert a.dtype == np.float32 and a.shape == (H, W, 3)
            assert np.array_equal(a, b)  # bit for bit, and frame i is frame i


def test_pool_frames_of_different_sizes_and_a_small_window(scene, pool):
    cams = [rs.Camera(eye=(0.3, 0.5, 4.0), width=w, height=h) for w, h in [(40, 30), (64, 48), (16, 12), (48, 36)]]
    ref = _serial([scene] * 4, cams)
    got = list(batch.iter_batch(scene, cams, run=rs.RunOptions(executor=pool, progress=False, window=1)))
    assert [g.shape for g in got] == [r.shape for r in ref]
    assert all(np.array_equal(a, b) for a, b in zip(got, ref))


def test_pool_workers_write_frames_and_resume(scene, pool, tmp_path):
    cams = animate.orbit_cameras(scene.camera, 5)
    out = tmp_path / "frames"
    paths = batch.render_batch(scene, cams, out_dir=out, pattern="f_{:02d}.npy", run=rs.RunOptions(executor=pool,
                                                                                                   progress=False))
    assert paths == [str(out / f"f_{i:02d}.npy") for i in range(5)]
    ref = _serial([scene] * 5, cams)
    assert all(np.array_equal(np.load(p), r) for p, r in zip(paths, ref))
    os.remove(paths[2])
    before = {p: os.stat(p).st_mtime_ns for p in paths if os.path.exists(p)}
    again = batch.render_batch(scene, cams, out_dir=out, pattern="f_{:02d}.npy", run=rs.RunOptions(executor=pool,
                                                                                                   progress=False))
    assert again == paths and np.array_equal(np.load(paths[2]), ref[2])
    assert all(os.stat(p).st_mtime_ns == t for p, t in before.items())  # the others were skipped


def test_pool_error_names_the_frame_after_its_retries(scene, pool):
    cams = animate.orbit_cameras(scene.camera, 4)
    scenes = [scene, scene, _bad_scene(scene.camera), scene]
    with pytest.raises(batch.FrameError, match=r"frame 2: ValueError: .*UVs.*\(3 attempts\)") as info:
        batch.render_batch(scenes, cams, run=rs.RunOptions(executor=pool, progress=False, retries=2))
    assert info.value.index == 2
    assert isinstance(info.value.__cause__, ValueError) and "UVs" in str(info.value.__cause__)
    assert "worker traceback" in str(info.value) and "Traceback" in str(info.value)
    with pytest.raises(batch.FrameError, match=r"frame 0: ValueError: .*UVs") as info:
        batch.render_batch(_bad_scene(scene.camera), run=rs.RunOptions(executor=pool, progress=False, retries=0))
    assert "attempts" not in str(info.value)
    # The pool was restarted after the error and renders again.
    assert len(pool.pids) == 0 or all(psutil.pid_exists(p) for p in pool.pids)
    got = batch.render_batch(scene, cams, run=rs.RunOptions(executor=pool, progress=False))
    assert all(np.array_equal(a, b) for a, b in zip(got, _serial([scene] * 4, cams)))


def test_pool_replaces_a_killed_worker(scene):
    cams = animate.orbit_cameras(scene.camera, 12)
    ref = _serial([scene] * 12, cams)
    with batch.ProcessPool(2) as p:
        it = batch.iter_batch(scene, cams, run=rs.RunOptions(executor=p, progress=False))
        got = [next(it)]
        victim = p.pids[0]
        os.kill(victim, signal.SIGKILL)
        got += list(it)
        # The pool finds a dead worker when it next sends it work: in this batch if the victim
        # still had frames to do, else when the next batch starts (a tiny scene's frames may all
        # be done before the signal lands). Either way it is gone once the next batch is done.
        again = batch.render_batch(scene, cams[:3], run=rs.RunOptions(executor=p, progress=False))
        assert victim not in p.pids and len(p.pids) == 2
        # Killed between batches.
        victim = p.pids[1]
        os.kill(victim, signal.SIGKILL)
        again += batch.render_batch(scene, cams[:3], run=rs.RunOptions(executor=p, progress=False))
        assert victim not in p.pids and len(p.pids) == 2
    assert len(got) == 12 and all(np.array_equal(a, b) for a, b in zip(got, ref))
    assert len(again) == 6 and all(np.array_equal(a, b) for a, b in zip(again, ref[:3] * 2))


def test_a_worker_killed_after_the_liveness_check_is_replaced(scene, monkeypatch):
    """The race of the test above, made certain: the worker is dead, but its process still polls as alive
    when the batch is sent (a broken pipe then), and is replaced with the batch resent."""
    cams = animate.orbit_cameras(scene.camera, 3)
    with batch.ProcessPool(2) as p:
        first = batch.render_batch(scene, cams, run=rs.RunOptions(executor=p, progress=False))
        w = p._workers[1]
        w.proc.kill()
        w.proc.wait()
        monkeypatch.setattr(w.proc, "poll", lambda: None)  # as if not yet reaped
        again = batch.render_batch(scene, cams, run=rs.RunOptions(executor=p, progress=False))
        assert w.pid not in p.pids and len(p.pids) == 2
    assert all(np.array_equal(a, b) for a, b in zip(first, again))


def test_pool_shutdown_leaves_no_process_and_no_segment(scene, tmp_path, monkeypatch):
    cams = animate.orbit_cameras(scene.camera, 6)
    segments = _segments()
    others = _pool_children()  # another test's pool, if any

    batch.render_batch(scene, cams, run=rs.RunOptions(workers=2, progress=False))  # a pool of its own (executor="auto")
    assert _pool_children() == others and _segments() == segments

    with pytest.raises(batch.FrameError):  # an error mid-batch
        batch.render_batch([scene, _bad_scene(scene.camera)] * 3, run=rs.RunOptions(workers=2, progress=False,
                                                                                    retries=0))
    assert _pool_children() == others and _segments() == segments

    it = batch.iter_batch(scene, cams, run=rs.RunOptions(workers=2, progress=False))  # the consumer stops early
    next(it)
    it.close()
    assert _pool_children() == others and _segments() == segments

    class Interrupting:  # Ctrl-C while the client waits for frames
        def update(self, n=1):
            raise KeyboardInterrupt

        def close(self):
            pass

    monkeypatch.setattr(driver, "_progress_bar", lambda *a: Interrupting())
    with pytest.raises(KeyboardInterrupt):
        batch.render_batch(scene, cams, run=rs.RunOptions(workers=2))
    assert _pool_children() == others and _segments() == segments
    monkeypatch.undo()

    with batch.ProcessPool(2) as p:
        pids = p.pids
        batch.render_batch(scene, cams, run=rs.RunOptions(executor=p, progress=False), out_dir=tmp_path)
    assert not any(psutil.pid_exists(pid) for pid in pids)
    assert _pool_children() == others and _segments() == segments


def test_executor_spellings(scene, pool):
    cams = animate.orbit_cameras(scene.camera, 3)
    ref = _serial([scene] * 3, cams)
    for kw in (dict(executor="Processes", workers=1), dict(executor="serial"), dict(executor="auto")):
        got = batch.render_batch(scene, cams, run=rs.RunOptions(progress=False, **kw))
        assert all(np.array_equal(a, b) for a, b in zip(got, ref)), kw
    assert driver.check_executor("auto", None, None) == "serial"
    assert driver.check_executor("auto", 2, None) == driver.LOCAL_EXECUTOR
    assert driver.check_executor("auto", None, "tcp://x:1") == "dask"
    assert driver.check_executor("DASK", None, None) == "dask"
    assert driver.check_executor(pool, None, None) is pool


def test_pool_bad_input_names_the_field(scene, pool):
    cams = animate.orbit_cameras(scene.camera, 2)
    cases = [
        (ValueError, "executor", dict(executor="threads")),
        (TypeError, "executor", dict(executor=2)),
        (ValueError, "workers", dict(executor="processes", workers=0)),
        (ValueError, "workers", dict(workers=-1)),
        (ValueError, "workers", dict(workers=True)),
        (ValueError, "numba_threads", dict(executor="processes", numba_threads=0)),
        (ValueError, "workers", dict(executor="serial", workers=2)),
        (ValueError, "scheduler", dict(executor="processes", scheduler="tcp://127.0.0.1:1")),
        (ValueError, "executor", dict(executor=pool, workers=2)),
        (ValueError, "retries", dict(workers=2, retries=-1)),
    ]
    for exc, name, kw in cases:  # the record refuses them, before any pool could start
        with pytest.raises(exc, match=name):
            rs.RunOptions(progress=False, **kw)
    with pytest.raises(ValueError, match="cache"):
        batch.render_batch(scene, cams, run=rs.RunOptions(workers=2, progress=False), cache=batch.SceneCache())
    with pytest.raises(ValueError, match="workers"):
        batch.ProcessPool(0)
    with pytest.raises(ValueError, match="numba_threads"):
        batch.ProcessPool(1, numba_threads=1.5)
    assert _pool_children() != []  # the module's pool only: none of the bad calls started one
    assert sorted(_pool_children()) == sorted(pool.pids)


SCENE_TOML = """
[camera]
eye = [0.0, 0.5, 4.0]
width = 40
height = 30
[[object]]
shape = "icosphere"
subdivisions = 1
[[light]]
type = "point"
position = [2.0, 3.0, 4.0]
intensity = 20.0
"""


def test_cli_animate_workers_and_executor(tmp_path, capsys):
    from raycast_shade.apps.cli import main

    path = tmp_path / "ball.toml"
    path.write_text(SCENE_TOML)
    common = ["animate", str(path), "--frames", "3", "--no-progress"]
    assert main(common + ["-o", str(tmp_path / "serial/")]) == 0
    assert "this process" in capsys.readouterr().out
    assert main(common + ["--workers", "2", "-o", str(tmp_path / "pool/")]) == 0
    assert "2 worker processes" in capsys.readouterr().out
    for i in range(3):
        name = f"frame_{i:05d}.png"
        assert (tmp_path / "serial" / name).read_bytes() == (tmp_path / "pool" / name).read_bytes()
    assert main(common + ["--executor", "threads", "-o", str(tmp_path / "bad/")]) == 2
    assert main(common + ["--executor", "serial", "--workers", "2", "-o", str(tmp_path / "bad/")]) == 2
