"""A texture decoded from sRGB says so in a field, which ``dataclasses.replace`` keeps."""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest

import raycast_shade as rs

_FLAT = np.full((4, 4, 3), 0.5)  # the encoding of a flat normal's neighbour: valid texels either way
_FLAT[..., 2] = 1.0


@pytest.mark.parametrize("change", [dict(wrap="clamp"), dict(filter="bilinear"), dict(tiling=(2.0, 2.0)),
                                    dict(name="renamed"), dict(texels=np.full((2, 2, 3), 0.25))])
def test_replace_keeps_the_srgb_marker(change):
    tex = rs.Texture.from_array(_FLAT)  # srgb=True: colours
    assert tex.decoded_from_srgb
    copy = dataclasses.replace(tex, **change)
    assert copy.decoded_from_srgb
    with pytest.raises(ValueError, match=r"normal_map: texture .* was decoded from sRGB"):
        rs.Material(normal_map=copy)


def test_linear_data_stays_linear_through_replace():
    tex = rs.Texture.from_array(_FLAT, srgb=False)
    assert not tex.decoded_from_srgb
    copy = dataclasses.replace(tex, wrap="clamp")
    assert not copy.decoded_from_srgb
    assert rs.Material(normal_map=copy).normal_map is copy


def test_the_marker_is_a_checked_bool():
    with pytest.raises(TypeError, match=r"texture\.decoded_from_srgb"):
        rs.Texture(_FLAT, decoded_from_srgb="yes")
    assert not rs.Texture(_FLAT).decoded_from_srgb  # made from texels: linear unless said
    with pytest.raises(TypeError, match=r"decoded_from_srgb: from_array sets it"):
        rs.Texture.from_array(_FLAT, decoded_from_srgb=False)


@pytest.mark.parametrize("wraps", [None, (33071, 33071), (33648, 10497), (33071, 10497)])
def test_loaded_gltf_colour_maps_say_srgb_and_data_maps_do_not(tmp_path, wraps):
    """Every loader path that builds a Texture (shared, clamped, mirrored, padded on one axis) keeps
    the marker: the base colour and emission are colours; metallic-roughness and occlusion are data."""
    from tests.scene.test_gltf_material_extensions import _image, _quad_file

    mat = {"name": "quad", "pbrMetallicRoughness": {"baseColorTexture": {"index": 0},
                                                    "metallicRoughnessTexture": {"index": 1}},
           "emissiveTexture": {"index": 0}, "emissiveFactor": [1, 1, 1], "occlusionTexture": {"index": 1}}
    samplers = [{"wrapS": wraps[0], "wrapT": wraps[1]}] if wraps else None
    path = _quad_file(tmp_path / "q.gltf", mat, [_image(0), _image(1)], samplers=samplers)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", rs.DroppedOnLoadWarning)
        (pbr,) = rs.load_models(path, reflectance="pbr")
        (phong,) = rs.load_models(path)
    m = pbr.material
    assert m.kd_map.decoded_from_srgb and m.ka_map.decoded_from_srgb and m.ke_map.decoded_from_srgb
    assert not m.metallic_roughness_map.decoded_from_srgb and not m.ao_map.decoded_from_srgb
    assert phong.material.kd_map.decoded_from_srgb and phong.material.ks_map.decoded_from_srgb
    with pytest.raises(ValueError, match=r"normal_map: texture .* was decoded from sRGB"):
        rs.Material(normal_map=m.kd_map)
