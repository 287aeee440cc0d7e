"""render_views' file options: the float image only when asked, compression a choice."""

from __future__ import annotations

import json
import zipfile

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.apps.animate import orbit_cameras
from raycast_shade.apps.views import render_views
from raycast_shade.output.bufferfile import load_npz, read_exr


@pytest.fixture(scope="module")
def scene():
    return rs.Scene([rs.Model(rs.shapes.icosphere(2))], lights=[rs.PointLight((2, 3, 4), intensity=20)],
                    camera=rs.Camera(eye=(0.3, 0.5, 4.0), width=48, height=36))


def _members(path):
    with zipfile.ZipFile(path) as zf:
        return {i.filename: i.compress_type for i in zf.infolist()}


def test_float_image_and_zip_compression_when_asked(scene, tmp_path):
    cam = orbit_cameras(scene.camera, 1)
    render_views(scene, cam, tmp_path / "a", files=rs.ViewFiles(buffers=["zdepth", "id"], formats=["npz", "exr"],
                                                                image=None, compression="none"))
    render_views(scene, cam, tmp_path / "b", files=rs.ViewFiles(buffers=["zdepth", "id"], formats=["npz", "exr"],
                                                                image=None, float_image=True, compression="zip"))
    plain, zipped = _members(tmp_path / "a" / "view_00000.npz"), _members(tmp_path / "b" / "view_00000.npz")
    assert "image.npy" not in plain and set(plain.values()) == {zipfile.ZIP_STORED}
    assert "image.npy" in zipped and set(zipped.values()) == {zipfile.ZIP_DEFLATED}
    frame = rs.render(scene, camera=cam[0], buffers=("zdepth", "id"))
    a, b = load_npz(tmp_path / "a" / "view_00000.npz"), load_npz(tmp_path / "b" / "view_00000.npz")
    ea, eb = read_exr(tmp_path / "a" / "view_00000.exr"), read_exr(tmp_path / "b" / "view_00000.exr")
    assert "image" not in ea and np.array_equal(eb["image"], frame.image) and np.array_equal(b["image"], frame.image)
    for name, buf in frame.buffers.items():
        assert np.array_equal(a[name], buf) and np.array_equal(b[name], buf) and np.array_equal(eb[name], buf)


@pytest.mark.parametrize("isal", [True, False])
def test_auto_compression_zips_where_isal_is_installed_and_the_plan_says_which(scene, tmp_path, monkeypatch, isal):
    import json
    import sys

    if isal:
        pytest.importorskip("isal")
    else:
        monkeypatch.setitem(sys.modules, "isal", None)
    render_views(scene, orbit_cameras(scene.camera, 1), tmp_path, files=rs.ViewFiles(buffers=["zdepth"], image=None))
    want = "zip" if isal else "none"
    assert set(_members(tmp_path / "view_00000.npz").values()) == {zipfile.ZIP_DEFLATED if isal else zipfile.ZIP_STORED}
    with open(tmp_path / "plan.json") as fh:
        assert json.load(fh)["settings"]["compression"] == want


def test_bad_file_options_are_refused_before_anything_is_written(scene, tmp_path):
    cam = orbit_cameras(scene.camera, 1)
    with pytest.raises(ValueError, match="compression: expected one of.*'zstd'"):
        render_views(scene, cam, tmp_path / "x", files=rs.ViewFiles(compression="zstd"))
    with pytest.raises(TypeError, match="float_image: expected True or False"):
        render_views(scene, cam, tmp_path / "x", files=rs.ViewFiles(float_image="yes"))
    assert not (tmp_path / "x").exists()


def test_each_views_files_hold_that_views_frame_with_the_writer_thread(scene, tmp_path):
    import imageio.v3 as iio

    from raycast_shade.output.tonemap import to_uint8

    cams = orbit_cameras(scene.camera, 3)
    render_views(scene, cams, tmp_path,
                 files=rs.ViewFiles(buffers=["zdepth", "normal", "id"], formats=["npz", "depth_png"]))
    for i, cam in enumerate(cams):  # view i rendered while view i - 1 was written: nothing crossed over
        frame = rs.render(scene, camera=cam, buffers=("zdepth", "normal", "id"))
        back = load_npz(tmp_path / f"view_{i:05d}.npz")
        for name, buf in frame.buffers.items():
            assert np.array_equal(back[name], buf), (i, name)
        assert np.array_equal(iio.imread(tmp_path / f"view_{i:05d}.png"), to_uint8(frame.image)), i
        record = json.loads((tmp_path / f"view_{i:05d}.json").read_text())
        ids = frame.buffers["model_id"]  # the objects, now listed on the writer thread, are this view's
        rows, cols = np.nonzero(ids == 0)
        assert [(o["id"], o["pixels"], o["box"]) for o in record["objects"]] == \
            [(0, rows.size, [cols.min(), rows.min(), cols.max() + 1, rows.max() + 1])], i


@pytest.mark.parametrize("overlap", [True, False])
def test_the_writer_threads_numba_threads_are_its_own(scene, tmp_path, monkeypatch, overlap):
    import numba

    from raycast_shade.apps import views

    seen = []
    real = views._write_files
    monkeypatch.setattr(views, "_two_frames_fit", lambda jobs, memory: overlap)
    monkeypatch.setattr(views, "_write_files", lambda *a: (seen.append(numba.get_num_threads()), real(*a))[1])
    top = numba.config.NUMBA_NUM_THREADS
    numba.set_num_threads(top)
    render_views(scene, orbit_cameras(scene.camera, 2), tmp_path, files=rs.ViewFiles(buffers=["zdepth"]))
    # on the writer thread its kernels run alone; the caller's keep every thread they had
    assert seen == ([1, 1] if overlap else [top, top])
    assert numba.get_num_threads() == top


def test_a_failed_write_stops_the_set_without_its_record_and_a_rerun_finishes_it(scene, tmp_path, monkeypatch):
    import raycast_shade.apps.views as views

    cams = orbit_cameras(scene.camera, 3)
    real = views.npz_into
    calls = []

    def failing(fh, *args, **kw):  # fails halfway through the second view's npz
        calls.append(fh)
        if len(calls) == 2:
            fh.write(b"PK\x03\x04 half a file")
            raise OSError("disk full (simulated)")
        return real(fh, *args, **kw)

    monkeypatch.setattr(views, "npz_into", failing)
    with pytest.raises(OSError, match="disk full"):
        render_views(scene, cams, tmp_path / "set", files=rs.ViewFiles(buffers=["zdepth"], image=None))
    assert (tmp_path / "set" / "view_00000.json").exists()
    assert not (tmp_path / "set" / "view_00001.json").exists()
    assert not (tmp_path / "set" / "view_00001.npz").exists()  # the atomic write left no half file
    monkeypatch.setattr(views, "npz_into", real)
    render_views(scene, cams, tmp_path / "set", files=rs.ViewFiles(buffers=["zdepth"], image=None))
    render_views(scene, cams, tmp_path / "one", files=rs.ViewFiles(buffers=["zdepth"], image=None))
    for i in range(3):  # the finished set holds the bytes a single run writes
        name = f"view_{i:05d}.npz"
        assert (tmp_path / "set" / name).read_bytes() == (tmp_path / "one" / name).read_bytes(), name


def test_views_overlap_only_where_two_frames_fit_the_memory_limit(scene, monkeypatch, tmp_path):
    import raycast_shade.common.validate as validate
    from raycast_shade.apps import views
    from raycast_shade.scene.framememory import frame_bytes_per_pixel

    jobs = [type("Job", (), {"camera": c})() for c in orbit_cameras(scene.camera, 2)]
    memory = dict(buffers=("zdepth", "model_id"), samples=1)
    one = scene.camera.width * scene.camera.height * frame_bytes_per_pixel(**memory)
    monkeypatch.setattr(validate, "memory_limit", lambda: 2 * one)
    assert views._two_frames_fit(jobs, memory)
    monkeypatch.setattr(validate, "memory_limit", lambda: 2 * one - 1)
    assert not views._two_frames_fit(jobs, memory)
    # without the overlap the set is written all the same, view after view
    render_views(scene, orbit_cameras(scene.camera, 2), tmp_path, files=rs.ViewFiles(buffers=["zdepth"], image=None))
    assert sorted(p.name for p in tmp_path.glob("view_*.npz")) == ["view_00000.npz", "view_00001.npz"]


def test_a_view_set_packs_and_builds_its_bvh_once(scene, tmp_path, monkeypatch):
    import raycast_shade.visibility.embree as embree

    builds = []
    real = embree.EmbreeAccel.__init__

    def counting(self, *args, **kw):
        builds.append(1)
        real(self, *args, **kw)

    monkeypatch.setattr(embree.EmbreeAccel, "__init__", counting)
    fresh = rs.Scene([rs.Model(rs.shapes.icosphere(1))], lights=scene.lights, camera=scene.camera)  # no BVH yet
    render_views(fresh, orbit_cameras(scene.camera, 3), tmp_path, files=rs.ViewFiles(buffers=["zdepth"], image=None))
    assert len(builds) == 1  # one mesh set: one BVH, shared by the three views


@pytest.mark.parametrize("overlap", [True, False])
def test_views_of_several_sizes_each_render_into_arrays_of_their_size(scene, tmp_path, monkeypatch, overlap):
    import imageio.v3 as iio

    from raycast_shade.apps import views
    from raycast_shade.output.tonemap import to_uint8

    monkeypatch.setattr(views, "_two_frames_fit", lambda jobs, memory: overlap)  # two image arrays, or one

    small = scene.camera.replace(width=40, height=30)
    cams = [scene.camera, small, small, scene.camera]  # the image arrays are replaced, then reused in turn
    render_views(scene, cams, tmp_path, files=rs.ViewFiles(buffers=["zdepth"], formats=["npz"]))
    for i, cam in enumerate(cams):
        want = to_uint8(rs.render(scene, camera=cam).image)
        assert np.array_equal(iio.imread(tmp_path / f"view_{i:05d}.png"), want), i


@pytest.mark.parametrize("image", [".png", ".pfm"])
def test_the_records_sizes_and_digests_are_hashlibs_over_the_files(scene, tmp_path, image):
    """Hashed as written (PNG, npz, EXR, depth PNG) or read back (other images): hashlib's SHA-256
    over each file on disk, and the files equal those of the path-taking writers."""
    import hashlib

    from raycast_shade.output.bufferfile import save_npz, write_depth_png, write_exr
    from raycast_shade.output.imagefile import write_image

    cams = orbit_cameras(scene.camera, 2)
    render_views(scene, cams, tmp_path / "v", files=rs.ViewFiles(buffers=["zdepth", "normal", "id", "mask"],
                                                                 formats=["npz", "exr", "depth_png"], image=image,
                                                                 compression="zip"))
    for i in range(2):
        record = json.loads((tmp_path / "v" / f"view_{i:05d}.json").read_text())
        assert len(record["files"]) == 4
        for name, entry in record["files"].items():
            data = (tmp_path / "v" / name).read_bytes()
            assert entry["bytes"] == len(data) > 0
            assert entry["sha256"] == hashlib.sha256(data).hexdigest(), name
    frame = rs.render(scene, camera=cams[1], buffers=("zdepth", "normal", "id", "mask"))
    kept = {k: frame.buffers[k] for k in ("zdepth", "normal", "model_id", "triangle_id", "mask")}
    ref = {"npz": save_npz(tmp_path / "r.npz", kept, camera=cams[1], compressed=1),
           "exr": write_exr(tmp_path / "r.exr", kept, compression="zip"),
           "_depth.png": write_depth_png(tmp_path / "r.png", frame.buffers["zdepth"], fast=True),
           image: write_image(tmp_path / ("i" + image), frame.image, fast=True)}
    for suffix, path in ref.items():
        name = f"view_00001{suffix if suffix.startswith('_') else '.' + suffix.lstrip('.')}"
        assert (tmp_path / "v" / name).read_bytes() == open(path, "rb").read(), name


def test_view_files_passed_whole_write_what_the_deprecated_keyword_arguments_write(scene, tmp_path):
    from raycast_shade.apps.views import ViewFiles

    cams = orbit_cameras(scene.camera, 2)
    kw = dict(buffers=["zdepth", "id"], formats=["npz", "depth_png"], image=".PNG", depth_scale=500.0,
              float_image=True, compression="none")
    with pytest.warns(DeprecationWarning) as caught:
        render_views(scene, cams, tmp_path / "kw", **kw)
    # one warning per flat keyword, each naming the field of files that replaces it
    assert sorted(str(w.message).split("=")[0] for w in caught) == sorted(kw)
    assert all(f"files=ViewFiles({str(w.message).split('=')[0]}=...)" in str(w.message) for w in caught)
    files = ViewFiles(**kw)
    assert files.buffers == ("zdepth", "id") and files.formats == ("npz", "depth_png") and files.image == ".png"
    render_views(scene, cams, tmp_path / "whole", files=files)
    for name in ("plan.json", "view_00001.npz", "view_00001_depth.png", "view_00001.png", "view_00001.json"):
        assert (tmp_path / "kw" / name).read_bytes() == (tmp_path / "whole" / name).read_bytes(), name
    # the same plan: the folder written with keyword arguments resumes with files= (nothing rendered again)
    render_views(scene, cams, tmp_path / "kw", files=files)
    with pytest.raises(ValueError, match=r"files: depth_scale=1000.0 is given besides files.depth_scale=500.0"), \
            pytest.warns(DeprecationWarning):
        render_views(scene, cams, tmp_path / "x", files=files, depth_scale=1000.0)
    with pytest.raises(TypeError, match="files: expected"):
        render_views(scene, cams, tmp_path / "x", files={"buffers": ["zdepth"]})
    assert not (tmp_path / "x").exists()


@pytest.mark.parametrize("field, value, error, match", [
    ("buffers", ["zdepth", "nope"], ValueError, "buffers"),
    ("formats", ["npz", "tiff"], ValueError, "formats: unknown format"),
    ("image", ".exr", ValueError, "image"),
    ("image", 5, TypeError, "image"),
    ("depth_scale", 0.0, ValueError, "depth_scale"),
    ("float_image", "yes", TypeError, "float_image"),
    ("compression", "lzma", ValueError, "compression"),
])
def test_view_files_refuse_bad_fields_naming_them(field, value, error, match):
    from raycast_shade.apps.views import ViewFiles

    with pytest.raises(error, match=match):
        ViewFiles(**{field: value})
    with pytest.raises(ValueError, match="formats: nothing to write"):
        ViewFiles(formats=(), image=None)
