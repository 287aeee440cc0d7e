"""A hand-made hit buffer in the other byte order (as read from a big-endian file) shades as the native one."""

import numpy as np

import raycast_shade as rs


def _scene():
    return rs.Scene([rs.Model(rs.shapes.icosphere(2), rs.Material(kd=(0.8, 0.3, 0.2), ks=0.4, shininess=20))],
                    lights=[rs.PointLight((2.0, 2.0, 3.0))], camera=rs.Camera(eye=(0, 0, 4), width=24, height=18))


def test_a_big_endian_hit_buffer_shades_bit_for_bit_as_the_native_one():
    scene = _scene()
    hits = rs.cast_camera(scene.geometry, scene.camera)
    fields = ("prim", "geom", "u", "v", "t")
    swapped = rs.HitBuffer(*(getattr(hits, f).astype(getattr(hits, f).dtype.newbyteorder(">")) for f in fields))
    for f in fields:  # the values are kept, only the byte order is the machine's
        assert getattr(swapped, f).dtype.isnative
        np.testing.assert_array_equal(getattr(swapped, f), getattr(hits, f))
    for method in ("flat", "gouraud", "phong"):
        a = rs.shade(scene, scene.camera, swapped, method)
        b = rs.shade(scene, scene.camera, hits, method)
        np.testing.assert_array_equal(np.asarray(getattr(a, "image", a)), np.asarray(getattr(b, "image", b)))
