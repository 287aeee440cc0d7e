"""The input contract of ``render``'s own arguments: bad ones refused before anything
is packed, NumPy scalars taken (issue 17, classes 4 and 6; the scene's side:
``tests/scene/test_input_contract.py``).
"""

from __future__ import annotations

import numpy as np
import pytest

import raycast_shade as rs

from tests.conftest import small_scene


# =====================================================================================================
# 4. Silently accepted: render's own arguments
# =====================================================================================================
@pytest.mark.parametrize("shading", ["flat", "gouraud", "phong", "auto"])
@pytest.mark.parametrize("tolerance, error, match", [
    (np.nan, ValueError, r"tolerance: must be finite"),
    (np.inf, ValueError, r"tolerance: must be finite"),
    (-0.01, ValueError, r"tolerance: must be > 0"),
    (0.0, ValueError, r"tolerance: must be > 0"),
    ("0.01", ValueError, r"tolerance: expected a number, got str"),  # ValueError: as choose_methods always raised
    (True, ValueError, r"tolerance: expected a number, got bool"),
    (None, ValueError, r"tolerance: expected a number"),
])
def test_render_checks_the_tolerance_in_every_mode(shading, tolerance, error, match):
    scene = small_scene()
    with pytest.raises(error, match=match):
        rs.render(scene, shading, tolerance=tolerance)
    assert not scene.has_geometry  # before anything was packed


@pytest.mark.parametrize("max_depth, error", [(-1, ValueError), (2.0, TypeError), (True, TypeError),
                                              ("2", TypeError), (np.int64(-3), ValueError)])
def test_render_checks_max_depth(max_depth, error):
    scene = small_scene()
    with pytest.raises(error, match="max_depth"):
        rs.render(scene, max_depth=max_depth)
    assert not scene.has_geometry



# =====================================================================================================
# 6. Refused though valid: NumPy scalars for render's arguments
# =====================================================================================================
@pytest.mark.parametrize("kwargs", [
    dict(max_depth=np.int64(2)), dict(max_depth=np.int32(0)), dict(max_depth=np.uint8(3)), dict(max_depth=np.array(1)),
    dict(tolerance=np.float32(0.01)), dict(tolerance=np.float64(0.5)), dict(tolerance=np.array(0.02)),
    dict(tolerance=1), dict(shading="auto", tolerance=np.float32(0.01)), dict(shading="auto", tolerance=np.int64(1)),
])
def test_render_takes_numpy_scalars(kwargs):
    assert rs.render(small_scene(), **kwargs).image.shape == (6, 8, 3)

