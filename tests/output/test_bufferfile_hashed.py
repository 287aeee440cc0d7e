"""Files hashed as they are written (the view sets' records): the digest and size are hashlib's over
the file on disk, and the in-memory writers give the bytes of the path-taking writers."""

from __future__ import annotations

import hashlib

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.output.bufferfile import (depth_png_bytes, exr_into, npz_into, save_npz, write_depth_png,
                                             write_exr)
from raycast_shade.output.imagefile import HashingWriter, write_hashed


def _buffers(h=37, w=53, seed=0):
    rng = np.random.default_rng(seed)
    ids = rng.integers(-1, 3, (h, w)).astype(np.int32)
    return {"zdepth": rng.uniform(0.5, 3.0, (h, w)).astype(np.float32),
            "normal": rng.normal(size=(h, w, 3)).astype(np.float32),
            "model_id": ids, "mask": ids >= 0}


def _file_digest(path) -> str:
    return hashlib.blake2b(path.read_bytes(), digest_size=16).hexdigest()


@pytest.mark.parametrize("compressed", [False, 1, 6])
def test_npz_written_through_a_hash_is_save_npz_and_its_digest_hashlib(tmp_path, compressed):
    bufs = _buffers()
    cam = rs.Camera(eye=(0.0, 0.0, 4.0), width=53, height=37)
    save_npz(tmp_path / "a.npz", bufs, camera=cam, compressed=compressed)
    size, digest = write_hashed(tmp_path / "b.npz", lambda fh: npz_into(fh, bufs, camera=cam, compressed=compressed,
                                                                        threads=2),
                                hashlib.blake2b(digest_size=16))
    data = (tmp_path / "b.npz").read_bytes()
    assert data == (tmp_path / "a.npz").read_bytes()
    assert size == len(data) and digest == _file_digest(tmp_path / "b.npz")
    back = np.load(tmp_path / "b.npz")
    assert np.array_equal(back["normal"], bufs["normal"]) and np.array_equal(back["mask"], bufs["mask"])


def test_npz_into_never_seeks(tmp_path):
    """Front to back: a stream that cannot seek or tell takes the whole file."""

    class Stream:
        def __init__(self):
            self.parts = []

        def write(self, b):
            self.parts.append(bytes(b))
            return len(self.parts[-1])

    bufs = _buffers(h=600, w=1200, seed=3)  # several 4 MiB deflate chunks per member
    out = Stream()
    npz_into(out, bufs, compressed=1, threads=2)
    save_npz(tmp_path / "a.npz", bufs, compressed=1)
    assert b"".join(out.parts) == (tmp_path / "a.npz").read_bytes()


@pytest.mark.parametrize("compression", ["none", "zip"])
def test_exr_into_is_write_exr(tmp_path, compression):
    bufs = _buffers(seed=1)
    write_exr(tmp_path / "a.exr", bufs, compression=compression)
    size, digest = write_hashed(tmp_path / "b.exr", lambda fh: exr_into(fh, bufs, compression=compression),
                                hashlib.blake2b(digest_size=16))
    assert (tmp_path / "b.exr").read_bytes() == (tmp_path / "a.exr").read_bytes()
    assert digest == _file_digest(tmp_path / "b.exr") and size == (tmp_path / "b.exr").stat().st_size


def test_exr_into_refuses_compressions_openexr_writes():
    with pytest.raises(ValueError, match="compression"):
        exr_into(None, _buffers(), compression="piz")


def test_depth_png_bytes_are_write_depth_pngs_file(tmp_path):
    depth = _buffers()["zdepth"]
    write_depth_png(tmp_path / "d.png", depth, fast=True)
    assert depth_png_bytes(depth, fast=True) == (tmp_path / "d.png").read_bytes()
    with pytest.raises(ValueError, match="depth: negative value"):
        depth_png_bytes(-depth)


def test_a_failed_fill_leaves_no_file_and_sizes_count_every_write(tmp_path):
    def fill(fh):
        fh.write(b"abc")
        fh.write(np.arange(10, dtype=np.uint16))  # any C-contiguous buffer
        raise OSError("disk full (simulated)")

    with pytest.raises(OSError, match="disk full"):
        write_hashed(tmp_path / "x.bin", fill, hashlib.sha256())
    assert list(tmp_path.iterdir()) == []
    h = hashlib.sha256()
    sink = HashingWriter(open(tmp_path / "y.bin", "wb"), h)
    sink.write(b"abc")
    sink.write(np.arange(10, dtype=np.uint16))
    sink.fh.close()
    assert sink.size == 23 and h.hexdigest() == hashlib.sha256((tmp_path / "y.bin").read_bytes()).hexdigest()
