"""rs.animate_light / rs.animate_orbit: one call, an object the notebook plays (an animated PNG in
_repr_html_), whose frames are exactly the renders of the orbit's scenes."""

from __future__ import annotations

import base64
import io
import re

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.apps.animate import orbit_cameras, orbit_light
from raycast_shade.apps.movie import Animation


def _scene():
    spot = rs.SpotLight(position=(1.0, 3.0, 1.0), direction=(-0.3, -1.0, -0.3), intensity=6.0, exponent=2,
                        inner_angle=25, outer_angle=40)
    return rs.Scene([rs.Model(rs.shapes.icosphere(2), rs.Material(kd=(0.8, 0.3, 0.2), ks=0.5, shininess=30)),
                     rs.Model(rs.shapes.plane(5.0, center=(0.0, -1.0, 0.0), normal="+y"), rs.Material(kd=0.6))],
                    lights=[rs.PointLight((2.0, 2.0, 2.0), intensity=12.0, attenuation="inverse_square"), spot],
                    camera=rs.Camera(eye=(0.0, 1.0, 4.0), target=(0.0, -0.3, 0.0), width=24, height=18),
                    ambient=0.1)


def _played(animation):
    """The frames of the APNG inside the HTML, decoded with Pillow."""
    from PIL import Image

    from IPython.core.formatters import DisplayFormatter

    data, _ = DisplayFormatter().format(animation)
    html = data["text/html"]
    src = re.search(r"src='data:image/png;base64,([^']+)'", html).group(1)
    im = Image.open(io.BytesIO(base64.b64decode(src)))
    frames = []
    for i in range(im.n_frames):
        im.seek(i)
        frames.append(np.asarray(im.convert("RGB")))
    return html, np.stack(frames), im.info.get("loop")


def test_a_moving_light_plays_the_renders_of_orbit_light():
    pytest.importorskip("IPython")
    scene = _scene()
    movie = rs.animate_light(scene, 4, light_index=1, scale=2)
    html, played, loop = _played(movie)
    assert played.shape == (4, 36, 48, 3) and loop == 0
    for i, s in enumerate(orbit_light(scene, 4, light_index=1)):
        expected = rs.render(s, "phong").to_uint8()
        np.testing.assert_array_equal(played[i], np.repeat(np.repeat(expected, 2, 0), 2, 1))
    assert len({p.tobytes() for p in played}) == 4  # the light moves
    assert "width='48'" in html and repr(movie) == "Animation(4 frames of 24x18 at 12 fps)"


def test_three_methods_side_by_side_with_labels_and_an_orbit():
    pytest.importorskip("IPython")
    scene = _scene()
    movie = rs.animate_orbit(scene, 3, shading=("flat", "gouraud", "phong"), scale=1, fps=6)
    html, played, _ = _played(movie)
    assert played.shape == (3, 18, 72, 3)
    assert [m for m in re.findall(r"font-weight:bold'>([^<]+)<", html)] == ["flat", "Gouraud", "Phong"]
    cams = orbit_cameras(scene.camera, 3)
    for i, cam in enumerate(cams):
        for j, m in enumerate(("flat", "gouraud", "phong")):
            np.testing.assert_array_equal(played[i][:, 24 * j:24 * (j + 1)], rs.render(scene, m, camera=cam).to_uint8())
    assert movie.fps == 6.0


def test_default_display_size_is_legible(tmp_path):
    movie = rs.animate_light(_scene(), 2)
    assert movie.scale * 24 >= 480
    assert movie.save(tmp_path / "a.gif") == 2 and (tmp_path / "a.gif").stat().st_size > 0


def test_bad_arguments():
    scene = _scene()
    with pytest.raises(ValueError, match="shading"):
        rs.animate_light(scene, 2, shading="toon")
    with pytest.raises(ValueError, match="shading"):
        rs.animate_light(scene, 2, shading=())
    with pytest.raises(TypeError, match="frames"):
        rs.animate_orbit(scene, 2.5)
    with pytest.raises(ValueError, match="light_index"):
        rs.animate_light(scene, 2, light_index=5)
    with pytest.raises(ValueError, match="camera"):
        rs.animate_orbit(scene.replace(camera=None), 2)
    with pytest.raises(TypeError, match="scene"):
        rs.animate_light("scene.toml")
    with pytest.raises(ValueError, match="frames"):
        Animation(np.zeros((0, 4, 4, 3), np.uint8))
    with pytest.raises(ValueError, match="fps"):
        Animation(np.zeros((1, 4, 4, 3), np.uint8), fps=0)
