"""[render] width/height override the camera's, and the overridden values are still checked."""

import pytest

import raycast_shade as rs
from raycast_shade.scene.scenefile import SceneFileError

TOML = """[camera]
eye = [0, 0, 4]
width = {width}
height = 6
[render]
width = 8
height = 6
[[object]]
shape = "icosphere"
[[light]]
type = "point"
position = [2, 2, 2]
"""


@pytest.mark.parametrize("width", ['"abc"', "true", "0", "-3", "2.5"])
def test_a_wrong_camera_width_is_refused_even_where_render_overrides_it(tmp_path, width):
    path = tmp_path / "scene.toml"
    path.write_text(TOML.format(width=width))
    with pytest.raises(SceneFileError, match=r"camera\.width"):
        rs.render_file(str(path))


def test_the_render_size_wins_over_a_valid_camera_size(tmp_path):
    path = tmp_path / "scene.toml"
    path.write_text(TOML.format(width=100))
    frame = rs.render_file(str(path))
    assert frame.image.shape[:2] == (6, 8)
