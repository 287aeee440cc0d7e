"""Data sets of views: render_views serially and on Dask, resume, the index, the CLI."""

from __future__ import annotations

import json
import os

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.apps.animate import orbit_cameras
from raycast_shade.apps.cli import main
from raycast_shade.apps.views import INDEX_NAME, PLAN_NAME, render_views
from raycast_shade.output.bufferfile import load_npz, read_depth_png, read_exr

W, H = 40, 30
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


@pytest.fixture(scope="module")
def scene():
    s = rs.Scene([rs.Model(rs.shapes.icosphere(2)), rs.Model(rs.shapes.plane(size=4.0, center=(0, 0, -1.2)))],
                 lights=[rs.PointLight((2, 3, 4), intensity=20)],
                 camera=rs.Camera(eye=(0.3, 0.5, 4.0), width=W, height=H))
    rs.render(s, buffers=("zdepth",))  # compile before any worker starts
    return s


def _names(folder):
    return sorted(os.listdir(folder))


def test_views_write_one_file_set_per_view_and_an_index(scene, tmp_path):
    cams = orbit_cameras(scene.camera, 4)
    index = render_views(scene, cams, tmp_path,
                         files=rs.ViewFiles(buffers=["zdepth", "normal", "id"], formats=["npz", "exr", "depth_png"]))
    assert index == os.path.join(tmp_path, INDEX_NAME)
    stems = [f"view_{i:05d}" for i in range(4)]
    assert _names(tmp_path) == sorted([INDEX_NAME, PLAN_NAME] + [s + e for s in stems
                                                                 for e in (".png", ".npz", ".exr", "_depth.png", ".json")])
    data = json.load(open(index))
    assert data["buffers"] == ["zdepth", "normal", "model_id", "triangle_id"]
    for view, cam in zip(data["views"], cams):
        K, R, t = cam.to_opencv()
        assert np.array_equal(view["K"], K) and np.array_equal(view["R"], R) and np.array_equal(view["t"], t)
        assert view["files"]["npz"] == f"view_{view['index']:05d}.npz"
        frame = rs.render(scene, camera=cam, buffers=("zdepth", "normal", "id"))
        npz = load_npz(tmp_path / view["files"]["npz"])
        exr = read_exr(tmp_path / view["files"]["exr"])
        for name, buf in frame.buffers.items():
            assert np.array_equal(npz[name], buf) and np.array_equal(exr[name], buf), name
        assert "image" not in npz and "image" not in exr and np.array_equal(npz["R"], R)  # float_image=False
        depth = read_depth_png(tmp_path / view["files"]["depth_png"])
        assert np.abs(depth - frame.buffers["zdepth"]).max() <= 5e-4 + 1e-6


def test_views_resume_and_leave_no_partial_file(scene, tmp_path):
    cams = orbit_cameras(scene.camera, 3)
    render_views(scene, cams, tmp_path, files=rs.ViewFiles(buffers=["zdepth"]))
    stamps = {n: os.stat(tmp_path / n).st_mtime_ns for n in _names(tmp_path)}
    os.remove(tmp_path / "view_00001.npz")  # one file of one view gone
    stale = tmp_path / ".view_00002.npz.0123456789ab.tmp.npz"  # what a killed writer leaves
    stale.write_bytes(b"partial")
    render_views(scene, cams, tmp_path, files=rs.ViewFiles(buffers=["zdepth"]))
    assert not stale.exists()
    after = {n: os.stat(tmp_path / n).st_mtime_ns for n in _names(tmp_path)}
    assert set(after) == set(stamps)
    redone = {n for n in after if n in stamps and after[n] != stamps[n]}
    assert redone == {"view_00001.npz", "view_00001.png", "view_00001.json", INDEX_NAME, PLAN_NAME}


def test_records_of_blake2b_digests_still_resume_and_still_catch_a_changed_file(scene, tmp_path):
    """Records written before the digests were SHA-256 hold 16-byte BLAKE2b ones ("blake2b"): such a
    view is still done if its files match them, and rendered again if one does not."""
    import hashlib

    cams = orbit_cameras(scene.camera, 2)
    render_views(scene, cams, tmp_path, files=rs.ViewFiles(buffers=["zdepth"]))
    for i in range(2):
        path = tmp_path / f"view_{i:05d}.json"
        record = json.loads(path.read_text())
        for name, entry in record["files"].items():
            data = (tmp_path / name).read_bytes()
            assert entry.pop("sha256") == hashlib.sha256(data).hexdigest()
            entry["blake2b"] = hashlib.blake2b(data, digest_size=16).hexdigest()
        path.write_text(json.dumps(record))
    npz = tmp_path / "view_00001.npz"
    data = bytearray(npz.read_bytes())
    data[-30] ^= 1  # one bit of view 1's npz, its size kept
    npz.write_bytes(bytes(data))
    stamps = {n: os.stat(tmp_path / n).st_mtime_ns for n in _names(tmp_path)}
    render_views(scene, cams, tmp_path, files=rs.ViewFiles(buffers=["zdepth"]))
    after = {n: os.stat(tmp_path / n).st_mtime_ns for n in _names(tmp_path)}
    redone = {n for n in after if after[n] != stamps[n]}
    assert redone == {"view_00001.npz", "view_00001.png", "view_00001.json", INDEX_NAME, PLAN_NAME}
    assert "sha256" in json.loads((tmp_path / "view_00001.json").read_text())["files"]["view_00001.npz"]
    assert "blake2b" in json.loads((tmp_path / "view_00000.json").read_text())["files"]["view_00000.npz"]


def test_views_on_two_workers_match_serial(scene, tmp_path):
    cams = orbit_cameras(scene.camera, 5)
    render_views(scene, cams, tmp_path / "serial", files=rs.ViewFiles(buffers=["zdepth", "position", "id"], image=None))
    render_views(scene, cams, tmp_path / "dask", files=rs.ViewFiles(buffers=["zdepth", "position", "id"], image=None),
                 run=rs.RunOptions(workers=2, numba_threads=1, per_task=2))
    assert _names(tmp_path / "serial") == _names(tmp_path / "dask")
    for name in _names(tmp_path / "serial"):
        if name.endswith(".npz"):
            a, b = load_npz(tmp_path / "serial" / name), load_npz(tmp_path / "dask" / name)
            assert a.keys() == b.keys() and all(np.array_equal(a[k], b[k]) for k in a), name
    assert json.load(open(tmp_path / "serial" / INDEX_NAME)) == json.load(open(tmp_path / "dask" / INDEX_NAME))


def test_views_check_arguments_before_rendering(scene, tmp_path):
    cams = orbit_cameras(scene.camera, 2)
    with pytest.raises(ValueError, match="buffers: unknown buffer 'depht'"):
        render_views(scene, cams, tmp_path / "a", files=rs.ViewFiles(buffers=["depht"]))
    with pytest.raises(ValueError, match="formats: unknown format 'tiff'"):
        render_views(scene, cams, tmp_path / "a", files=rs.ViewFiles(formats=["tiff"]))
    with pytest.raises(ValueError, match="image:"):
        render_views(scene, cams, tmp_path / "a", files=rs.ViewFiles(image=".exr"))
    with pytest.raises(TypeError, match="cameras\\[1\\]"):
        render_views(scene, [cams[0], "camera"], tmp_path / "a")
    assert not (tmp_path / "a").exists()


def test_cli_views(tmp_path, capsys):
    out = tmp_path / "set"
    code = main(["views", os.path.join(ROOT, "examples", "shapes.toml"), "--orbit", "2", "--buffers",
                 "depth,normal,id", "--width", "32", "--height", "24", "-o", str(out)])
    assert code == 0
    assert "2 views" in capsys.readouterr().out
    data = json.load(open(out / INDEX_NAME))
    assert len(data["views"]) == 2 and data["views"][0]["width"] == 32
    assert set(load_npz(out / "view_00001.npz")) >= {"depth", "normal", "model_id", "triangle_id", "K", "R", "t"}
    code = main(["views", os.path.join(ROOT, "examples", "shapes.toml"), "--orbit", "2", "--buffers", "depth,foo",
                 "-o", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "unknown buffer 'foo'" in err and "Traceback" not in err


def test_cli_views_of_a_mesh_file(tmp_path, capsys):
    """``views`` takes a mesh file as ``render`` does: framed and lit by ``model_scene``; each view's
    buffers are those of a render of that scene from the orbit's camera."""
    import imageio.v3 as iio
    import trimesh

    from raycast_shade.scene.meshfile import model_scene

    path = tmp_path / "ball.obj"
    trimesh.creation.icosphere(2).export(path)
    out = tmp_path / "set"
    code = main(["views", str(path), "--orbit", "3", "--width", "32", "--height", "24", "-o", str(out)])
    assert code == 0 and "3 views" in capsys.readouterr().out
    scene = model_scene(path, width=32, height=24)
    cam = orbit_cameras(scene.camera, 3)[2]
    frame = rs.render(scene, camera=cam, buffers=("zdepth", "normal", "id", "mask"))
    data = load_npz(out / "view_00002.npz")
    np.testing.assert_array_equal(data["zdepth"], frame.buffers["zdepth"])
    assert data["mask"].any() and not data["mask"].all()
    np.testing.assert_array_equal(iio.imread(out / "view_00002.png"), frame.to_uint8())
    code = main(["views", str(path), "--orbit", "2", "--shading", "flat,phong", "-o", str(tmp_path / "b")])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "one method for a mesh file" in err


def test_memory_stays_flat_as_the_number_of_views_grows(scene, tmp_path):
    """Each view's buffers are written and dropped before the next: the peak of traced
    allocations (NumPy's included) for 24 views is that of 3, not 8 times it."""
    import tracemalloc

    big = scene.replace(camera=scene.camera.replace(width=160, height=120))
    peaks = {}
    for n in (3, 24):
        cams = orbit_cameras(big.camera, n)
        tracemalloc.start()
        render_views(big, cams, tmp_path / f"n{n}", files=rs.ViewFiles(buffers=["zdepth", "normal", "position", "id"]))
        peaks[n] = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
    one_view = 160 * 120 * (12 + 4 + 12 + 12 + 8)  # image, zdepth, normal, position, ids
    assert peaks[24] < peaks[3] + 2 * one_view, peaks


def test_render_views_is_public():
    assert rs.render_views is render_views and "render_views" in rs.__all__
