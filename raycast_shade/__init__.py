"""raycast_shade: the classic local-illumination models, by ray casting.

Embree finds the hits, Numba shades them: flat, Gouraud and Phong shading with
Lambert and Phong/Blinn-Phong reflection, per-channel colour and the lecture's
attenuation laws.

>>> import raycast_shade as rs
>>> scene = rs.Scene(
...     [rs.Model(rs.shapes.icosphere(3), rs.Material(kd=(0.8, 0.3, 0.2), ks=0.5, shininess=40))],
...     lights=[rs.PointLight((2, 3, 4), intensity=20, attenuation="inverse_square")],
...     camera=rs.Camera(eye=(0, 0, 4), width=320, height=240),
... )
>>> frame = rs.render(scene, shading="phong")
>>> frame.image.shape
(240, 320, 3)
"""

from .visibility.platforms import require_embreex

require_embreex()  # first: a platform without Embree 4 hears so here, naming the remedy, not at the first render

from .scene import heightmap as bump  # noqa: E402 - after the check
from .scene import shapes
from .scene.heightmap import HeightMap
from .scene.camera import Camera
from .visibility.cast import cast_camera, cast_rays
from .output.frame import Frame
from .visibility.hits import HitBuffer
from .scene.lights import AreaLight, DirectionalLight, PointLight, SpotLight
from .scene.material import Material
from .scene.texture import Texture
from .scene.meshfile import load_models
from .scene.mesh import Mesh
from .scene.normals import WindingWarning, winding_conflicts
from .render import render, render_file
from .gradients import grad
from .fitting import FitResult, fit
from .scene.scene import Model, Scene
from .insight.auto import choose_methods
from .insight.explain import explain
from .shading.normals import shading_normals
from .shading.shade import SHADINGS, shade
from .output.tonemap import read_pfm, to_uint8, write_pfm
from .common.version import __version__
from .common.warnings import (AllMaskedWarning, BumpIgnoredWarning, ColourRangeWarning, CreaseWarning,
                              DroppedOnLoadWarning, EmptyViewWarning, LensFoldWarning, LightInsideWarning,
                              NoLightsWarning, NormalMapWarning, ShadingWarning, SingleSidedWarning,
                              ZeroNormalWarning)


__all__ = [
    "AreaLight", "Camera", "DirectionalLight", "HeightMap", "Texture", "load_models", "bump", "Frame", "HitBuffer", "Material", "Mesh", "Model", "PointLight", "Scene", "SpotLight",
    "SHADINGS", "cast_camera", "cast_rays", "grad", "fit", "FitResult", "read_pfm", "render", "render_file", "choose_methods", "shade", "shading_normals", "shapes", "to_uint8", "write_pfm",
    "WindingWarning", "winding_conflicts",
    "ShadingWarning", "BumpIgnoredWarning", "ColourRangeWarning", "CreaseWarning", "DroppedOnLoadWarning",
    "LightInsideWarning", "NoLightsWarning", "ZeroNormalWarning", "EmptyViewWarning", "SingleSidedWarning",
    "AllMaskedWarning", "NormalMapWarning", "LensFoldWarning",
    "figures", "overlays",
    "explain", "explore", "render_views", "ViewFiles", "RunOptions", "ExportOptions", "diagnose", "warmup", "animate_light",
    "animate_orbit",
    "save_npz", "load_npz", "write_exr", "read_exr", "write_depth_png", "read_depth_png",
    "optical_flow", "move_model", "semantic_classes", "object_table", "view_objects", "coco_instances", "write_coco",
    "rle_encode", "rle_decode", "nerfstudio_transforms", "write_transforms", "write_colmap",
    "keyframes", "orbit_poses", "write_flo", "read_flo", "write_flow_png", "read_flow_png", "flow_colors",
]

# Imported on first access: figures needs matplotlib and explore ipywidgets (the
# "notebook" extra), render_views and its records (ViewFiles, RunOptions, ExportOptions) the batch machinery, the vision files and labels are
# not needed to render, and none belongs on the start-up path of ``raycast-shade demo``.
_LAZY = {"figures": ".output.figures", "overlays": ".output.overlays"}
_LAZY_FUNCTIONS = {"explore": ".apps.explore", "render_views": ".apps.views", "ViewFiles": ".apps.viewfiles",
                   "RunOptions": ".apps.batch.run", "ExportOptions": ".apps.viewexports", "diagnose": ".apps.diagnose",
                   "warmup": ".apps.warmup", "animate_light": ".apps.movie", "animate_orbit": ".apps.movie",
                   **{n: ".output.bufferfile" for n in ("save_npz", "load_npz", "write_exr", "read_exr",
                                                         "write_depth_png", "read_depth_png")},
                   **{n: ".output.flow" for n in ("optical_flow", "move_model")},
                   **{n: ".scene.posetrack" for n in ("keyframes", "orbit_poses")},
                   **{n: ".output.flowfiles" for n in ("write_flo", "read_flo", "write_flow_png", "read_flow_png",
                                                        "flow_colors")},
                   **{n: ".output.labels" for n in ("semantic_classes", "object_table", "view_objects",
                                                     "coco_instances", "write_coco", "rle_encode", "rle_decode")},
                   **{n: ".output.export" for n in ("nerfstudio_transforms", "write_transforms", "write_colmap")}}


def __getattr__(name):
    import importlib

    if name in _LAZY:
        return importlib.import_module(_LAZY[name], __name__)
    if name in _LAZY_FUNCTIONS:
        return getattr(importlib.import_module(_LAZY_FUNCTIONS[name], __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
