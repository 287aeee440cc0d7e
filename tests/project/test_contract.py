"""One input contract for every public function (issue 23, item 6), walked generically.

Every callable of ``raycast_shade.__all__`` (and of the public modules it exports: ``shapes``,
``bump``, ``figures``, ``overlays``; and every public class's alternative constructors) is called
once per argument and per generic bad value of :data:`BAD` (None, NaN, inf, -1, 0, 1e308, "abc",
numeric strings, True, an empty array, a wrong shape), the other arguments kept at a small valid
baseline (:func:`baselines`). The contract:

- a ``ValueError`` or ``TypeError`` whose message names the argument (or, for a file path,
  an ``OSError`` naming the file), raised before any work (no kernel inputs packed, no Embree
  BVH built or fetched: :func:`_work_probe`), or
- correct work, where the value is legal: the explicit, reviewed :data:`LEGAL` list says why.

Anything else (a value silently accepted, another exception type, a message that does not name
the argument) fails. A new public function fails :func:`test_every_public_callable_has_a_baseline`
until it has a baseline, so it is covered by default. The good unusual inputs are checked too:
NumPy scalars where a number is meant, ``(3, 1)`` and ``(1, 3)`` arrays where a 3-vector is meant.
The command line: every option of every subcommand, given generic bad strings, exits 2 with one
line, never a traceback.

``python -m docs.figures --only contract`` writes the functions x bad values table of this
walk to docs/contract.md.
"""

from __future__ import annotations

import argparse
import contextlib
import inspect
import io
import math
import os
import types
import warnings

import numpy as np
import pytest

import raycast_shade as rs

# -- the generic bad values -----------------------------------------------------------------------------------

BAD = {
    "None": lambda: None,
    "nan": lambda: math.nan,
    "inf": lambda: math.inf,
    "-1": lambda: -1,
    "0": lambda: 0,
    "1e308": lambda: 1e308,
    "'abc'": lambda: "abc",
    "['1','2','3']": lambda: ["1", "2", "3"],  # numeric strings: np.array(..., float) converts them silently
    "True": lambda: True,
    "empty": lambda: np.empty(0),
    "shape": lambda: np.zeros((2, 2)),
}

OK, ERROR, ACCEPTED, WRONG_TYPE, UNNAMED = "ok", "error", "accepted", "wrong type", "unnamed"


def _mesh():
    return rs.shapes.icosphere(1)


def _scene(w=16, h=12):
    return rs.Scene([rs.Model(_mesh(), rs.Material(kd=0.6, ks=0.3))], lights=[rs.PointLight((2.0, 3.0, 4.0))],
                    camera=rs.Camera(eye=(0.0, 0.0, 4.0), width=w, height=h))


def _trimesh_box():
    import trimesh

    return trimesh.creation.box()


def baselines(tmp):
    """``{qualified name: (callable, {argument: valid value})}``: the arguments varied, each valid.

    ``tmp`` is a folder for the files some functions read or write.
    """
    scene = _scene()
    cam = scene.camera
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        frame = rs.render(scene, "phong")
        term_frame = rs.render(scene, "phong", terms=True)
    hits = frame.hits
    obj = tmp / "tri.obj"
    obj.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    png = tmp / "img.png"
    from PIL import Image

    Image.fromarray(np.full((4, 4, 3), 128, np.uint8)).save(png)
    pfm = tmp / "img.pfm"
    rs.write_pfm(str(pfm), np.zeros((2, 3, 3), np.float32))
    toml = tmp / "scene.toml"
    toml.write_text('[camera]\neye = [0.0, 0.0, 4.0]\nwidth = 16\nheight = 12\n\n[[object]]\nshape = "icosphere"\n'
                    'subdivisions = 1\n\n[[light]]\ntype = "point"\nposition = [2.0, 3.0, 4.0]\n')
    verts = _mesh().vertices
    mesh = _mesh()
    image = np.full((4, 5, 3), 0.5, np.float32)
    # The vision files, labels and exports: one frame's buffers, written once so the readers have files.
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        vision = rs.render(scene, "phong", buffers=("zdepth", "model_id"))
    depth, model_id = vision.buffers["zdepth"], vision.buffers["model_id"]
    bufs = {"zdepth": depth}
    image4 = np.zeros(depth.shape + (3,), np.float32)
    npz, exr, dpng = tmp / "r.npz", tmp / "r.exr", tmp / "r.png"
    rs.save_npz(str(npz), bufs)
    rs.write_exr(str(exr), bufs)
    rs.write_depth_png(str(dpng), depth)
    cam2 = rs.Camera(eye=(0.3, 0.0, 4.0), target=(0.0, 0.0, 0.0), width=cam.width, height=cam.height)
    coco_views = [dict(file_name="a.png", width=cam.width, height=cam.height,
                       objects=rs.view_objects(model_id, cam, rle=True))]
    table = {
        "Camera": (rs.Camera, dict(eye=(0.0, 0.0, 4.0), target=(0.0, 0.0, 0.0), up=(0.0, 1.0, 0.0), fov=45.0,
                                   width=16, height=12, projection="perspective", ortho_height=2.0, fx=20.0,
                                   fy=20.0, cx=8.0, cy=6.0)),
        "DirectionalLight": (rs.DirectionalLight, dict(direction=(0.0, -1.0, -1.0), intensity=1.0, color=1.0,
                                                       shadows=False, name="sun")),
        "PointLight": (rs.PointLight, dict(position=(2.0, 3.0, 4.0), intensity=1.0, color=1.0, attenuation="none",
                                           k=1.0, shadows=False, name="lamp")),
        "SpotLight": (rs.SpotLight, dict(position=(0.0, 3.0, 0.0), direction=(0.0, -1.0, 0.0), intensity=1.0,
                                         color=1.0, attenuation="none", k=1.0, shadows=False, exponent=1.0,
                                         inner_angle=20.0, outer_angle=30.0, name="spot")),
        "AreaLight": (rs.AreaLight, dict(position=(0.0, 3.0, 0.0), u=(1.0, 0.0, 0.0), v=(0.0, 0.0, 0.5),
                                         shape="rectangle", samples=4, intensity=1.0, color=1.0, attenuation="none",
                                         k=1.0, shadows=False, name="panel")),
        "AreaLight.disc": (rs.AreaLight.disc, dict(position=(0.0, 3.0, 0.0), normal=(0.0, -1.0, 0.0), radius=0.5)),
        "HeightMap": (rs.HeightMap, dict(heights=np.zeros((4, 4)), scale=0.02, wrap="repeat", tiling=(1.0, 1.0))),
        "Texture": (rs.Texture, dict(texels=np.full((2, 2, 3), 0.5), wrap="repeat", filter="mipmap",
                                     tiling=(1.0, 1.0), name="t")),
        "Material": (rs.Material, dict(kd=0.5, ka=1.0, ks=0.2, shininess=32.0, specular="phong", reflectivity=0.0,
                                       name="m")),
        "Mesh": (rs.Mesh, dict(vertices=mesh.vertices, faces=mesh.faces, normals=mesh.normals, uvs=mesh.uvs,
                               weighting="angle", crease_angle=None, name="mesh")),
        "Model": (rs.Model, dict(mesh=mesh, material=rs.Material())),
        "Scene": (rs.Scene, dict(models=scene.models, lights=scene.lights, camera=cam, ambient=0.1,
                                 background=0.0)),
        "load_models": (rs.load_models, dict(path=str(obj))),
        "cast_camera": (rs.cast_camera, dict(geometry=scene.geometry, camera=cam)),
        "cast_rays": (rs.cast_rays, dict(geometry=scene.geometry, origins=np.zeros((2, 3)),
                                         directions=np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]]), tnear=0.0,
                                         tfar=10.0)),
        "read_pfm": (rs.read_pfm, dict(path=str(pfm))),
        "write_pfm": (rs.write_pfm, dict(path=str(tmp / "out.pfm"), image=image)),
        "render": (rs.render, dict(scene=scene, shading="phong", camera=cam, backend="raycast",
                                   interpolation="perspective", max_depth=3, tolerance=0.01, samples=1)),
        "render_file": (rs.render_file, dict(path=str(toml))),
        "grad": (rs.grad, dict(scene=scene, dL_dimage=np.ones((cam.height, cam.width, 3)), wrt=("kd",),
                               shading="phong", frame=frame, edges=False, edge_density=4.0, seed=0, samples=1)),
        "fit": (rs.fit, dict(scene=scene, target=np.full((cam.height, cam.width, 3), 0.2), params=("kd",), loss="l2",
                             shading="phong", max_iter=1, progress=None, keep_images=False, samples=1)),
        "choose_methods": (rs.choose_methods, dict(scene=scene, camera=cam, tolerance=0.01, max_pixels=2.0)),
        "shade": (rs.shade, dict(scene=scene, camera=cam, hits=hits, shading="phong")),
        "shading_normals": (rs.shading_normals, dict(scene=scene, camera=cam, hits=hits, shading="phong")),
        "to_uint8": (rs.to_uint8, dict(image=image, exposure=1.0, tonemap="clamp", gamma="srgb")),
        "winding_conflicts": (rs.winding_conflicts, dict(vertices=mesh.vertices, faces=mesh.faces)),
        "explain": (rs.explain, dict(frame=frame, x=3, y=4)),
        "save_npz": (rs.save_npz, dict(path=str(tmp / "b.npz"), buffers=bufs, image=image4, camera=cam,
                                       compressed=False)),
        "load_npz": (rs.load_npz, dict(path=str(npz))),
        "write_exr": (rs.write_exr, dict(path=str(tmp / "b.exr"), buffers=bufs, image=image4, compression="none",
                                         threads=1)),
        "read_exr": (rs.read_exr, dict(path=str(exr))),
        "write_depth_png": (rs.write_depth_png, dict(path=str(tmp / "d.png"), depth=depth, scale=1000.0)),
        "read_depth_png": (rs.read_depth_png, dict(path=str(dpng), scale=1000.0)),
        "optical_flow": (rs.optical_flow, dict(scene=scene, camera=cam, camera_b=cam2)),
        "move_model": (rs.move_model, dict(scene=scene, index=0, matrix=np.eye(4))),
        "keyframes": (rs.keyframes, dict(views=[0, 2], poses=np.tile(np.eye(4), (2, 1, 1)), n_views=3)),
        "orbit_poses": (rs.orbit_poses, dict(n_views=3, axis=(0.0, 1.0, 0.0), degrees=90.0, center=(0.0, 0.0, 0.0),
                                             start=np.eye(4))),
        "write_flo": (rs.write_flo, dict(path=str(tmp / "f.flo"), flow=np.zeros((3, 4, 2)), valid=None)),
        "read_flo": (rs.read_flo, dict(path=rs.write_flo(str(tmp / "r.flo"), np.ones((3, 4, 2))))),
        "write_flow_png": (rs.write_flow_png, dict(path=str(tmp / "f.png"), flow=np.zeros((3, 4, 2)), valid=None)),
        "read_flow_png": (rs.read_flow_png, dict(path=rs.write_flow_png(str(tmp / "r_flow.png"), np.ones((3, 4, 2))))),
        "flow_colors": (rs.flow_colors, dict(flow=np.ones((3, 4, 2)), valid=None, max_flow=2.0, background=(0, 0, 0))),
        "semantic_classes": (rs.semantic_classes, dict(scene=scene)),
        "object_table": (rs.object_table, dict(scene=scene)),
        "view_objects": (rs.view_objects, dict(model_id=model_id, camera=cam, rle=True)),
        "coco_instances": (rs.coco_instances, dict(scene=scene, views=coco_views)),
        "write_coco": (rs.write_coco, dict(path=str(tmp / "coco.json"), scene=scene, views=coco_views)),
        "rle_encode": (rs.rle_encode, dict(mask=model_id >= 0)),
        "rle_decode": (rs.rle_decode, dict(rle=rs.rle_encode(model_id >= 0))),
        "nerfstudio_transforms": (rs.nerfstudio_transforms, dict(cameras=[cam, cam2], file_paths=["a.png", "b.png"])),
        "write_transforms": (rs.write_transforms, dict(path=str(tmp / "transforms.json"), cameras=[cam, cam2],
                                                       file_paths=["a.png", "b.png"])),
        "write_colmap": (rs.write_colmap, dict(folder=str(tmp / "colmap"), cameras=[cam, cam2], names=["a.png", "b.png"])),
        "figures.terms": (rs.figures.terms, dict(items=term_frame.terms, columns=2, panel_width=3.0, vmax=1.0)),
        "warmup": (rs.warmup, dict(progress=False)),
        "animate_light": (rs.animate_light, dict(scene=scene, frames=2, shading="phong", light_index=0,
                                                 degrees=90.0, fps=12.0, scale=1)),
        "animate_orbit": (rs.animate_orbit, dict(scene=scene, frames=2, shading="phong", degrees=90.0, fps=12.0,
                                                 scale=1)),
        "diagnose": (rs.diagnose, dict(image=rs.to_uint8(frame.image), scene=scene, method="phong", camera=cam,
                                       encoding="srgb", tolerance=1.0)),
        "shapes.icosphere": (rs.shapes.icosphere, dict(subdivisions=1, radius=1.0, center=(0.0, 0.0, 0.0))),
        "shapes.uv_sphere": (rs.shapes.uv_sphere, dict(rings=4, segments=6, radius=1.0, center=(0.0, 0.0, 0.0))),
        "shapes.torus": (rs.shapes.torus, dict(major_radius=1.0, minor_radius=0.35, major_segments=8,
                                               minor_segments=6, center=(0.0, 0.0, 0.0))),
        "shapes.plane": (rs.shapes.plane, dict(size=2.0, subdivisions=1, center=(0.0, 0.0, 0.0), normal="+z")),
        "shapes.cube": (rs.shapes.cube, dict(size=1.0, center=(0.0, 0.0, 0.0), crease_angle=30.0)),
        "shapes.cylinder": (rs.shapes.cylinder, dict(radius=0.5, height=1.0, segments=8, center=(0.0, 0.0, 0.0),
                                                     crease_angle=60.0)),
        "shapes.make": (rs.shapes.make, dict(shape="icosphere")),
        "bump.spherical_uvs": (rs.bump.spherical_uvs, dict(vertices=verts, center=(0.0, 0.0, 0.0))),
        "bump.cylindrical_uvs": (rs.bump.cylindrical_uvs, dict(vertices=verts, axis=1, height=2.0)),
        "bump.planar_uvs": (rs.bump.planar_uvs, dict(vertices=verts, axis=2)),
        "bump.tangent_frames": (rs.bump.tangent_frames, dict(vertices=mesh.vertices, faces=mesh.faces,
                                                             uvs=mesh.uvs, face_normals=mesh.prepared.face_normals)),
        "overlays.distances": (rs.overlays.distances, dict(frame=frame)),
        "overlays.overlay": (rs.overlays.overlay, dict(frame=frame, width=1.0, color=(1.0, 1.0, 1.0), radius=2.0,
                                                       length=0.2)),
        "overlays.normal_glyphs": (rs.overlays.normal_glyphs, dict(frame=frame, length=0.2, width=1.0)),
        "figures.montage": (rs.figures.montage, dict(frames_or_images=[image, image], labels=["a", "b"], columns=2,
                                                     panel_width=4.0)),
        "figures.difference": (rs.figures.difference, dict(a=image, b=image, title="d", width=6.0)),
        "figures.profile": (rs.figures.profile, dict(frame=frame, row=0, title="p")),
        "explore": (rs.explore, dict(scene=scene, camera=cam, model=0, light=0, max_depth=3)),
        "Camera.from_opencv": (rs.Camera.from_opencv, dict(K=np.array([[20.0, 0, 8], [0, 20.0, 6], [0, 0, 1]]),
                                                           R=np.eye(3), t=(0.0, 0.0, 4.0), width=16, height=12)),
        "Camera.from_opengl": (rs.Camera.from_opengl, dict(view=cam.view_matrix(),
                                                           projection=cam.projection_matrix(0.1, 100.0),
                                                           width=16, height=12)),
        "Camera.projection_matrix": (cam.projection_matrix, dict(near=0.1, far=100.0)),
        "Camera.fit": (rs.Camera.fit, dict(scene_or_bounds=np.array([[-1.0, -1.0, -1.0], [1.0, 1.0, 1.0]]),
                                           direction=(-0.4, -0.35, -1.0), margin=0.05, width=16, height=12)),
        "HeightMap.from_image": (rs.HeightMap.from_image, dict(path=str(png))),
        "HeightMap.from_function": (rs.HeightMap.from_function, dict(fn=lambda u, v: u * v, resolution=8)),
        "HeightMap.dimples": (rs.HeightMap.dimples, dict(count=2, radius=0.3, resolution=8)),
        "HeightMap.wrinkles": (rs.HeightMap.wrinkles, dict(frequency=2, octaves=2, seed=1, resolution=8)),
        "Texture.from_array": (rs.Texture.from_array, dict(image=np.full((2, 2, 3), 0.5), srgb=True)),
        "Texture.from_image": (rs.Texture.from_image, dict(path=str(png), srgb=True)),
        "Texture.checker": (rs.Texture.checker, dict(squares=2, texels_per_square=2,
                                                     colors=((1.0, 1.0, 1.0), (0.0, 0.0, 0.0)))),
        "HitBuffer.empty": (rs.HitBuffer.empty, dict(height=4, width=5)),
        "Mesh.load": (rs.Mesh.load, dict(path=str(obj))),
        "Mesh.from_trimesh": (rs.Mesh.from_trimesh, dict(tm=_trimesh_box())),
        "Frame.save": (frame.save, dict(path=str(tmp / "frame.png"))),
        "SpotLight.falloff": (rs.SpotLight((0.0, 3.0, 0.0), direction=(0.0, -1.0, 0.0)).falloff,
                              dict(cos_angle=0.9)),
        "render_views": (rs.render_views, dict(scene=scene, cameras=[cam], out_dir=str(tmp / "views"), files=None,
                                               run=None, poses={0: np.eye(4)[None]})),
        "ViewFiles": (rs.ViewFiles, dict(buffers=("zdepth",), formats=("npz",), image=".png", depth_scale=1000.0,
                                         float_image=False, compression="none")),
        "RunOptions": (rs.RunOptions, dict(workers=2, scheduler=None, executor="auto", retries=2, resume=True,
                                           numba_threads=1, per_task=1, progress=False, window=4, transfer="auto")),
        "ExportOptions": (rs.ExportOptions, dict(coco_segmentation="rle", polygon_tolerance=0.5, colmap_layout="flat",
                                                 colmap_points=1000)),
    }
    return table


# Modules and names that are not functions to call with arguments.
NOT_CALLED = {
    "SHADINGS": "a tuple of names",
    "HitBuffer": "a plain record the casters fill (H x W or N arrays); its consumers check it (check_hits: "
                 "shade, shading_normals, explain), and they are walked",
    "Frame": "the record render() returns; its consumers (explain, overlays) are walked",
    "FitResult": "the record fit() returns",
}
NOT_CALLED_IN_MODULES = {"shapes.SHAPES": "a table", "bump.WRAPS": "a tuple", "bump.HeightMap": "as HeightMap",
                         "figures.LUMINANCE": "a constant"}


# (callable, argument, bad value) -> why the value is legal. Reviewed: each is a real use.
LEGAL = {
    ("read_depth_png", "scale", "1e308"): "legal: depths in units that small",
    ("view_objects", "rle", "True"): "a flag",
    ("write_colmap", "folder", "'abc'"): "a folder named abc (created)",
    ("move_model", "index", "0"): "the first model",
    **{("orbit_poses", "degrees", v): "no turn, or a turn the other way" for v in ("0", "-1")},
    **{(f, "valid", "None"): "the default: valid everywhere" for f in ("write_flo", "write_flow_png", "flow_colors")},
    ("orbit_poses", "start", "None"): "the default: the identity",
    ("flow_colors", "max_flow", "None"): "the default: the longest flow",
    ("flow_colors", "max_flow", "1e308"): "a legal scale: every flow drawn white",
    **{("save_npz", a, "None"): "the default: not stored" for a in ("camera", "image")},
    ("save_npz", "compressed", "0"): "deflate level 0: stored blocks",
    ("save_npz", "compressed", "True"): "a flag: deflate at level 1",
    ("write_exr", "image", "None"): "the default: buffers only",
    ("write_exr", "threads", "None"): "the default: one per core",
    ("write_exr", "threads", "0"): "OpenEXR's own: compress on the calling thread",
    ("write_depth_png", "depth", "shape"): "a (2, 2) depth map is a depth map",
    ("write_depth_png", "scale", "1e308"): "legal; depths past 16 bits are stored as 0 (none), as documented",
    ("figures.terms", "columns", "None"): "the default: up to 4 columns",
    ("figures.terms", "vmax", "None"): "the default: the brightest term's maximum",
    ("figures.terms", "vmax", "1e308"): "a legal (all-black) scale, as montage's exposure",
    **{(f, "degrees", v): "any finite angle turns (reduced modulo 360 x frames)"
       for f in ("animate_light", "animate_orbit") for v in ("-1", "0", "1e308")},
    ("animate_light", "light_index", "0"): "the first light",
    **{(f, "scale", "None"): "the default display size" for f in ("animate_light", "animate_orbit")},
    ("warmup", "progress", "True"): "a flag",
    ("fit", "keep_images", "True"): "a flag",
    ("grad", "edges", "True"): "a flag (the edge term of the geometry's gradients; none asked for here: warned)",
    ("grad", "seed", "0"): "a seed",
    ("diagnose", "camera", "None"): "the scene's own camera",
    ("Camera.fit", "margin", "0"): "no margin: the extreme point touches the frame",
    **{(f, a, "None"): "None is the documented default" for f, a in [
        ("Material", "kd"),
        ("Material", "ks"), ("Mesh", "normals"), ("Mesh", "uvs"), ("Mesh", "crease_angle"), ("Scene", "camera"),
        ("render", "camera"), ("grad", "wrt"), ("grad", "frame"), ("fit", "progress"), ("shapes.cube", "crease_angle"), ("shapes.cylinder", "crease_angle"),
        ("bump.cylindrical_uvs", "height"), ("overlays.overlay", "radius"), ("overlays.overlay", "length"),
        ("overlays.normal_glyphs", "length"), ("figures.montage", "labels"), ("figures.montage", "columns"),
        ("figures.difference", "title"), ("figures.profile", "title"), ("explore", "camera")]},
    **{("explore", a, "0"): "the first model or light; no mirror bounces" for a in ("model", "light", "max_depth")},
    **{(f, "title", "'abc'"): "a title" for f in ("figures.difference", "figures.profile")},
    ("figures.profile", "frame", "shape"): "an (H, W) array is a grey image",
    ("Texture.from_array", "image", "shape"): "an (h, w) array is a grey image",
    ("Camera.projection_matrix", "far", "1e308"): "a far plane that far: the matrix stays finite",
    ("HeightMap.wrinkles", "seed", "0"): "a seed",
    ("HitBuffer.empty", "height", "0"): "an empty buffer",
    ("HitBuffer.empty", "width", "0"): "an empty buffer",
    ("SpotLight.falloff", "cos_angle", "-1"): "a cosine: behind the light, factor 0",
    ("SpotLight.falloff", "cos_angle", "0"): "a cosine: at right angles, factor 0",
    ("SpotLight.falloff", "cos_angle", "empty"): "documented: any shape (none in, none out)",
    ("SpotLight.falloff", "cos_angle", "shape"): "documented: any shape",
    **{(f, "srgb", "True"): "a flag" for f in ("Texture.from_array", "Texture.from_image")},
    ("figures.profile", "row", "0"): "the top row",
    **{(f, a, "True"): "a boolean option" for f, a in [
        ("DirectionalLight", "shadows"), ("PointLight", "shadows"), ("SpotLight", "shadows"),
        ("AreaLight", "shadows")]},
    **{(f, a, v): "a principal point may lie anywhere in the image plane" for f in ("Camera",)
       for a in ("cx", "cy") for v in ("-1", "0")},
    **{(f, a, "0"): "zero is a legal amount" for f, a in [
        ("DirectionalLight", "intensity"), ("DirectionalLight", "color"), ("PointLight", "intensity"),
        ("PointLight", "color"), ("PointLight", "k"), ("SpotLight", "intensity"), ("SpotLight", "color"),
        ("SpotLight", "k"), ("SpotLight", "exponent"), ("SpotLight", "inner_angle"), ("AreaLight", "intensity"),
        ("AreaLight", "color"), ("AreaLight", "k"), ("Material", "kd"),
        ("Material", "ka"), ("Material", "ks"), ("Material", "reflectivity"), ("Scene", "ambient"),
        ("Scene", "background"), ("render", "max_depth"), ("HeightMap", "scale"),
        ("explain", "x"), ("explain", "y"), ("cast_rays", "tnear"), ("RunOptions", "retries"),
        ("shapes.icosphere", "subdivisions"),
        ("bump.cylindrical_uvs", "axis"), ("bump.planar_uvs", "axis")]},
    **{(f, "name", "'abc'"): "a name" for f in ("DirectionalLight", "PointLight", "SpotLight", "AreaLight",
                                                 "Material", "Mesh", "Texture")},
    **{(f, a, "1e308"): "a mesh of any finite size is a mesh; a scene refuses it at render (scene vertices: "
                        "beyond 1e18 from the scene's centre, Embree's float32 test overflows)"
       for f, a in [("shapes.cube", "size"), ("shapes.plane", "size"), ("shapes.cylinder", "height"),
                    ("shapes.cylinder", "radius"), ("shapes.icosphere", "radius"), ("shapes.uv_sphere", "radius"),
                    ("shapes.torus", "major_radius")]},
    **{(f, a, v): "documented: any shape; negatives and NaN give 0, inf and huge values saturate"
       for f, a in [("to_uint8", "image")] for v in ("-1", "0", "1e308", "empty", "inf", "nan", "shape")},
    ("to_uint8", "exposure", "1e308"): "saturates to white where the image is > 0",
    ("to_uint8", "gamma", "1e308"): "a legal (flattening) curve",
    ("Camera", "fx", "1e308"): "a telephoto pin-hole: renders (the centre pixels)",
    ("Camera", "fy", "1e308"): "a telephoto pin-hole: renders",
    ("Camera", "cx", "1e308"): "a principal point far off the image: renders (nothing in view)",
    ("Camera", "cy", "1e308"): "a principal point far off the image: renders (nothing in view)",
    ("Camera", "ortho_height", "1e308"): "a camera is a camera; render refuses the frame (camera.eye: beyond 1e18)",
    ("HeightMap", "heights", "shape"): "a 2 x 2 height map, the smallest legal one",
    ("Texture", "texels", "shape"): "a 2 x 2 grey texture (2-D texels are grey)",
    ("HeightMap", "scale", "-1"): "a negative scale turns bumps into dents",
    ("Material", "shininess", "1e308"): "a highlight only where r.v = 1: legal, (r.v)^t underflows to 0",
    ("PointLight", "k", "1e308"): "read only by the heuristic law: 1/(d + k), a vanishing light",
    ("SpotLight", "k", "1e308"): "read only by the heuristic law: 1/(d + k), a vanishing light",
    ("AreaLight", "k", "1e308"): "read only by the heuristic law: 1/(d + k), a vanishing light",
    ("Scene", "lights", "empty"): "an empty sequence: no lights (render warns NoLightsWarning)",
    ("bump.cylindrical_uvs", "height", "1e308"): "v = h / height: all near 0, legal",
    ("cast_rays", "tfar", "0"): "an empty interval: every ray misses",
    ("cast_rays", "tfar", "inf"): "an unbounded ray",
    ("cast_rays", "tfar", "1e308"): "a finite but unbounded-in-practice ray",
    ("choose_methods", "max_pixels", "0"): "documented >= 0: Gouraud only for sub-pixel edges",
    ("overlays.normal_glyphs", "length", "1e308"): "glyphs clipped to the image",
    ("overlays.normal_glyphs", "width", "1e308"): "glyphs clipped to the image: every pixel",
    ("overlays.overlay", "width", "1e308"): "lines clipped to the image: every pixel",
    ("overlays.overlay", "radius", "1e308"): "dots clipped to the image: every pixel",
    ("overlays.overlay", "length", "1e308"): "glyphs clipped to the image",
    ("overlays.overlay", "color", "0"): "black",
    ("render_views", "cameras", "None"): "the scene's own camera (plan_batch)",
    ("render_views", "out_dir", "'abc'"): "a folder name",
    ("render_views", "files", "None"): "the default: ViewFiles()",
    ("render_views", "run", "None"): "the default: RunOptions(), in this process",
    ("render_views", "poses", "None"): "the default: every model as the scene places it",
    **{("RunOptions", a, "None"): "None is the documented default (this process; automatic)"
       for a in ("workers", "scheduler", "numba_threads", "per_task", "window")},
    **{("RunOptions", a, "True"): "a flag" for a in ("resume", "progress")},
    ("ExportOptions", "colmap_points", "0"): "documented: no points, an empty points3D.txt",
    ("ExportOptions", "polygon_tolerance", "0"): "documented: exact polygons along the pixel edges",
    ("ViewFiles", "image", "None"): "no image file per view (the buffers are written)",
    ("ViewFiles", "formats", "None"): "no buffer files: each view writes its image and its record",
    ("ViewFiles", "float_image", "True"): "a flag",
    ("ViewFiles", "depth_scale", "1e308"): "legal, as write_depth_png's scale: depths past 16 bits are stored as 0",
    ("render", "tolerance", "1e308"): "any method is good enough",
    ("choose_methods", "tolerance", "1e308"): "any method is good enough",
    ("choose_methods", "max_pixels", "1e308"): "no limit on the pixels sampled",
}


PATHS = ("path", "out_dir")
LATE = "late"
# The work a refusal must come before: packing the kernels' inputs, and the Embree BVH (built or fetched).
WORK = ("kernel_inputs", "embree_accel")


@contextlib.contextmanager
def _work_probe():
    """Count calls of the :data:`WORK` functions, wherever the package imported them."""
    import sys

    from raycast_shade.shading import inputs
    from raycast_shade.visibility import accel

    originals = {"kernel_inputs": inputs.kernel_inputs, "embree_accel": accel.embree_accel}
    calls = []

    def counting(name, fn):
        def wrapper(*args, **kwargs):
            calls.append(name)
            return fn(*args, **kwargs)
        return wrapper

    patched = []
    for modname, mod in list(sys.modules.items()):
        if not modname.startswith("raycast_shade") or mod is None:
            continue
        for attr, value in list(vars(mod).items()):  # under any name (inputs.prepare is kernel_inputs)
            for name, fn in originals.items():
                if value is fn:
                    setattr(mod, attr, counting(name, fn))
                    patched.append((mod, attr, fn))
    try:
        yield calls
    finally:
        for mod, attr, fn in patched:
            setattr(mod, attr, fn)


def _names_argument(message: str, arg: str, value) -> bool:
    """Whether an error message names the argument (``width``, ``camera.width``, ``models[0]``...);
    for a file or folder, naming the path given serves as well."""
    m = message.lower()
    if arg in PATHS and isinstance(value, str) and value.lower() in m:
        return True
    return arg.lower() in m or arg.lower().replace("_", " ") in m


def classify(fn, kwargs, arg, value):
    """Call ``fn(**kwargs)`` with ``arg`` replaced by ``value``: (outcome, message).

    Run from the folder of the baselines' files, so that a path such as "abc" lands there."""
    args = dict(kwargs, **{arg: value})
    out = io.StringIO()
    calls = []
    try:
        with warnings.catch_warnings(), contextlib.redirect_stdout(out), _work_probe() as calls:
            warnings.simplefilter("ignore")
            result = fn(**args)
        if hasattr(result, "savefig"):  # a matplotlib figure: close it, or hundreds pile up
            import matplotlib.pyplot as plt

            plt.close(result)
    except (ValueError, TypeError) as exc:
        if calls:  # refused, but only after packing or tracing: late
            return LATE, f"{type(exc).__name__} after {sorted(set(calls))}: {exc}"
        return (ERROR if _names_argument(str(exc), arg, value) else UNNAMED), f"{type(exc).__name__}: {exc}"
    except OSError as exc:
        if arg in PATHS and isinstance(exc, (FileNotFoundError, FileExistsError, IsADirectoryError,
                                             NotADirectoryError)):
            return ERROR, f"{type(exc).__name__}: {exc}"
        return WRONG_TYPE, f"{type(exc).__name__}: {exc}"
    except Exception as exc:  # noqa: BLE001 - the point is to see every other kind
        return WRONG_TYPE, f"{type(exc).__name__}: {exc}"
    return ACCEPTED, ""


def walk(tmp):
    """Every (callable, argument, bad value): ``{(name, arg, value key): (outcome, message)}``."""
    results = {}
    here = os.getcwd()
    os.chdir(tmp)
    try:
        _walk(tmp, results)
    finally:
        os.chdir(here)
    return results


def _walk(tmp, results):
    for name, (fn, kwargs) in baselines(tmp).items():
        for arg in kwargs:
            for key, make in BAD.items():
                outcome, message = classify(fn, kwargs, arg, make())
                if outcome == ACCEPTED and (name, arg, key) in LEGAL:
                    outcome = OK
                results[name, arg, key] = (outcome, message)


def public_callables():
    """Qualified names of every public callable: ``rs.__all__`` and its public modules' ``__all__``."""
    names = []
    for n in rs.__all__:
        obj = getattr(rs, n)
        if isinstance(obj, type) and issubclass(obj, Warning):
            continue
        if isinstance(obj, types.ModuleType):
            for m in getattr(obj, "__all__", ()):
                if callable(getattr(obj, m)) and not (isinstance(getattr(obj, m), type)
                                                      and issubclass(getattr(obj, m), Warning)):
                    names.append(f"{n}.{m}")
            continue
        names.append(n)
        if isinstance(obj, type):  # its alternative constructors are public functions too
            names += [f"{n}.{k}" for k, v in vars(obj).items()
                      if not k.startswith("_") and isinstance(v, (classmethod, staticmethod))]
    return names


@pytest.fixture(scope="module")
def walked(tmp_path_factory):
    return walk(tmp_path_factory.mktemp("contract"))


def test_every_public_callable_has_a_baseline(tmp_path):
    have = set(baselines(tmp_path))
    missing = [n for n in public_callables() if n not in have and n not in NOT_CALLED
               and n not in NOT_CALLED_IN_MODULES]
    assert not missing, f"public callables the contract walk does not cover (add a baseline): {missing}"


def test_baselines_are_valid(tmp_path):
    for name, (fn, kwargs) in baselines(tmp_path).items():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            fn(**kwargs)  # raises if a baseline is wrong, which would make every row meaningless


def test_every_bad_value_is_refused_naming_the_argument(walked):
    bad = {k: v for k, v in walked.items() if v[0] not in (OK, ERROR)}
    lines = [f"{n}({a}={k}): {o} {m[:120]}" for (n, a, k), (o, m) in sorted(bad.items())]
    assert not bad, f"{len(bad)} breaches of the contract:\n" + "\n".join(lines)


def test_the_work_probe_sees_work():
    # The "before any work" half of the contract is only as good as the probe: it must see a render's work.
    with _work_probe() as calls:
        rs.render(_scene(), "phong")
    assert set(calls) == set(WORK), calls


def test_legal_list_holds_no_stale_entries(walked):
    stale = [k for k in LEGAL if k not in walked or walked[k][0] != OK]
    assert not stale, f"LEGAL entries the walk no longer accepts or no longer has: {stale}"


# -- the good unusual inputs ---------------------------------------------------------------------------------

def _vector_args(table):
    for name, (fn, kwargs) in table.items():
        for arg, value in kwargs.items():
            if isinstance(value, tuple) and len(value) == 3 and all(isinstance(c, float) for c in value):
                yield name, fn, kwargs, arg, value


def _scalar_args(table):
    for name, (fn, kwargs) in table.items():
        for arg, value in kwargs.items():
            if isinstance(value, (int, float)) and not isinstance(value, bool):
                yield name, fn, kwargs, arg, value


def test_column_and_row_vectors_are_taken_where_a_vector_is_meant(tmp_path):
    refused = []
    for name, fn, kwargs, arg, value in _vector_args(baselines(tmp_path)):
        for shape in ((3, 1), (1, 3)):
            outcome, message = classify(fn, kwargs, arg, np.array(value).reshape(shape))
            if outcome != ACCEPTED:
                refused.append(f"{name}({arg}={shape}): {message}")
    assert not refused, refused


def test_numpy_scalars_are_numbers(tmp_path):
    refused = []
    for name, fn, kwargs, arg, value in _scalar_args(baselines(tmp_path)):
        kinds = (np.int64, np.int32, np.array) if isinstance(value, int) else (np.float64, np.float32, np.array)
        for kind in kinds:
            outcome, message = classify(fn, kwargs, arg, kind(value))
            if outcome != ACCEPTED:
                refused.append(f"{name}({arg}={kind.__name__}({value})): {message}")
    assert not refused, refused


def test_strings_and_booleans_are_never_numbers(walked):
    """The two classes the issue names, on every numeric argument: never accepted."""
    loose = [k for k, (o, _) in walked.items() if k[2] in ("'abc'", "True") and o == ACCEPTED]
    assert not loose, loose


# -- the command line ---------------------------------------------------------------------------------------

CLI_BAD = {"'abc'": "abc", "nan": "nan", "inf": "inf", "-1": "-1", "0": "0", "1e308": "1e308", "''": ""}
SCENE_TOML = ('[camera]\neye = [0.0, 0.0, 4.0]\nwidth = 8\nheight = 6\n\n[[object]]\nshape = "icosphere"\n'
              'subdivisions = 1\n\n[[light]]\ntype = "point"\nposition = [2.0, 3.0, 4.0]\n')
# Valid, small runs of each subcommand; the option walked is appended (the last occurrence wins).
CLI_BASE = {"demo": ["--width=8", "--height=6", "-o", "demo.png"], "render": ["scene.toml", "-o", "out.png"],
            "animate": ["scene.toml", "--frames=2", "-o", "frames"],
            "views": ["scene.toml", "--orbit=2", "-o", "views", "--overwrite"]}  # each run its own plan
# Options whose values are names of things outside the walk: files (any string names one) and the
# address of a Dask scheduler (connecting to "abc" waits for a network timeout).
CLI_NOT_WALKED = {"output": "a path", "scheduler": "a Dask scheduler's address", "image": "an extension (views)",
                  "formats": "a list of names, tested in test_views"}
# (subcommand, option, value) -> why exit 0 is right.
CLI_LEGAL = {
    **{(c, "--degrees", v): "any finite angle orbits" for c in ("animate",) for v in ("-1", "0")},
    **{(c, "--light-index", "0"): "the first light" for c in ("animate",)},
    **{(c, "--max-depth", "0"): "no mirror bounces" for c in ("render", "animate", "views")},
    **{(c, "--exposure", "1e308"): "saturates to white, as to_uint8" for c in ("demo", "render", "animate", "views")},
    **{(c, "--gamma", "1e308"): "a legal (flattening) curve, as to_uint8" for c in ("demo", "render", "animate",
                                                                                   "views")},
    **{(c, "--tolerance", "1e308"): "any method is good enough" for c in ("render", "animate", "views")},
    ("animate", "--degrees", "1e308"): "reduced modulo 360 x frames: every frame a finite turn",
    ("animate", "--fps", "1e308"): "the frame rate of a video; PNG frames (the walk's output) have none",
    ("views", "--export", "''"): "an empty list of exports: the view set alone, as without --export",
    ("views", "--colmap-points", "0"): "no surface points: an empty points3D.txt, as before",
    ("views", "--coco-polygons", "0"): "polygons along every pixel corner: exact",
}


def _cli_options():
    from raycast_shade.apps.cli import build_parser

    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    for command, p in sub.choices.items():
        for action in p._actions:
            if action.option_strings and action.nargs != 0 and action.dest not in ("help", "version"):
                yield command, action


def _cli_run(argv):
    from raycast_shade.apps.cli import main

    err, out = io.StringIO(), io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out), warnings.catch_warnings():
        try:
            code = main(argv)
        except SystemExit as exc:  # argparse's own usage errors
            code = exc.code
        except BaseException as exc:  # noqa: BLE001 - a traceback would reach the user
            return -1, f"{type(exc).__name__}: {exc}"
    return code, err.getvalue()


def cli_walk(tmp):
    """Every (subcommand, option, bad value): ``{(command, option, key): (outcome, message)}``."""
    here = os.getcwd()
    os.chdir(tmp)
    (tmp / "scene.toml").write_text(SCENE_TOML)
    (tmp / "frames").mkdir(exist_ok=True)
    results = {}
    try:
        for command, action in _cli_options():
            if action.dest in CLI_NOT_WALKED:
                continue
            option = action.option_strings[-1]
            for key, value in CLI_BAD.items():
                code, err = _cli_run([command] + CLI_BASE.get(command, []) + [f"{option}={value}"])
                errors = [ln for ln in err.splitlines() if "error:" in ln]
                if code == 0:
                    outcome = OK if (command, option, key) in CLI_LEGAL else ACCEPTED
                elif code == 2 and len(errors) == 1 and "Traceback" not in err:
                    outcome = ERROR
                else:
                    outcome = WRONG_TYPE
                results[command, option, key] = (outcome, errors[-1] if errors else err[-200:])
    finally:
        os.chdir(here)
    return results


@pytest.fixture(scope="module")
def cli_walked(tmp_path_factory):
    return cli_walk(tmp_path_factory.mktemp("cli"))


def test_cli_baselines_run(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "scene.toml").write_text(SCENE_TOML)
    (tmp_path / "frames").mkdir()
    for command, argv in CLI_BASE.items():
        code, err = _cli_run([command] + argv)
        assert code == 0 and "error" not in err, (command, err)  # else every row of the walk is meaningless


def test_cli_options_refuse_generic_bad_values_in_one_line(cli_walked):
    bad = {k: v for k, v in cli_walked.items() if v[0] not in (OK, ERROR)}
    lines = [f"{c} {o}={k}: {out} {m[:150]}" for (c, o, k), (out, m) in sorted(bad.items())]
    assert not bad, f"{len(bad)} breaches of the command line's contract:\n" + "\n".join(lines)


def test_cli_legal_list_holds_no_stale_entries(cli_walked):
    stale = [k for k in CLI_LEGAL if cli_walked.get(k, ("",))[0] != OK]
    assert not stale, stale


# -- numbers that can overflow don't: texture coordinates and tilings of any finite size -----------------------

def _textured_plane(uv, tiling=(1.0, 1.0), wrap="repeat", filt="bilinear", texels=None):
    plane = rs.shapes.plane(2.0, subdivisions=2)
    uvs = np.broadcast_to(np.asarray(uv, np.float64), plane.uvs.shape) if uv is not None else plane.uvs
    mesh = rs.Mesh(plane.vertices, plane.faces, normals=plane.normals, uvs=uvs, name="quad")
    if texels is None:
        texels = np.random.default_rng(5).uniform(0.0, 1.0, (3, 5, 3))
    tex = rs.Texture(texels, wrap=wrap, filter=filt, tiling=tiling)
    return rs.Scene([rs.Model(mesh, rs.Material(kd=1.0, ka=0.0, ks=0.0, kd_map=tex))],
                    lights=[rs.DirectionalLight((0.0, 0.0, -1.0))], ambient=0.0,
                    camera=rs.Camera(eye=(0.0, 0.0, 3.0), width=16, height=12))


HUGE_UVS = [(1e20, 1e20), (1e300, -1e300), (-1e300, 1e20), (2.0 ** 60, 3.0)]


@pytest.mark.parametrize("wrap", ["repeat", "clamp"])
@pytest.mark.parametrize("filt", ["bilinear", "mipmap"])
@pytest.mark.parametrize("uv", HUGE_UVS)
def test_huge_uvs_give_the_reduced_uv_pixels(uv, filt, wrap):
    # Reduced: repeat's period is 1, and a float64 past 2**52 is a whole number, so u mod 1 = 0;
    # clamp takes the border texel on the side of the sign: u -> 1 or 0.
    reduced = [(0.0 if wrap == "repeat" else (1.0 if c > 0 else 0.0)) for c in uv]
    if wrap == "repeat" and uv[1] == 3.0:
        reduced[1] = 0.0
    from raycast_shade.study.reference import shade_reference

    for shading in ("flat", "gouraud", "phong"):
        for backend in ("raycast", "raster"):
            scene = _textured_plane(uv, wrap=wrap, filt=filt)
            frame = rs.render(scene, shading, backend=backend)
            expect = rs.render(_textured_plane(reduced, wrap=wrap, filt=filt), shading, backend=backend)
            img = frame.image
            assert np.all(np.isfinite(img)) and img.min() >= 0.0 and img.max() <= 1.0, (shading, backend)
            np.testing.assert_array_equal(img, expect.image, err_msg=f"{shading} {backend}")
            e = frame.explain(8, 6)
            np.testing.assert_allclose(e.total, img[6, 8], rtol=2 * np.finfo(np.float32).eps, atol=1e-12)
            # The NumPy twin reduces huge coordinates its own way (np.fmod over arrays): the same pixels.
            twin = shade_reference(scene, scene.camera, frame.hits, shading)
            np.testing.assert_allclose(twin, img, rtol=2 * np.finfo(np.float32).eps, atol=1e-12)


@pytest.mark.parametrize("tiling", [(1e30, 2.0 ** 60), (1e300, 1e30)])
def test_huge_tilings_wrap_exactly(tiling):
    # u * tiling past 2**52 is a whole number of periods: the pixel of u = 0 (bilinear), or, mip-mapped,
    # the pyramid's 1 x 1 average (the footprint covers billions of texels).
    texels = np.random.default_rng(5).uniform(0.0, 1.0, (4, 4, 3))
    for shading in ("flat", "gouraud", "phong"):
        frame = rs.render(_textured_plane(None, tiling=tiling, texels=texels), shading)
        expect = rs.render(_textured_plane((0.0, 0.0), texels=texels), shading)
        assert np.all(np.isfinite(frame.image)) and frame.image.min() >= 0.0
        np.testing.assert_array_equal(frame.image, expect.image, err_msg=shading)
        mip = rs.render(_textured_plane(None, tiling=tiling, texels=texels, filt="mipmap"), shading)
        top = rs.Texture(texels, filter="mipmap").pyramid[-1].reshape(3).astype(np.float64)
        hit = mip.mask
        np.testing.assert_allclose(mip.image[hit], np.broadcast_to(top, (int(hit.sum()), 3)), rtol=1e-6)
