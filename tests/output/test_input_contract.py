"""The input contract of frame files: tone options a format would ignore, misspelt or
out of range, and output paths that cannot be written, refused before anything is
rendered or written (issue 17, classes 4 and 8; the scene's side:
``tests/scene/test_input_contract.py``).
"""

from __future__ import annotations

import os

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.output.imagefile import check_image_path

from tests.conftest import small_scene


# =====================================================================================================
# 4. Silently accepted: tone options a format ignores, misspelt or out of range
# =====================================================================================================
@pytest.fixture
def frame():
    return rs.render(small_scene())


@pytest.mark.parametrize("ext", [".png", ".pfm", ".npy", ".jpg"])
@pytest.mark.parametrize("kwargs, error, match", [
    (dict(exposur=2), TypeError, r"save: unexpected keyword argument 'exposur' \(did you mean 'exposure'\?\)"),
    (dict(gama=2.2), TypeError, r"unexpected keyword argument 'gama' \(did you mean 'gamma'\?\)"),
    (dict(tone_map="clamp"), TypeError, r"unexpected keyword argument 'tone_map' \(did you mean 'tonemap'\?\)"),
    (dict(quality=90), TypeError, r"unexpected keyword argument 'quality'; expected exposure, tonemap, gamma"),
    (dict(exposure=-1), ValueError, r"exposure: must be > 0"),
    (dict(exposure=0.0), ValueError, r"exposure: must be > 0"),
    (dict(exposure=np.nan), ValueError, r"exposure: must be finite"),
    (dict(exposure=True), TypeError, r"exposure: expected a number, got bool"),
    (dict(exposure="2"), TypeError, r"exposure: expected a number, got str"),
    (dict(gamma=-2.2), ValueError, r"gamma: must be > 0"),
    (dict(gamma="linear"), ValueError, r"gamma: expected 'srgb' or a number"),
    (dict(gamma=True), TypeError, r"gamma: expected a number"),
    (dict(tonemap="aces"), ValueError, r"tonemap: expected one of"),
    (dict(tonemap=1), TypeError, r"tonemap: expected a string"),
])
def test_frame_save_refuses_bad_tone_options_for_every_format(frame, tmp_path, ext, kwargs, error, match):
    path = tmp_path / f"x{ext}"
    with pytest.raises(error, match=match):
        frame.save(path, **kwargs)
    assert not path.exists()


@pytest.mark.parametrize("ext", [".pfm", ".npy"])
@pytest.mark.parametrize("kwargs", [dict(exposure=2.0), dict(tonemap="reinhard"), dict(gamma="srgb"),
                                    dict(exposure=1.0, gamma=2.2)])
def test_tone_options_with_a_linear_format_are_refused(frame, tmp_path, ext, kwargs):
    """A .pfm stores the linear image: exposure=2 had no effect and no word said so."""
    with pytest.raises(ValueError, match=rf"{', '.join(kwargs)}: tone options do not apply to \{ext}"):
        frame.save(tmp_path / f"x{ext}", **kwargs)
    frame.save(tmp_path / f"x{ext}")  # without them: written


def test_frame_save_still_takes_valid_tone_options(frame, tmp_path):
    frame.save(tmp_path / "a.png", exposure=np.float32(2.0), tonemap="reinhard", gamma=np.int64(2))
    assert (tmp_path / "a.png").exists()



# =====================================================================================================
# 8. Late errors: an output that cannot be written is refused before rendering
# =====================================================================================================
def test_an_output_that_is_a_folder_is_refused(tmp_path):
    (tmp_path / "d.png").mkdir()
    with pytest.raises(ValueError, match=r"output: '.*d\.png' is a folder, not a file"):
        check_image_path(tmp_path / "d.png", "output", writable=True)
    assert check_image_path(tmp_path / "d.png", "output") == ".png"  # the extension check alone is unchanged


@pytest.mark.parametrize("rel", ["missing/x.png", "a/b/c/x.pfm", "missing/x.npy"])
def test_an_output_in_a_missing_folder_is_refused(tmp_path, rel):
    with pytest.raises(ValueError, match=r"folder .* does not exist"):
        check_image_path(tmp_path / rel, "output", writable=True)


def test_an_output_under_a_regular_file_is_refused(tmp_path):
    (tmp_path / "file").write_text("x")
    with pytest.raises(ValueError, match=r"output: .*file is not a folder"):
        check_image_path(tmp_path / "file" / "x.png", "output", writable=True)


def test_an_output_in_a_read_only_place_is_refused(tmp_path, monkeypatch):
    """os.access says yes to root for read-only folders (tests run as root), so the
    refusal is shown with a patched os.access."""
    real = os.access
    monkeypatch.setattr(os, "access", lambda p, mode: False if os.fspath(p) == str(tmp_path) else real(p, mode))
    with pytest.raises(ValueError, match=r"output: '.*x\.png' cannot be written"):
        check_image_path(tmp_path / "x.png", "output", writable=True)
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "old.png").write_bytes(b"")
    monkeypatch.setattr(os, "access", lambda p, mode: not os.fspath(p).endswith("old.png"))
    with pytest.raises(ValueError, match=r"old\.png' cannot be written"):
        check_image_path(tmp_path / "sub" / "old.png", "output", writable=True)


def test_writable_outputs_pass(tmp_path):
    assert check_image_path(tmp_path / "x.png", "output", writable=True) == ".png"
    (tmp_path / "y.pfm").write_bytes(b"")
    assert check_image_path(tmp_path / "y.pfm", "output", writable=True) == ".pfm"  # overwriting is fine


@pytest.mark.parametrize("path", ["", b""])
def test_an_empty_output_path_is_refused(path):
    with pytest.raises(ValueError, match=r"output: expected a file name, got an empty path"):
        check_image_path(path, "output")

