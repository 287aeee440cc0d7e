"""One validator per rule (raycast_shade.common.validate): each rule's closed-form answers, and that the
places which once carried their own copy of it now give the same answers through it."""

from __future__ import annotations

import re

import numpy as np
import pytest

from raycast_shade.common.validate import as_bool, as_count, as_names


@pytest.mark.parametrize("value, want", [(True, True), (False, False), (np.bool_(True), True),
                                         (np.bool_(False), False)])
def test_as_bool_accepts_the_two_flags_and_gives_a_python_bool(value, want):
    got = as_bool(value, "flag")
    assert got is want


@pytest.mark.parametrize("value, kind", [(1, "int"), (0, "int"), ("yes", "str"), (None, "NoneType"),
                                         (1.0, "float"), (np.int64(1), "int64"), (np.array(True), "ndarray")])
def test_as_bool_refuses_everything_else_naming_the_field(value, kind):
    with pytest.raises(TypeError, match=f"^light.shadows: expected True or False, got {kind}$"):
        as_bool(value, "light.shadows")


@pytest.mark.parametrize("value, minimum, want", [(1, 1, 1), (7, 1, 7), (np.int32(3), 1, 3), (0, 0, 0),
                                                  (np.uint64(2**40), 1, 2**40), (np.array(2), 1, 2)])
def test_as_count_accepts_integers_from_the_minimum(value, minimum, want):
    got = as_count(value, "workers", minimum=minimum)
    assert got == want and type(got) is int


@pytest.mark.parametrize("value, minimum", [(0, 1), (-1, 0), (True, 0), (np.bool_(True), 1), (2.0, 1), ("2", 1),
                                            (None, 1), (np.array(True), 1), (np.array(2.0), 1), (np.array([2]), 1),
                                            (np.array(0), 1)])
def test_as_count_refuses_with_a_value_error_naming_the_field(value, minimum):
    with pytest.raises(ValueError, match=rf"^workers: expected an integer >= {minimum}, got {re.escape(repr(value))}$"):
        as_count(value, "workers", minimum=minimum)


def test_as_count_optional_takes_none_and_says_so():
    assert as_count(None, "window", optional=True) is None
    with pytest.raises(ValueError, match=r"^window: expected an integer >= 1 or None, got 0$"):
        as_count(0, "window", optional=True)


_FORMATS = ("npz", "exr", "depth_png")


@pytest.mark.parametrize("value, want", [
    (None, ()), ("", ()), ([], ()),
    ("npz", ("npz",)), ("EXR, npz,", ("exr", "npz")), (["depth_png", "NPZ", "npz"], ("depth_png", "npz")),
    (("exr",), ("exr",)), (iter(["npz"]), ("npz",)),
])
def test_as_names_gives_lower_case_names_in_order_without_repeats(value, want):
    assert as_names(value, "formats", _FORMATS) == want


@pytest.mark.parametrize("value, error, match", [
    (["npz", "tiff"], ValueError, r"^formats: unknown format 'tiff'; expected some of npz, exr, depth_png$"),
    ("npz,jpg", ValueError, r"^formats: unknown format 'jpg'"),
    (5, TypeError, r"^formats: expected a sequence of format names, got int$"),
    (["npz", 5], TypeError, r"^formats: expected format names \(str\), got int$"),
    (np.array(["npz"]), TypeError, r"^formats: expected a sequence of format names, got ndarray$"),
    (np.empty(0), TypeError, r"^formats: expected a sequence of format names, got ndarray$"),
    ({"npz": 1}, TypeError, r"^formats: expected a sequence of format names, got dict$"),
])
def test_as_names_refuses_naming_the_field_and_the_item(value, error, match):
    with pytest.raises(error, match=match):
        as_names(value, "formats", _FORMATS)


def test_as_names_item_word_is_given_or_the_field_less_its_s():
    with pytest.raises(ValueError, match="^buffers: unknown buffer 'x'"):
        as_names("x", "buffers", ("zdepth",))
    with pytest.raises(ValueError, match="^passes: unknown shading pass 'x'"):
        as_names("x", "passes", ("flat",), item="shading pass")


def test_the_former_copies_answer_through_the_shared_rules():
    """Lights, materials, cameras, view files, batch and run options and the scene cache: same messages, one
    rule each."""
    import raycast_shade as rs
    from raycast_shade.apps.batch.cache import SceneCache
    from raycast_shade.apps.batch.options import check_options
    from raycast_shade.apps.batch.run import RunOptions
    from raycast_shade.apps.viewfiles import ViewFiles
    from raycast_shade.output.buffers import check_buffers

    with pytest.raises(TypeError, match="^key.shadows: expected True or False, got int$"):
        rs.PointLight(position=(0, 1, 0), name="key", shadows=1)
    assert rs.PointLight(position=(0, 1, 0), shadows=np.bool_(False)).shadows is False
    with pytest.raises(TypeError, match=r"^m\.double_sided: expected True or False, got str$"):
        rs.Material(name="m", double_sided="yes")
    with pytest.raises(TypeError, match="^fisheye: expected True or False, got NoneType$"):
        rs.Camera.from_opencv(np.diag([100.0, 100.0, 1.0]), np.eye(3), np.zeros(3), 64, 48,
                              dist=[0.1, 0, 0, 0], fisheye=None)
    with pytest.raises(TypeError, match="^float_image: expected True or False, got int$"):
        ViewFiles(float_image=1)
    assert ViewFiles(formats="NPZ,npz", float_image=np.bool_(True)).formats == ("npz",)
    with pytest.raises(ValueError, match="^formats: unknown format 'tiff'"):
        ViewFiles(formats=["npz", "tiff"])
    with pytest.raises(TypeError, match="^resume: expected True or False, got NoneType$"):
        check_options("phong", {}, None, None)
    with pytest.raises(ValueError, match="^retries: expected an integer >= 0, got -1$"):
        RunOptions(retries=-1)
    with pytest.raises(ValueError, match="^per_task: expected an integer >= 1 or None, got True$"):
        RunOptions(per_task=True)
    with pytest.raises(TypeError, match="^progress: expected True or False, got int$"):
        RunOptions(progress=1)
    with pytest.raises(ValueError, match="^size: expected an integer >= 1, got 0$"):
        SceneCache(0)
    assert check_buffers("id,zdepth") == ("model_id", "triangle_id", "zdepth")
    with pytest.raises(ValueError, match="^buffers: unknown buffer 'nope'"):
        check_buffers(["zdepth", "nope"])
