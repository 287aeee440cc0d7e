"""glTF ``KHR_materials_pbrSpecularGlossiness`` read by the library itself.

trimesh converts the extension to metallic-roughness on its own, outside the texture path
every other image takes (palette PNGs, sRGB decoding), which gave a dark, mirror-like
surface. Here the extension's own images are decoded from the file (:func:`gltf_image`)
and mapped, diffuse colour ``D`` (``diffuseFactor`` times ``diffuseTexture``, sRGB),
specular colour ``S`` (``specularFactor`` times the ``specularGlossinessTexture``'s RGB,
sRGB) and glossiness ``g`` (``glossinessFactor`` times its alpha, linear):

* ``reflectance="phong"``: kd = ka = D, ks = S, Blinn-Phong t = 2 / alpha^2 - 2 with
  alpha = (1 - g)^2 (the roughness-to-exponent map of the metallic-roughness path, roughness
  1 - g); with a texture, one exponent from the median glossiness (named in the warning).
* ``reflectance="pbr"``: converted to the GGX model's base colour, metallic and roughness
  1 - g per texel, metallic m solving ``0.04 (1 - m)^2 + d m = s (1 - m)`` for the
  brightnesses d of D and s of S (the diffuse ``base (1 - m) = D`` and the reflectance
  at normal incidence ``0.04 (1 - m) + base m = S`` of the metallic model), 0 where
  s < 0.04; base colour ``D / (1 - m)`` blended into ``(S - 0.04 (1 - m)) / m`` by m^2.
  Exact for dielectrics of specular 0.04 and for pure metals (D = 0); approximated
  otherwise (a coloured or other-than-0.04 dielectric specular has no metallic-roughness
  counterpart), which the warning says.
"""

from __future__ import annotations

import io
import math
import os
from types import SimpleNamespace
from urllib.parse import unquote

import numpy as np

from .gltfgeometry import _buffers
from .wrapped import DIELECTRIC_F0, Wrapped, alpha_channel, alpha_mask, resample, shininess_of_roughness

__all__ = ["from_spec_gloss", "gltf_image", "metal_rough_of_spec_gloss"]

_LUMA = np.array([0.299, 0.587, 0.114])  # perceived brightness weights (squared channels, as is usual here)


def gltf_image(ctx, texinfo):
    """The PIL image a glTF textureInfo names, decoded from the file (a file next to it, a data
    URI or a buffer view), once per image; None without one or where the file is missing
    (that file is named with the file's other missing references); a str saying why for an
    image Pillow cannot read."""
    from PIL import Image

    js = ctx.gltf or {}
    try:
        tex = js["textures"][texinfo["index"]]
        src = ((tex.get("extensions") or {}).get("EXT_texture_webp") or {}).get("source", tex.get("source"))
        img = js["images"][src]
    except (KeyError, IndexError, TypeError):
        return None
    key = ("gltf-image", src)
    if key not in ctx.cache:
        uri, data = img.get("uri"), None
        if isinstance(uri, str) and uri.startswith("data:"):
            import base64

            data = base64.b64decode(uri.split(",", 1)[1])
        elif isinstance(uri, str):
            full = os.path.join(ctx.base_dir, unquote(uri))
            if os.path.isfile(full):
                with open(full, "rb") as fh:
                    data = fh.read()
        elif "bufferView" in img:
            if "buffers" not in ctx.cache:
                ctx.cache["buffers"] = _buffers(ctx.path, js)
            view = js["bufferViews"][img["bufferView"]]
            start = view.get("byteOffset", 0)
            data = ctx.cache["buffers"][view["buffer"]][start:start + view["byteLength"]]
        image = None
        if data is not None:
            try:
                image = Image.open(io.BytesIO(data))
                image.load()
            except Exception as exc:  # Pillow raises many kinds for a broken image: named, drawn without it
                image = f"images[{src}] of {os.path.basename(ctx.path)}: not a readable image ({exc})"
        ctx.cache[key] = image
    return ctx.cache[key]


def _checked(ext: dict, key: str, n: int, default, where: str) -> np.ndarray:
    v = ext.get(key, default)
    vals = v if isinstance(v, list) else [v]
    if len(vals) != n or not all(isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)
                                 and 0.0 <= x <= 1.0 for x in vals):
        raise ValueError(f"{where}.{key}: expected {n} number(s) in [0, 1], got {v!r}")
    return np.array(vals, np.float64)


def metal_rough_of_spec_gloss(diffuse, specular, glossiness):
    """Metallic-roughness parameters of specular-glossiness ones (see the module docstring).

    Parameters
    ----------
    diffuse, specular : (..., 3) float
        Linear diffuse and specular colours in [0, 1].
    glossiness : (...) float
        In [0, 1].

    Returns
    -------
    base : (..., 3) float64
        Base colour in [0, 1].
    metallic, roughness : (...) float64
        In [0, 1]; roughness = 1 - glossiness.
    """
    d3, s3 = np.asarray(diffuse, np.float64), np.asarray(specular, np.float64)
    d, s = np.sqrt(d3 ** 2 @ _LUMA), np.sqrt(s3 ** 2 @ _LUMA)
    a, b, c = DIELECTRIC_F0, d + s - 2.0 * DIELECTRIC_F0, DIELECTRIC_F0 - s
    m = (-b + np.sqrt(np.maximum(b * b - 4.0 * a * c, 0.0))) / (2.0 * a)
    m = np.where(s < DIELECTRIC_F0, 0.0, np.clip(m, 0.0, 1.0))
    mm = m[..., None]
    from_d = d3 / np.maximum(1.0 - mm, 1e-6)
    from_s = (s3 - DIELECTRIC_F0 * (1.0 - mm)) / np.maximum(mm, 1e-6)
    base = np.clip(from_d * (1.0 - mm ** 2) + from_s * mm ** 2, 0.0, 1.0)
    return base, m, 1.0 - np.asarray(glossiness, np.float64)


def from_spec_gloss(mat, js: dict, ext: dict, name: str, lost: list, ctx) -> dict:
    """A ``KHR_materials_pbrSpecularGlossiness`` material's :class:`Material` keywords (colours,
    specular, alpha mask); the core's normal, occlusion and emissive maps are from_pbr's."""
    mats = (ctx.gltf or {}).get("materials", []) or []
    index = next((i for i, m in enumerate(mats) if m is js), None)
    where = f"{os.path.basename(ctx.path)}: materials[{index}].extensions.KHR_materials_pbrSpecularGlossiness"
    diffuse = _checked(ext, "diffuseFactor", 4, [1.0, 1.0, 1.0, 1.0], where)
    spec = _checked(ext, "specularFactor", 3, [1.0, 1.0, 1.0], where)
    gloss = float(_checked(ext, "glossinessFactor", 1, 1.0, where)[0])
    d_info, sg_info = ext.get("diffuseTexture"), ext.get("specularGlossinessTexture")
    dtex, sgtex = gltf_image(ctx, d_info), gltf_image(ctx, sg_info)
    for slot, img in (("diffuseTexture", dtex), ("specularGlossinessTexture", sgtex)):
        if isinstance(img, str):
            lost.append(f"{slot}: {img} (drawn without it)")
    dtex, sgtex = (None if isinstance(i, str) else i for i in (dtex, sgtex))
    d_wraps, sg_wraps = ctx.sampler(d_info)[:2], ctx.sampler(sg_info)[:2]
    shim = SimpleNamespace(alphaMode=js.get("alphaMode"), baseColorTexture=dtex)
    kw = alpha_mask(shim, js, diffuse, name, lost, ctx, d_wraps)
    d_texels = ctx.linear(dtex, f"{name}.diffuseTexture") if dtex is not None else None
    s_texels = ctx.linear(sgtex, f"{name}.specularGlossinessTexture") if sgtex is not None else None
    g_texels = None
    if sgtex is not None:
        a = alpha_channel(sgtex)[::-1]  # row 0 at v = 0, as the decoded texels
        g_texels = a.astype(np.float64) / (np.iinfo(a.dtype).max if a.dtype.kind in "ui" else 1.0)
    if ctx.reflectance == "pbr":
        kw.update(_as_ggx(diffuse[:3], spec, gloss, (d_texels, s_texels, g_texels), name, ctx,
                          d_wraps if dtex is not None else sg_wraps))
        lost.append("KHR_materials_pbrSpecularGlossiness: converted to metallic-roughness (approximated: exact "
                    "for a specular of 0.04 grey or a black diffuse)")
        return kw
    rgb = diffuse[:3]
    kw.update(kd=rgb, ka=rgb, ks=spec, shininess=shininess_of_roughness(1.0 - gloss))
    if d_texels is not None:
        kw["kd_map"] = kw["ka_map"] = ctx.wrapped(("sg-diffuse", ctx.image_key(dtex), *d_wraps), lambda: Wrapped(
            d_texels, d_wraps[0], d_wraps[1], f"{name}.diffuseTexture", srgb=True))
    if s_texels is not None:
        kw["ks_map"] = ctx.wrapped(("sg-specular", ctx.image_key(sgtex), *sg_wraps), lambda: Wrapped(
            s_texels, sg_wraps[0], sg_wraps[1], f"{name}.specularGlossinessTexture", srgb=True))
        g_med = gloss * float(np.median(g_texels))
        kw["shininess"] = shininess_of_roughness(1.0 - g_med)
        if np.ptp(g_texels) > 0:
            lost.append(f"specularGlossinessTexture: glossiness per texel drawn with one exponent, from the "
                        f"median glossiness {g_med:.3g} (approximated)")
    return kw


def _as_ggx(diffuse, spec, gloss: float, texels, name: str, ctx, wraps) -> dict:
    """GGX keywords (base colour map, metallic-roughness map or factors) converted per texel."""
    d_t, s_t, g_t = texels
    if d_t is None and s_t is None:
        base, m, r = metal_rough_of_spec_gloss(diffuse, spec, gloss)
        return {"specular": "ggx", "kd": base, "ka": base, "metallic": float(m), "roughness": float(r)}
    key = ("sg-ggx", id(d_t), id(s_t), tuple(diffuse), tuple(spec), gloss)
    if key not in ctx.cache:
        shape = (d_t if d_t is not None else s_t).shape[:2]
        if s_t is not None and s_t.shape[:2] != shape:
            s_t, g_t = resample(s_t, shape), resample(g_t[..., None], shape)[..., 0]
        dd = diffuse * (d_t if d_t is not None else 1.0)
        ss = spec * (s_t if s_t is not None else 1.0)
        gg = gloss * (g_t if g_t is not None else 1.0)
        base, m, r = metal_rough_of_spec_gloss(np.broadcast_to(dd, shape + (3,)), np.broadcast_to(ss, shape + (3,)),
                                               np.broadcast_to(gg, shape))
        mr = np.stack([np.zeros(shape), r, m], axis=-1).astype(np.float32)
        ctx.cache[key] = (Wrapped(base.astype(np.float32), wraps[0], wraps[1], f"{name}.diffuse(converted)", srgb=True),
                          Wrapped(mr, wraps[0], wraps[1], f"{name}.specularGlossiness(converted)"), d_t, s_t)
    base_w, mr_w = ctx.cache[key][:2]
    return {"specular": "ggx", "kd": 1.0, "ka": 1.0, "kd_map": base_w, "ka_map": base_w, "metallic": 1.0,
            "roughness": 1.0, "metallic_roughness_map": mr_w}
