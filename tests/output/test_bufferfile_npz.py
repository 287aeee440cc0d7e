"""save_npz's threaded writer: every codec, thread count and chunking reads back bit for bit with numpy
and zipfile (CRCs checked), and the file is what np.savez's reader expects."""

from __future__ import annotations

import io
import zipfile
import zlib

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from raycast_shade.output import npzwrite
from raycast_shade.output.bufferfile import load_npz, save_npz
from raycast_shade.output.npzwrite import deflate_backend, write_npz


def _arrays(h=24, w=32, seed=5):
    rng = np.random.default_rng(seed)
    z = np.round(rng.random((h, w)), 3).astype(np.float32)
    return {"zdepth": z, "position": rng.normal(size=(h, w, 3)).astype(np.float32),
            "triangle_id": rng.integers(-1, 2**31 - 1, (h, w), dtype=np.int32), "mask": z > 0.4,
            "wide": np.asfortranarray(rng.random((h, w))), "K": np.eye(3)}


def _buffers():
    return {k: v for k, v in _arrays().items() if k != "K"}  # save_npz's buffers share one (H, W)


def _check_zip(data: bytes, arrays: dict, method: int):
    with zipfile.ZipFile(io.BytesIO(data)) as zf:
        assert zf.testzip() is None  # every member's CRC-32 and sizes as its headers say
        assert [i.filename for i in zf.infolist()] == [k + ".npy" for k in arrays]
        assert {i.compress_type for i in zf.infolist()} == {method}
    with np.load(io.BytesIO(data), allow_pickle=False) as back:
        for name, a in arrays.items():
            assert back[name].dtype == a.dtype and back[name].shape == a.shape, name
            assert np.array_equal(back[name], a), name


def _write(arrays, level, **kw) -> bytes:
    fh = io.BytesIO()
    write_npz(fh, arrays, level, **kw)
    return fh.getvalue()


@pytest.mark.parametrize("level", [None, 0, 1, 3, 6, 9])
@pytest.mark.parametrize("threads", [0, 3])
@pytest.mark.parametrize("prefer_isal", [True, False])
def test_every_level_thread_count_and_backend_reads_back(monkeypatch, level, threads, prefer_isal):
    monkeypatch.setattr(npzwrite, "CHUNK", 1000)  # many chunks per member: their joins are tested
    arrays = _arrays()
    data = _write(arrays, level, threads=threads, prefer_isal=prefer_isal)
    _check_zip(data, arrays, zipfile.ZIP_STORED if level is None else zipfile.ZIP_DEFLATED)


def test_isal_is_used_where_it_serves_and_installed():
    pytest.importorskip("isal")
    assert [deflate_backend(v) for v in (None, 0, 1, 2, 3, 4, 9)] == ["stored", "zlib", "isal", "isal", "isal",
                                                                      "zlib", "zlib"]
    assert deflate_backend(1, prefer_isal=False) == "zlib"


def test_stored_members_are_the_npy_files_np_save_writes():
    arrays = _arrays()
    with zipfile.ZipFile(io.BytesIO(_write(arrays, None))) as zf:
        for name, a in arrays.items():
            ref = io.BytesIO()
            np.save(ref, np.ascontiguousarray(a))  # a Fortran-ordered array is stored C-ordered
            assert zf.read(name + ".npy") == ref.getvalue(), name


def test_same_arrays_same_bytes_whatever_the_threads():
    arrays = _arrays()
    assert _write(arrays, 1, threads=0) == _write(arrays, 1, threads=4)
    assert _write(arrays, None, threads=0) == _write(arrays, None, threads=2)


def test_chunked_deflate_is_one_stream_a_plain_inflater_reads(monkeypatch):
    monkeypatch.setattr(npzwrite, "CHUNK", 512)
    a = np.arange(5000, dtype=np.float32)
    with zipfile.ZipFile(io.BytesIO(_write({"a": a}, 1, threads=2))) as zf:
        info = zf.infolist()[0]
        raw = zf.fp.getvalue()
    start = info.header_offset + 30 + len(info.filename) + 20  # local header, name, ZIP64 extra
    stream = raw[start:start + info.compress_size]
    d = zlib.decompressobj(-15)
    body = d.decompress(stream)
    assert d.eof and not d.unused_data  # one deflate stream, ended once, at the end
    ref = io.BytesIO()
    np.save(ref, a)
    assert body == ref.getvalue()


def test_non_ascii_names_are_flagged_utf8(tmp_path):
    b = {"tiefe_ä": np.ones((2, 3), np.float32)}
    path = save_npz(tmp_path / "a.npz", b)
    with zipfile.ZipFile(path) as zf:
        assert zf.namelist() == ["tiefe_ä.npy"]
    assert np.array_equal(load_npz(path)["tiefe_ä"], b["tiefe_ä"])


@settings(max_examples=25, deadline=None)
@given(h=st.integers(1, 9), w=st.integers(1, 9), level=st.sampled_from([None, 1, 5]), chunk=st.integers(1, 64),
       seed=st.integers(0, 2**16))
def test_any_shape_and_chunk_size_round_trips(h, w, level, chunk, seed):
    old = npzwrite.CHUNK
    npzwrite.CHUNK = chunk  # hypothesis and monkeypatch's function scope do not mix: restored below
    try:
        arrays = _arrays(h, w, seed)
        _check_zip(_write(arrays, level, threads=2), arrays,
                   zipfile.ZIP_STORED if level is None else zipfile.ZIP_DEFLATED)
    finally:
        npzwrite.CHUNK = old


def test_save_npz_threads_checked_before_the_file_is_opened(tmp_path):
    with pytest.raises(ValueError, match="threads"):
        save_npz(tmp_path / "a.npz", _buffers(), threads=-1)
    with pytest.raises(TypeError, match="threads"):
        save_npz(tmp_path / "a.npz", _buffers(), threads=1.5)
    assert not (tmp_path / "a.npz").exists()


def test_compressed_true_is_level_one(tmp_path):
    a = save_npz(tmp_path / "a.npz", _buffers(), compressed=True)
    b = save_npz(tmp_path / "b.npz", _buffers(), compressed=1)
    assert open(a, "rb").read() == open(b, "rb").read()
