"""The packed geometry in bounded memory (issue 41): one model shares its prepared arrays instead of
copying them, the kernels see the same array types, and the values are the concatenation's."""

import numba
import numpy as np

import raycast_shade as rs


def _scene(models):
    return rs.Scene(models, lights=[rs.PointLight((2.0, 3.0, 4.0))], camera=rs.Camera(eye=(0.0, 0.0, 4.0)))


def _kernel_types(geo):
    return {k: numba.typeof(getattr(geo, k)) for k in ("vertices", "normals", "faces", "face_normals", "uvs")}


def test_one_model_shares_its_normals_and_copies_nothing_the_kernels_would_see_differently():
    mesh = rs.shapes.icosphere(2)  # UVs: read-only in the mesh, so copied
    model = rs.Model(mesh, rs.Material())
    geo = _scene([model]).geometry
    prep = model.prepared
    assert geo.normals is prep.normals and geo.face_normals is prep.face_normals  # no copies
    assert geo.local_faces is prep.faces  # read by Python only (the Embree buffers)
    assert np.array_equal(geo.faces, mesh.faces) and not np.shares_memory(geo.faces, mesh.faces)
    assert np.array_equal(geo.uvs, mesh.uvs) and geo.uvs.flags.writeable
    for name, t in _kernel_types(geo).items():  # what every kernel was compiled for: writeable, C order
        assert t.mutable and t.layout == "C", (name, t)


def test_several_models_are_the_plain_concatenation():
    a = rs.shapes.icosphere(1)
    b = rs.Mesh(rs.shapes.torus().vertices, rs.shapes.torus().faces, name="torus")  # no UVs
    models = [rs.Model(a, rs.Material()), rs.Model(b, rs.Material(), pose=np.diag([1.0, 1.0, 1.0, 1.0]))]
    geo = _scene(models).geometry
    pa, pb = models[0].prepared, models[1].prepared
    assert np.array_equal(geo.normals, np.concatenate([pa.normals, pb.normals]))
    assert np.array_equal(geo.face_normals, np.concatenate([pa.face_normals, pb.face_normals]))
    assert np.array_equal(geo.local_faces, np.concatenate([a.faces, b.faces]))
    assert np.array_equal(geo.faces, np.concatenate([a.faces, b.faces + len(a.vertices)]))
    assert np.array_equal(geo.uvs, np.concatenate([a.uvs, np.zeros((len(b.vertices), 2))]))
    assert geo.normals is not pa.normals


def test_a_model_without_uvs_gets_zeros_and_renders_as_before():
    mesh = rs.Mesh(rs.shapes.icosphere(2).vertices, rs.shapes.icosphere(2).faces, name="bare")
    scene = _scene([rs.Model(mesh, rs.Material(kd=0.7, ks=0.3))])
    geo = scene.geometry
    assert geo.uvs.shape == (len(mesh.vertices), 2) and not geo.uvs.any()
    frame = rs.render(scene, "phong", camera=scene.camera.replace(width=64, height=48))
    assert frame.mask.any() and np.isfinite(frame.image).all()
