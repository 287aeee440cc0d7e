"""The built-in demo: one scene, shaded flat, Gouraud and Phong.

Three coarse objects stand on a floor: a low-poly sphere, an egg and a tilted
torus. :func:`render_demo` renders the scene three times and stacks the panels
top to bottom (FLAT, GOURAUD, PHONG), so each object is compared down its own
column. The meshes are coarse on purpose, so that the lecture's differences
are plain to see:

* flat: one colour per triangle, facets everywhere, the floor a patchwork;
* Gouraud: smooth colour, but polygonal highlights and Mach bands along the
  edges; a highlight that falls inside a large polygon (the green pool of
  light on the floor, the egg's highlight) is lost entirely;
* Phong: round highlights and a round pool of light, from the same mesh.

Lights: a warm key light (point, inverse square) that casts shadows, a blue
light at infinity from the left, a magenta rim light behind (point,
heuristic ``1 / (d + k)``) and a green point light just above the floor
(inverse square). Shadow rays leave the point where each mode evaluates the
model, so the shadows too are blocky (flat), blurred (Gouraud) or crisp
(Phong).

Everything is procedural: no downloads, and no trimesh import (half a second
of start-up that ``raycast-shade demo`` does not need).
"""

from __future__ import annotations

import functools

import numpy as np

from ..scene.heightmap import HeightMap
from ..scene.camera import Camera
from ..scene.lights import DirectionalLight, PointLight
from ..scene.material import Material
from ..scene.mesh import Mesh
from ..scene.scene import Model, Scene
from ..scene.shapes import plane, torus, uv_sphere

__all__ = ["demo_scene", "render_demo", "render_demo_frames", "compose", "draw_text", "LABELS", "MODES",
           "FONT_SIZE"]

MODES = ("flat", "gouraud", "phong")
LABELS = ("FLAT", "GOURAUD", "PHONG")
DEFAULT_WIDTH = 960
DEFAULT_HEIGHT = 280


def _placed(mesh: Mesh, scale=(1.0, 1.0, 1.0), rotate_x: float = 0.0, offset=(0.0, 0.0, 0.0)) -> Mesh:
    """Scale (per axis), tilt about x (degrees) and move a mesh with normals."""
    s = np.asarray(scale, float)
    c, si = np.cos(np.radians(rotate_x)), np.sin(np.radians(rotate_x))
    r = np.array([[1.0, 0.0, 0.0], [0.0, c, -si], [0.0, si, c]])
    v = (mesh.vertices * s) @ r.T + np.asarray(offset, float)
    # Normals transform by the inverse transpose: 1/s per axis, then the rotation.
    n = (mesh.normals / s) @ r.T
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    return Mesh(v, mesh.faces, normals=n, uvs=mesh.uvs, name=mesh.name)


def demo_scene(width: int = DEFAULT_WIDTH, height: int = DEFAULT_HEIGHT) -> Scene:
    """Three coarse, glossy objects on a floor, under four coloured lights.

    Left to right: a red low-poly sphere (8 rings x 12 segments), an orange
    egg (a 10 x 14 sphere stretched along y, dimpled by a bump map) and a
    blue torus tilted towards the camera (16 x 8 segments), each with a Phong
    specular term; a grey, slightly glossy floor of 8 x 8 squares, and a
    square mirror behind the egg. The key light casts shadows.

    Parameters
    ----------
    width, height : int
        Image size of the scene's camera. The field of view widens for
        narrow images so that all three objects stay in view.

    Returns
    -------
    Scene
    """
    sphere = _placed(uv_sphere(rings=8, segments=12, radius=0.8), offset=(-2.05, 0.8, 0.0))
    egg = _placed(uv_sphere(rings=10, segments=14, radius=0.8), scale=(0.8, 1.2, 0.8), offset=(0.0, 0.96, 0.0))
    ring = _placed(torus(0.72, 0.3, 16, 8), rotate_x=62.0, offset=(2.05, 0.9, 0.0))
    floor = plane(size=14.0, subdivisions=8, center=(0.0, 0.0, -3.0), normal="+y", name="floor")
    models = [
        Model(sphere, Material(kd=(0.85, 0.18, 0.12), ka=(0.85, 0.18, 0.12), ks=0.7, shininess=40)),
        # Dimpled by a Blinn bump map: only Phong, which has a normal per pixel, shows it.
        Model(egg, Material(kd=(0.95, 0.62, 0.12), ka=(0.95, 0.62, 0.12), ks=0.6, shininess=60,
                            bump=HeightMap.dimples(6, 0.35, resolution=256, scale=0.012, tiling=(2.0, 2.0)))),
        Model(ring, Material(kd=(0.15, 0.4, 0.9), ka=(0.15, 0.4, 0.9), ks=0.8, shininess=30)),
        Model(floor, Material(kd=0.4, ka=0.4, ks=0.3, shininess=20)),
        # A mirror behind the egg shows the objects' backs (traced per point in every mode).
        Model(plane(size=2.6, center=(0.0, 1.3, -2.4), normal="+z", name="mirror"),
              Material(kd=0.05, ka=0.05, ks=0.0, reflectivity=0.85)),
    ]
    lights = [
        PointLight((2.0, 5.0, 3.0), intensity=30.0, color=(1.0, 0.92, 0.78), attenuation="inverse_square", shadows=True,
                   name="key"),
        DirectionalLight((1.0, -0.35, -0.4), intensity=0.4, color=(0.35, 0.5, 1.0), name="sky"),
        PointLight((-1.5, 3.0, -3.5), intensity=2.5, color=(1.0, 0.25, 0.75), attenuation="heuristic", k=1.0,
                   name="rim"),
        PointLight((1.05, 0.3, 1.25), intensity=0.6, color=(0.3, 1.0, 0.45), attenuation="inverse_square",
                   name="accent"),
    ]
    # Wide panels: the height fixes the view; narrow ones: the row of objects does.
    tan_half = max(0.345 * height / width, 0.15)
    fov = float(np.degrees(2.0 * np.arctan(tan_half)))
    camera = Camera(eye=(0.0, 2.2, 9.0), target=(0.0, 0.75, 0.0), fov=fov, width=width, height=height)
    return Scene(models, lights=lights, camera=camera, ambient=0.06)


def render_demo_frames(width: int = DEFAULT_WIDTH, height: int = DEFAULT_HEIGHT, *, caster: str = "auto"):
    """The demo scene rendered flat, Gouraud and Phong.

    Parameters
    ----------
    width, height : int
        Size of each frame.
    caster : {"auto", "embree", "embreex"}

    Returns
    -------
    list of Frame
        In the order of :data:`LABELS`.
    """
    import warnings

    from ..common.warnings import BumpIgnoredWarning
    from ..render import render

    scene = demo_scene(width, height)
    with warnings.catch_warnings():  # the egg's bumps are missing from flat and Gouraud on purpose
        warnings.simplefilter("ignore", BumpIgnoredWarning)
        return [render(scene, mode, caster=caster) for mode in MODES]


def compose(images, labels=LABELS, gap: int = 2) -> np.ndarray:
    """Stack images top to bottom, separated by ``gap`` black rows, and label them.

    Parameters
    ----------
    images : sequence of (H, W, 3) float
    labels : sequence of str, optional
        Drawn in the top-left corner of each panel (see :func:`draw_text`).
    gap : int

    Returns
    -------
    (n H + (n - 1) gap, W, 3) float32
    """
    w = images[0].shape[1]
    sep = np.zeros((gap, w, 3), np.float32)
    parts = []
    for i, img in enumerate(images):
        img = np.array(img, np.float32)
        if labels is not None and labels[i]:
            scale = max(1, img.shape[0] // 80)
            draw_text(img, labels[i], 3 * scale, 3 * scale, scale)
        if i:
            parts.append(sep)
        parts.append(img)
    return np.concatenate(parts, axis=0)


def render_demo(width: int = DEFAULT_WIDTH, height: int = DEFAULT_HEIGHT, *, labels: bool = True,
                caster: str = "auto") -> np.ndarray:
    """One image showing the three shading modes of :func:`demo_scene`.

    Panels are stacked top to bottom (flat, Gouraud, Phong), so each object
    is compared down its own column.

    Parameters
    ----------
    width, height : int
        Size of each panel.
    labels : bool
        Write FLAT / GOURAUD / PHONG on the panels.
    caster : {"auto", "embree", "embreex"}

    Returns
    -------
    (3 height + 4, width, 3) float32
        Linear RGB, with 2-pixel black gaps between the panels.
    """
    frames = render_demo_frames(width, height, caster=caster)
    return compose([f.image for f in frames], LABELS if labels else None)


#: Font pixels per ``scale`` of :func:`draw_text`: capitals about 7 ``scale`` tall.
FONT_SIZE = 10


@functools.lru_cache(maxsize=8)
def _font(size: int):
    """Pillow's built-in font (Aileron Regular, shipped inside Pillow: nothing downloaded) at ``size`` pixels;
    Pillow's fixed bitmap font where it is built without FreeType."""
    from PIL import ImageFont

    return ImageFont.load_default(size=size)


def _coverage(text: str, size: int) -> tuple:
    """``(alpha, left, top)``: the text's anti-aliased coverage in [0, 1] as (h, w) float32, and where
    its top-left pixel lies relative to the anchor (the top-left of the text)."""
    from PIL import Image, ImageDraw

    font = _font(size)
    left, top, right, bottom = font.getbbox(text, anchor="lt")
    if right <= left or bottom <= top:
        return np.zeros((0, 0), np.float32), 0, 0
    mask = Image.new("L", (right - left, bottom - top), 0)
    ImageDraw.Draw(mask).text((-left, -top), text, fill=255, font=font, anchor="lt")
    return np.asarray(mask, np.float32) / np.float32(255.0), left, top


def draw_text(image: np.ndarray, text: str, x: int, y: int, scale: int = 1, value: float = 1.0) -> None:
    """Write ``text`` into ``image`` in place, with a black drop shadow, in Pillow's built-in font.

    Parameters
    ----------
    image : (H, W, 3) float array
        Modified in place; the text is clipped at the borders.
    text : str
        Written as given (any characters the font has).
    x, y : int
        Top-left corner of the text in pixels.
    scale : int
        Size: the font is ``FONT_SIZE * scale`` pixels (capitals about
        ``7 * scale`` tall, as the 5x7 bitmap font this replaced), the
        shadow ``scale`` pixels down and right.
    value : float
        Linear intensity of the letters (1.0 is white after tone mapping);
        edge pixels blend it with the image by the glyph's coverage.
    """
    from ..common.validate import as_int

    scale = as_int(scale, "scale", minimum=1)
    alpha, left, top = _coverage(str(text), FONT_SIZE * scale)
    for shift, val in ((scale, 0.0), (0, value)):  # the shadow first, the letters over it
        _blend(image, alpha, int(y) + top + shift, int(x) + left + shift, val)


def _blend(image: np.ndarray, alpha: np.ndarray, y: int, x: int, value: float) -> None:
    """``image = value * alpha + image * (1 - alpha)`` over ``alpha``'s box at row ``y``, column ``x``, clipped."""
    h, w = image.shape[:2]
    ah, aw = alpha.shape
    y0, x0, y1, x1 = max(y, 0), max(x, 0), min(y + ah, h), min(x + aw, w)
    if y0 >= y1 or x0 >= x1:
        return
    a = alpha[y0 - y:y1 - y, x0 - x:x1 - x, None]
    region = image[y0:y1, x0:x1]
    region[...] = value * a + region * (1.0 - a)  # coverage 1: exactly value
