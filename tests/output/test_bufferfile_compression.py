"""save_npz's deflate levels and write_exr's compressions: every choice reads back bit for bit."""

from __future__ import annotations

import zipfile

import numpy as np
import pytest

from raycast_shade.output.bufferfile import EXR_COMPRESSIONS, load_npz, read_exr, save_npz, write_exr


def _buffers():
    rng = np.random.default_rng(3)
    z = np.round(rng.random((24, 32)), 2).astype(np.float32)  # repetitive enough to compress
    return {"zdepth": z, "normal": np.repeat(z[..., None], 3, axis=2), "model_id": (z > 0.5).astype(np.int32) - 1,
            "mask": z > 0.2}


@pytest.mark.parametrize("compressed, kind", [(False, zipfile.ZIP_STORED), (True, zipfile.ZIP_DEFLATED),
                                              (1, zipfile.ZIP_DEFLATED), (9, zipfile.ZIP_DEFLATED)])
def test_npz_levels_read_back_with_numpy(tmp_path, compressed, kind):
    b = _buffers()
    path = save_npz(tmp_path / "a.npz", b, image=np.ones((24, 32, 3), np.float32), compressed=compressed)
    with zipfile.ZipFile(path) as zf:
        assert {i.compress_type for i in zf.infolist()} == {kind}
    back = load_npz(path)
    assert set(back) == set(b) | {"image"}
    for name, buf in b.items():
        assert back[name].dtype == buf.dtype and np.array_equal(back[name], buf), name
    with np.load(path) as data:  # numpy's own reader
        assert np.array_equal(data["normal"], b["normal"])


def test_npz_levels_shrink_the_file(tmp_path):
    sizes = [(tmp_path / f"{c}.npz").stat().st_size if save_npz(tmp_path / f"{c}.npz", _buffers(), compressed=c)
             else 0 for c in (False, 1)]
    assert sizes[1] < 0.7 * sizes[0]


@pytest.mark.parametrize("bad, exc", [(10, ValueError), (-1, ValueError), ("zip", TypeError), (1.0, TypeError)])
def test_bad_npz_level_is_refused_before_the_file_is_opened(tmp_path, bad, exc):
    with pytest.raises(exc, match="compressed: expected"):
        save_npz(tmp_path / "a.npz", _buffers(), compressed=bad)
    assert not (tmp_path / "a.npz").exists()


@pytest.mark.parametrize("compression", EXR_COMPRESSIONS)
def test_exr_compressions_read_back(tmp_path, compression):
    pytest.importorskip("OpenEXR")
    b = _buffers()
    path = write_exr(tmp_path / "a.exr", b, compression=compression, threads=2)
    back = read_exr(path)
    for name, buf in b.items():
        assert np.array_equal(back[name], buf), name


def test_exr_compression_and_threads_are_checked_and_the_thread_count_restored(tmp_path):
    OpenEXR = pytest.importorskip("OpenEXR")
    before = OpenEXR.global_thread_count()
    with pytest.raises(ValueError, match="compression: expected one of"):
        write_exr(tmp_path / "a.exr", _buffers(), compression="lzma")
    with pytest.raises(ValueError, match="threads: must be >= 0"):
        write_exr(tmp_path / "a.exr", _buffers(), threads=-2)
    assert not (tmp_path / "a.exr").exists()
    write_exr(tmp_path / "a.exr", _buffers(), compression="zip", threads=before + 3)
    assert OpenEXR.global_thread_count() == before
    none, zipped = (tmp_path / "n.exr"), (tmp_path / "a.exr")
    write_exr(none, _buffers())
    assert zipped.stat().st_size < none.stat().st_size


@pytest.mark.parametrize("compression", ["none", "zips", "zip"])
@pytest.mark.parametrize("threads", [0, 3])
@pytest.mark.parametrize("isal", [True, False])
def test_numpy_exr_writer_reads_back_in_openexr_bit_for_bit(tmp_path, monkeypatch, compression, threads, isal):
    """Our layout of uncompressed, ZIPS and ZIP files against OpenEXR's reader, odd sizes included (a
    last ZIP block of fewer than 16 lines), with ISA-L's deflate and zlib's."""
    import sys

    OpenEXR = pytest.importorskip("OpenEXR")
    if isal:
        pytest.importorskip("isal")
    else:
        monkeypatch.setitem(sys.modules, "isal", None)
    rng = np.random.default_rng(11)
    h, w = 37, 23
    b = {"zdepth": rng.random((h, w), dtype=np.float32), "normal": rng.normal(size=(h, w, 3)).astype(np.float32),
         "flat": np.full((h, w), 2.5, np.float32),  # compresses: the deflated blocks
         "triangle_id": rng.integers(-1, 2**31 - 1, (h, w)).astype(np.int32), "mask": rng.random((h, w)) > 0.5}
    image = rng.random((h, w, 3), dtype=np.float32)
    path = write_exr(tmp_path / "a.exr", b, image=image, compression=compression, threads=threads)
    with OpenEXR.File(str(path), separate_channels=True) as f:
        assert f.header()["compression"] == getattr(OpenEXR, ("NO" if compression == "none" else compression.upper())
                                                    + "_COMPRESSION")
        raw = {k: v.pixels for k, v in f.channels().items()}
    assert np.array_equal(raw["normal.Y"], b["normal"][..., 1]) and raw["triangle_id"].dtype == np.uint32
    assert np.array_equal(raw["triangle_id"], (b["triangle_id"].astype(np.int64) + 1).astype(np.uint32))
    back = read_exr(path)
    assert np.array_equal(back["image"], image)
    for name, buf in b.items():
        assert back[name].dtype == buf.dtype and np.array_equal(back[name], buf), name


@pytest.mark.parametrize("band_bytes", [1, 5000])
def test_uncompressed_exr_written_band_by_band_reads_back(tmp_path, monkeypatch, band_bytes):
    """Uncompressed lines assembled a band at a time (one line; a few lines and a short last band)."""
    pytest.importorskip("OpenEXR")
    from raycast_shade.output import exrwrite

    monkeypatch.setattr(exrwrite, "_BAND_BYTES", band_bytes)
    rng = np.random.default_rng(12)
    b = {"position": rng.normal(size=(19, 7, 3)).astype(np.float32), "model_id": rng.integers(-1, 5, (19, 7)),
         "mask": rng.random((19, 7)) > 0.3}
    back = read_exr(write_exr(tmp_path / "a.exr", b))
    for name, buf in b.items():
        assert np.array_equal(back[name], buf), name
