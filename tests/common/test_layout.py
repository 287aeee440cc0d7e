"""The packed rows (raycast_shade.common.layout): every packer writes exactly
the documented number of slots, each named slot holds what its name says,
the slots of a row tile it, and the docstrings state the same sizes."""

from __future__ import annotations

import re

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.common import layout as lay
from raycast_shade.scene.scene import SceneGeometry
from raycast_shade.shading.inputs import kernel_inputs
from raycast_shade.visibility.rays import camera_frame

# Slot -> width, per row; everything not listed is one float wide.
ROWS = {
    "CAM": ({"CAM_EYE": 3, "CAM_RIGHT": 3, "CAM_UP": 3, "CAM_FORWARD": 3, "CAM_ORTHO": 1, "CAM_WIDTH": 1,
             "CAM_HEIGHT": 1}, lay.CAM_SIZE),
    "LIGHT": ({"LIGHT_KIND": 1, "LIGHT_VEC": 3, "LIGHT_RADIANCE": 3, "LIGHT_ATT": 1, "LIGHT_K": 1,
               "LIGHT_SHADOWS": 1, "LIGHT_AXIS": 3, "LIGHT_COS_INNER": 1, "LIGHT_COS_OUTER": 1,
               "LIGHT_EXPONENT": 1, "LIGHT_EDGE_U": 3, "LIGHT_EDGE_V": 3, "LIGHT_SHAPE": 1, "LIGHT_SAMPLES": 1},
              lay.LIGHT_SIZE),
    "MAT": ({"MAT_KA": 3, "MAT_KD": 3, "MAT_KS": 3, "MAT_SHININESS": 1, "MAT_MODEL": 1, "MAT_REFLECTIVITY": 1,
             "MAT_KA_COLORS": 1, "MAT_KE": 3, "MAT_AO_STRENGTH": 1, "MAT_METALLIC": 1, "MAT_ROUGHNESS": 1},
            lay.MAT_SIZE),
    "BUMP": ({"BUMP_OFFSET": 1, "BUMP_ROWS": 1, "BUMP_COLS": 1, "BUMP_CLAMP": 1, "BUMP_TILE_U": 1,
              "BUMP_TILE_V": 1, "BUMP_SCALE": 1}, lay.BUMP_SIZE),
    "TEX": ({"TEX_OFFSET": 1, "TEX_WIDTH": 1, "TEX_HEIGHT": 1, "TEX_LEVELS": 1, "TEX_CLAMP": 1, "TEX_TILE_U": 1,
             "TEX_TILE_V": 1, "TEX_MIPMAP": 1}, lay.TEX_SIZE),
}


def _scene(lights, models=None, camera=None):
    models = models or [rs.Model(rs.shapes.plane(size=2, center=(5.0, -1.0, 2.0)), rs.Material(kd=0.5))]
    return rs.Scene(models, lights=lights, camera=camera or rs.Camera(eye=(5, -1, 6), target=(5, -1, 2),
                                                                       width=8, height=6))


@pytest.mark.parametrize("row", sorted(ROWS))
def test_the_slots_of_a_row_tile_it(row):
    """Every slot constant of a row is listed, and the slots cover 0 .. SIZE-1 once each
    (the camera row's last slot is the documented unused padding)."""
    widths, size = ROWS[row]
    values = {"LIGHT_POINT", "LIGHT_DIRECTIONAL", "LIGHT_SPOT", "LIGHT_AREA", "LIGHT_KINDS"}  # LIGHT_KIND values
    aliases = {"MAT_BLINN": "MAT_MODEL"}  # the model slot under its first name
    for alias, name in aliases.items():
        assert getattr(lay, alias) == getattr(lay, name)
    declared = {n for n in lay.__all__ if n.startswith(row + "_") and n != f"{row}_SIZE"} - values - set(aliases)
    assert declared == set(widths)
    covered = sorted(i for name, w in widths.items() for i in range(getattr(lay, name), getattr(lay, name) + w))
    unused = [size - 1] if row == "CAM" else []
    assert covered + unused == list(range(size))


def test_layout_docstring_states_the_constants():
    doc = lay.__doc__
    stated = dict(re.findall(r"\(([A-Z_]+),\) = \((\d+),\)", doc))
    stated.update((name, n) for name, n in re.findall(r"\([A-Z], ([A-Z_]+)\) = \([A-Z], (\d+)\)", doc))
    assert stated == {"CAM_SIZE": "16", "LIGHT_SIZE": "24", "MAT_SIZE": "19", "BUMP_SIZE": "7", "TEX_SIZE": "8"}
    for name, n in stated.items():
        assert getattr(lay, name) == int(n), name


@pytest.mark.parametrize("obj", [camera_frame, rs.Material.packed, rs.HeightMap.packed_info, rs.Scene.packed_lights,
                                 SceneGeometry, rs.Texture.packed_info])
def test_packer_docstrings_state_the_constants(obj):
    """Where a docstring writes ``NAME = n`` for a size, n is the constant's value."""
    pairs = re.findall(r"\(([^()]*)\) = \(([^()]*)\)", obj.__doc__)
    assert pairs, "no size stated"
    for left, right in pairs:
        for a, b in zip(left.split(","), right.split(",")):
            a, b = a.strip(), b.strip()
            if a in lay.__all__:
                assert getattr(lay, a) == int(b), f"{a} = {b}"
            else:
                assert a == b


def test_camera_row():
    """fov 90: the half height is tan 45 = 1, the half width the aspect 4/3."""
    cam = rs.Camera(eye=(0, 0, 4), target=(0, 0, 0), width=64, height=48, fov=90)
    origin = np.array([1.0, 2.0, 3.0])
    row = camera_frame(cam, origin)
    assert row.shape == (lay.CAM_SIZE,) and row.dtype == np.float64
    np.testing.assert_allclose(row[lay.CAM_EYE:lay.CAM_EYE + 3], [-1, -2, 1])
    np.testing.assert_allclose(row[lay.CAM_RIGHT:lay.CAM_RIGHT + 3], [4 / 3, 0, 0], atol=1e-15)
    np.testing.assert_allclose(row[lay.CAM_UP:lay.CAM_UP + 3], [0, 1, 0], atol=1e-15)
    np.testing.assert_allclose(row[lay.CAM_FORWARD:lay.CAM_FORWARD + 3], [0, 0, -1], atol=1e-15)
    assert row[lay.CAM_ORTHO] == 0.0
    assert row[lay.CAM_WIDTH] == cam.width == 64 and row[lay.CAM_HEIGHT] == cam.height == 48
    assert row[lay.CAM_SIZE - 1] == 0.0


def test_orthographic_camera_row():
    cam = rs.Camera(eye=(0, 0, 4), width=30, height=20, projection="orthographic", ortho_height=2.6)
    row = camera_frame(cam)
    assert row[lay.CAM_ORTHO] == 1.0
    np.testing.assert_allclose(row[lay.CAM_UP:lay.CAM_UP + 3], [0, 1.3, 0], atol=1e-15)
    np.testing.assert_allclose(row[lay.CAM_RIGHT:lay.CAM_RIGHT + 3], [1.95, 0, 0], atol=1e-15)


def test_material_row():
    m = rs.Material(ka=(0.1, 0.2, 0.3), kd=(0.4, 0.5, 0.6), ks=(0.7, 0.8, 0.9), shininess=17, specular="blinn",
                    reflectivity=0.25)
    row = m.packed()
    assert row.shape == (lay.MAT_SIZE,) and row.dtype == np.float64
    np.testing.assert_array_equal(row[lay.MAT_KA:lay.MAT_KA + 3], m.ka)
    np.testing.assert_array_equal(row[lay.MAT_KD:lay.MAT_KD + 3], m.kd)
    np.testing.assert_array_equal(row[lay.MAT_KS:lay.MAT_KS + 3], m.ks)
    assert row[lay.MAT_SHININESS] == m.shininess == 17
    assert row[lay.MAT_BLINN] == 1.0 and rs.Material(specular="phong").packed()[lay.MAT_BLINN] == 0.0
    assert row[lay.MAT_REFLECTIVITY] == m.reflectivity == 0.25


def test_heightmap_row():
    hm = rs.HeightMap(np.zeros((3, 5)), scale=-0.5, wrap="clamp", tiling=(2.0, 3.0))
    row = hm.packed_info(7)
    assert row.shape == (lay.BUMP_SIZE,) and row.dtype == np.float64
    assert row[lay.BUMP_OFFSET] == 7 and row[lay.BUMP_ROWS] == 3 and row[lay.BUMP_COLS] == 5
    assert row[lay.BUMP_CLAMP] == 1.0 and rs.HeightMap(np.zeros((2, 2))).packed_info(0)[lay.BUMP_CLAMP] == 0.0
    assert row[lay.BUMP_TILE_U] == 2.0 and row[lay.BUMP_TILE_V] == 3.0
    assert row[lay.BUMP_SCALE] == -0.5


def test_texture_row():
    """Levels stored one after another from the offset: 5 x 3 -> 2 x 1 -> 1 x 1."""
    tex = rs.Texture(np.ones((3, 5, 3)), wrap="clamp", tiling=(2.0, 4.0))
    row = tex.packed_info(9)
    assert row.shape == (lay.TEX_SIZE,) and row.dtype == np.float64
    assert row[lay.TEX_OFFSET] == 9 and row[lay.TEX_WIDTH] == 5 and row[lay.TEX_HEIGHT] == 3
    assert row[lay.TEX_LEVELS] == 3 and tex.size == 3 * (15 + 2 + 1) == tex.packed_texels().size
    assert row[lay.TEX_CLAMP] == 1.0 and row[lay.TEX_TILE_U] == 2.0 and row[lay.TEX_TILE_V] == 4.0
    assert row[lay.TEX_MIPMAP] == 1.0
    flat = rs.Texture(np.ones((3, 5, 3)), filter="bilinear").packed_info(0)
    assert flat[lay.TEX_MIPMAP] == 0.0 and flat[lay.TEX_LEVELS] == 1 and flat[lay.TEX_CLAMP] == 0.0


def test_texture_rows_in_the_scene():
    """A map shared by two slots is packed once; each model's slots name its rows."""
    tex = rs.Texture.checker(2, 2)
    other = rs.Texture(np.ones((2, 2, 3)))
    models = [rs.Model(rs.shapes.plane(), rs.Material(kd_map=tex, ks_map=tex)),
              rs.Model(rs.shapes.plane(center=(3, 0, 0)), rs.Material(ka_map=other, ke_map=tex)),
              rs.Model(rs.shapes.plane(center=(6, 0, 0)))]
    geo = _scene([], models=models).geometry
    assert geo.tex_info.shape == (2, lay.TEX_SIZE)
    assert geo.tex_index.shape == (3, lay.TEXMAP_COUNT)
    assert geo.tex_index.tolist() == [[-1, 0, 0, -1, -1], [1, -1, -1, 0, -1], [-1, -1, -1, -1, -1]]
    assert geo.tex_index[0, lay.TEXMAP_KD] == 0 and geo.tex_index[1, lay.TEXMAP_KA] == 1
    assert geo.tex_index[1, lay.TEXMAP_KE] == 0
    assert geo.tex_info[1, lay.TEX_OFFSET] == tex.size == geo.tex_info[0, lay.TEX_OFFSET] + tex.size
    assert geo.tex_texels.size == tex.size + other.size and geo.textured
    assert not _scene([]).geometry.textured


def test_light_rows():
    """A point light's position is re-centred like the geometry (the plane's centre is the
    box centre); a directional light's vector points towards the light."""
    point = rs.PointLight((2, 3, 4), intensity=2.0, color=(1.0, 0.5, 0.25), attenuation="heuristic", k=0.5,
                          shadows=True)
    sun = rs.DirectionalLight((0, -2, 0), intensity=0.3)
    scene = _scene([point, sun])
    np.testing.assert_allclose(scene.geometry.origin, [5, -1, 2])
    rows = scene.packed_lights()
    assert rows.shape == (2, lay.LIGHT_SIZE) and rows.dtype == np.float64
    assert rows[0, lay.LIGHT_KIND] == lay.LIGHT_POINT and rows[1, lay.LIGHT_KIND] == lay.LIGHT_DIRECTIONAL
    np.testing.assert_allclose(rows[0, lay.LIGHT_VEC:lay.LIGHT_VEC + 3], [2 - 5, 3 + 1, 4 - 2])
    np.testing.assert_array_equal(rows[1, lay.LIGHT_VEC:lay.LIGHT_VEC + 3], [0, 1, 0])
    np.testing.assert_array_equal(rows[0, lay.LIGHT_RADIANCE:lay.LIGHT_RADIANCE + 3], [2.0, 1.0, 0.5])
    np.testing.assert_allclose(rows[1, lay.LIGHT_RADIANCE:lay.LIGHT_RADIANCE + 3], [0.3, 0.3, 0.3])
    assert rows[0, lay.LIGHT_ATT] == lay.ATT_HEURISTIC == lay.ATT_CODE["heuristic"]
    assert rows[1, lay.LIGHT_ATT] == lay.ATT_NONE
    assert rows[0, lay.LIGHT_K] == 0.5
    assert rows[0, lay.LIGHT_SHADOWS] == 1.0 and rows[1, lay.LIGHT_SHADOWS] == 0.0
    assert _scene([]).packed_lights().shape == (0, lay.LIGHT_SIZE)
    assert not rows[:, lay.LIGHT_AXIS:lay.LIGHT_SAMPLES].any()  # the spot and area slots stay zero for other lights
    assert (rows[:, lay.LIGHT_SAMPLES] == 1.0).all()  # one sample each


def test_spot_light_row():
    """A spot is a point light (position re-centred, attenuation, shadows) plus its cone:
    the unit axis, the cosines of both half-angles and Warn's exponent."""
    spot = rs.SpotLight((2, 3, 4), (0, -3, 0), intensity=2.0, attenuation="inverse_square", exponent=8.0,
                        inner_angle=60.0, outer_angle=90.0, shadows=True)
    rows = _scene([spot]).packed_lights()
    assert rows[0, lay.LIGHT_KIND] == lay.LIGHT_SPOT
    np.testing.assert_allclose(rows[0, lay.LIGHT_VEC:lay.LIGHT_VEC + 3], [2 - 5, 3 + 1, 4 - 2])
    assert rows[0, lay.LIGHT_ATT] == lay.ATT_INVERSE_SQUARE and rows[0, lay.LIGHT_SHADOWS] == 1.0
    np.testing.assert_array_equal(rows[0, lay.LIGHT_AXIS:lay.LIGHT_AXIS + 3], [0, -1, 0])
    assert rows[0, lay.LIGHT_COS_INNER] == pytest.approx(0.5, abs=1e-15)
    assert rows[0, lay.LIGHT_COS_OUTER] == pytest.approx(0.0, abs=1e-15)
    assert rows[0, lay.LIGHT_EXPONENT] == 8.0
    k = kernel_inputs(_scene([spot]), _scene([spot]).camera)
    assert k["att_on"]  # a spot's attenuation switches the attenuation flag on, as a point light's


def test_attenuation_codes_are_the_named_ones():
    assert lay.ATT_CODE == {"none": lay.ATT_NONE, "inverse_square": lay.ATT_INVERSE_SQUARE,
                            "heuristic": lay.ATT_HEURISTIC}


def test_scene_geometry_rows():
    bumpy = rs.Material(kd=0.5, bump=rs.HeightMap(np.zeros((4, 4))))
    plain = _scene([rs.PointLight((0, 0, 5))])
    both = _scene([rs.PointLight((0, 0, 5))], models=[rs.Model(rs.shapes.icosphere(1), bumpy),
                                                       rs.Model(rs.shapes.icosphere(1, center=(3, 0, 0)),
                                                                rs.Material(reflectivity=0.5))])
    assert plain.geometry.materials.shape == (1, lay.MAT_SIZE)
    assert plain.geometry.bump_info.shape == (1, lay.BUMP_SIZE)  # the placeholder row
    assert both.geometry.materials.shape == (2, lay.MAT_SIZE)
    assert both.geometry.bump_info.shape == (1, lay.BUMP_SIZE)
    assert both.geometry.reflective and not plain.geometry.reflective


def test_kernel_inputs_use_the_rows():
    """The packed arguments have the documented widths, and the frame's flags read the named
    slots: ks switches the specular flag on, a point light's attenuation the other."""
    dull = _scene([rs.PointLight((0, 0, 5)), rs.DirectionalLight((0, 0, -1))])
    k = kernel_inputs(dull, dull.camera)
    assert k["cam"].shape == (lay.CAM_SIZE,)
    assert k["L"].lights.shape == (2, lay.LIGHT_SIZE)
    assert k["materials"].shape == (1, lay.MAT_SIZE)
    assert k["B"].bump_info.shape[1] == lay.BUMP_SIZE
    assert (k["spec_on"], k["att_on"]) == (False, False)
    shiny = dull.replace(models=[rs.Model(dull.models[0].mesh, rs.Material(ks=0.5))],
                         lights=[rs.PointLight((0, 0, 5), attenuation="inverse_square")])
    k = kernel_inputs(shiny, shiny.camera)
    assert (k["spec_on"], k["att_on"]) == (True, True)
