"""glTF texture maps before they meet a mesh: :class:`Wrapped` (texels, a sampler's wrap per
axis and a ``KHR_texture_transform``), the transform read from a textureInfo, and the
glossiness / roughness to Blinn-Phong exponent map the glTF mappers share.

``KHR_texture_transform`` is applied to the mesh's UVs once, at load: when every map of a
material has the same transform (the common case: an atlas region, a tiling), moving the
UVs is exact and costs the renderer nothing. Maps with different transforms would need a
UV set each, which the renderer does not have: :func:`transform_maps` then draws every map
with the first map's transform and names the others in the load warning. The same holds for
the UV set a map reads (``texCoord``): a material whose maps all read ``TEXCOORD_1`` is drawn
with that set as the mesh's UVs; maps reading different sets are named in the warning.
"""

from __future__ import annotations

import math

import numpy as np

from .texture import Texture

__all__ = ["Wrapped", "uv_transform", "apply_uv", "transform_maps", "UV_SET", "MAP_SLOTS", "alpha_mask", "alpha_channel", "resample", "shininess_of_roughness"]

MAX_SHININESS = 4096.0  # repeated squaring's limit (shading.illumination._power)
DIELECTRIC_F0 = 0.04  # a dielectric's Fresnel reflectance at normal incidence
_PAD_LIMIT = 16  # a clamped axis is padded to at most this many times its texels (else approximated)
_FLIP = np.array([[1.0, 0.0, 0.0], [0.0, -1.0, 1.0], [0.0, 0.0, 1.0]])  # glTF's v (down) <-> the mesh's v (up)

# The textureInfo slots of a glTF material (core, then KHR_materials_pbrSpecularGlossiness) and the
# Material keywords each may fill; what a slot's map lands in depends on the mapping (from_pbr).
MAP_SLOTS = {
    "baseColorTexture": ("kd_map", "ka_map", "ks_map", "alpha_map"),
    "metallicRoughnessTexture": ("kd_map", "ks_map", "metallic_roughness_map"),
    "diffuseTexture": ("kd_map", "ka_map", "alpha_map", "metallic_roughness_map"),
    "specularGlossinessTexture": ("ks_map", "kd_map", "metallic_roughness_map"),
    "normalTexture": ("normal_map",),
    "occlusionTexture": ("ao_map",),
    "emissiveTexture": ("ke_map",),
}


def shininess_of_roughness(r) -> float:
    """Blinn-Phong exponent of a GGX lobe of roughness ``r`` (alpha = r^2; Walter et al. 2007)."""
    alpha = max(float(r) ** 2, 1e-6)
    return float(np.clip(2.0 / alpha ** 2 - 2.0, 1.0, MAX_SHININESS))


def uv_transform(texinfo, where: str):
    """A textureInfo's ``KHR_texture_transform`` as ``(matrix, texCoord)``.

    Parameters
    ----------
    texinfo : dict or None
        The glTF textureInfo.
    where : str
        Its place in the file (``"Box.gltf: materials[0].normalTexture"``), for errors.

    Returns
    -------
    matrix : (2, 3) float64 or None
        The affine map of the mesh's UVs (``v`` up, as the loader keeps them) to the
        texture's: the spec's ``T * R * S`` conjugated by the flip of ``v``. The rotation
        is the one the spec's text, sample model and implementations agree on, ``u' = cos u
        + sin v``, ``v' = -sin u + cos v`` in glTF's UV space (``v`` down; its GLSL listing
        has it transposed: KhronosGroup/glTF issue 1563). None without a transform.
    texCoord : int
        The UV set the map reads (the extension's ``texCoord`` overrides the textureInfo's).

    Raises
    ------
    ValueError
        ``offset``, ``scale`` not two finite numbers, ``rotation`` not a finite number,
        ``texCoord`` not an integer >= 0 (naming ``where`` and the field).
    """
    if not isinstance(texinfo, dict):
        return None, 0
    tex_coord = texinfo.get("texCoord", 0)
    ext = (texinfo.get("extensions") or {}).get("KHR_texture_transform")
    if ext is None:
        return None, tex_coord if isinstance(tex_coord, int) else 0
    where = f"{where}.extensions.KHR_texture_transform"
    if not isinstance(ext, dict):
        raise ValueError(f"{where}: expected an object, got {ext!r}")

    def numbers(key, default, n):
        v = ext.get(key, default)
        vals = v if isinstance(v, list) else [v]
        if len(vals) != n or not all(isinstance(x, (int, float)) and not isinstance(x, bool)
                                     and math.isfinite(x) for x in vals):
            raise ValueError(f"{where}.{key}: expected {n} finite number(s), got {v!r}")
        return [float(x) for x in vals]

    (ou, ov), (su, sv), (rot,) = numbers("offset", [0, 0], 2), numbers("scale", [1, 1], 2), numbers("rotation", 0, 1)
    tex_coord = ext.get("texCoord", tex_coord)
    if isinstance(tex_coord, bool) or not isinstance(tex_coord, int) or tex_coord < 0:
        raise ValueError(f"{where}.texCoord: expected an integer >= 0, got {tex_coord!r}")
    c, s = math.cos(rot), math.sin(rot)
    trs = np.array([[c * su, s * sv, ou], [-s * su, c * sv, ov], [0.0, 0.0, 1.0]])
    m = (_FLIP @ trs @ _FLIP)[:2]
    return (None if np.array_equal(m, np.eye(3)[:2]) else m), tex_coord


def apply_uv(uvs: np.ndarray, matrix: np.ndarray) -> np.ndarray:
    """``uvs`` (N, 2) through a (2, 3) affine ``matrix``: (N, 2) float64."""
    uvs = np.asarray(uvs, np.float64)
    return uvs @ matrix[:, :2].T + matrix[:, 2]


UV_SET = "uv_set"  # transform_maps' note to load_models: the TEXCOORD_n every map of the material reads


def transform_maps(kw: dict, slots: dict, where: str, lost: list, cache: dict) -> None:
    """Attach the materials' ``KHR_texture_transform`` to its maps in ``kw`` (in place).

    ``slots`` maps a slot name (:data:`MAP_SLOTS`) to its textureInfo; a slot counts where
    one of its keywords holds a :class:`Wrapped`. One transform for every such slot: each
    map reads the mesh's UVs through it. Several: the first slot's is used for every map
    and the rest are named in ``lost``. The UV set (``texCoord``, the extension's overriding
    the textureInfo's) likewise: when every map reads set ``n > 0``, ``kw[UV_SET] = n`` asks
    the loader for ``TEXCOORD_n`` as the mesh's UVs; maps reading different sets are named
    in ``lost`` (every map then reads the first map's set).
    """
    found = []
    for slot, info in slots.items():
        if not isinstance(info, dict) or not any(isinstance(kw.get(k), Wrapped) for k in MAP_SLOTS[slot]):
            continue
        matrix, tex_coord = uv_transform(info, f"{where}.{slot}")
        found.append((slot, matrix, tex_coord))
    if not found:
        return
    first_slot, matrix, first_set = found[0]
    differ = [s for s, m, _ in found[1:] if not (m is None and matrix is None
                                                 or m is not None and matrix is not None and np.allclose(m, matrix))]
    if differ:
        lost.append(f"KHR_texture_transform: {', '.join(differ)} transformed otherwise than {first_slot} "
                    f"(one UV set per mesh: every map drawn with {first_slot}'s transform)")
    other_sets = [f"{s} (TEXCOORD_{n})" for s, _, n in found[1:] if n != first_set]
    if other_sets:
        lost.append(f"{where}: {', '.join(other_sets)} read another UV set than {first_slot} (TEXCOORD_{first_set}); "
                    f"one UV set per mesh: every map drawn with TEXCOORD_{first_set}")
    if first_set:
        kw[UV_SET] = (first_set, first_slot)
    if matrix is None:
        return
    for key, value in list(kw.items()):
        if isinstance(value, Wrapped):
            ck = ("uv", id(value), matrix.tobytes())
            if ck not in cache:
                cache[ck] = (value.transformed(matrix), value)  # the original kept alive with its id
            kw[key] = cache[ck][0]


class Wrapped:
    """Linear texels (row 0 at v = 0) with a glTF sampler's wrap per axis, and optionally a
    (2, 3) UV transform, made a :class:`Texture` (and the mesh's UVs moved) once the mesh's
    UVs are known."""

    def __init__(self, texels, wrap_s: str, wrap_t: str, name: str, uv=None, srgb: bool = False):
        self.texels, self.wrap_s, self.wrap_t, self.name, self.uv = texels, wrap_s, wrap_t, name, uv
        self.srgb = srgb  # colours decoded from sRGB: the Texture keeps the marker (Texture.decoded_from_srgb)
        self._base = None

    def transformed(self, uv) -> "Wrapped":
        """The same texels (and the same decoded Texture) read through the UV transform ``uv``."""
        w = Wrapped(self.texels, self.wrap_s, self.wrap_t, self.name, uv, self.srgb)
        w._base = self._base or self
        return w

    @property
    def _pads(self) -> bool:
        return "clamp" in (self.wrap_s, self.wrap_t) and self.wrap_s != self.wrap_t

    @property
    def needs_uvs(self) -> bool:
        return self._pads or self.uv is not None

    def _shared(self):
        base = self._base or self
        if getattr(base, "_shared_texture", None) is None:  # one Texture for every mesh that shares the picture
            base._shared_texture = base._texture(None)
        return base._shared_texture

    def texture(self, uvs=None):
        """``(Texture, uvs or None, note or None)``: the UVs transformed first (a UV transform);
        mirrored repeat is the repeat of the image and its mirror image side by side, at half
        the tiling (exact, bilinear and all); clamp on one axis only pads that axis with copies
        of its edge texels over the UVs' range and moves the UVs onto the padded image (exact
        away from the mip levels' edges)."""
        moved = None
        if self.uv is not None and uvs is not None and len(uvs):
            uvs = moved = apply_uv(uvs, self.uv)
        if not self._pads:
            tex, _, note = self._shared()
            return tex, moved, note
        tex, new_uvs, note = self._texture(uvs)
        return tex, (moved if new_uvs is None else new_uvs), note

    def _texture(self, uvs):
        if self.wrap_s == self.wrap_t == "clamp":
            return Texture(self.texels, wrap="clamp", name=self.name, decoded_from_srgb=self.srgb), None, None
        t, tiling, new_uvs, note = self.texels, [1.0, 1.0], None, None
        if self.wrap_s == "mirror":
            t = np.concatenate([t, t[:, ::-1]], axis=1)
            tiling[0] = 0.5
        if self.wrap_t == "mirror":
            t = np.concatenate([t, t[::-1]], axis=0)
            tiling[1] = 0.5
        for axis, mode in ((0, self.wrap_s), (1, self.wrap_t)):
            if mode != "clamp":
                continue
            tax = 1 - axis  # u runs along the texel columns, v along the rows
            n = t.shape[tax]
            c = uvs[:, axis] if uvs is not None and len(uvs) else np.zeros(1)
            lo, hi = min(0.0, float(c.min())), max(1.0, float(c.max()))
            n_lo, n_hi = int(math.ceil(-lo * n)) + 1, int(math.ceil((hi - 1.0) * n)) + 1
            total = n + n_lo + n_hi
            if uvs is None or total > _PAD_LIMIT * n:
                note = (f"{self.name}: clamp on {'uv'[axis]} only, with repeat on the other axis, shaded as "
                        "repeat (the UVs span too far to pad)")
                continue
            first = np.take(t, [0], axis=tax)
            last = np.take(t, [n - 1], axis=tax)
            t = np.concatenate([np.repeat(first, n_lo, axis=tax), t, np.repeat(last, n_hi, axis=tax)], axis=tax)
            if new_uvs is None:
                new_uvs = np.array(uvs, np.float64)
            new_uvs[:, axis] = (c * n + n_lo) / total
        return (Texture(np.ascontiguousarray(t), tiling=tuple(tiling), name=self.name, decoded_from_srgb=self.srgb),
                new_uvs, note)


_BLEND_CUTOFF = 0.5  # BLEND drawn as MASK at half coverage: each point is whichever of opaque / clear is nearer


def alpha_mask(mat, js: dict, base, name: str, lost: list, ctx, wraps) -> dict:
    """glTF's alphaMode as :class:`Material` keywords: ``MASK`` keeps the base colour's alpha
    (factor times texture alpha) as ``alpha_map`` with ``alphaCutoff`` (default 0.5); ``BLEND``
    is approximated as ``MASK`` at 0.5 (noted in ``lost``); ``OPAQUE`` ignores alpha, as the spec says."""
    mode = getattr(mat, "alphaMode", None) or js.get("alphaMode") or "OPAQUE"
    if mode == "OPAQUE":
        return {}
    if mode == "BLEND":
        cutoff = _BLEND_CUTOFF
        mname = js.get("name", getattr(mat, "name", None))
        lost.append(f"material {mname!r}: alphaMode BLEND: approximated as MASK with cutoff 0.5 (points at "
                    "least half opaque drawn opaque, the others see-through; no partial transparency)")
    else:
        cutoff = js.get("alphaCutoff", getattr(mat, "alphaCutoff", None))
        cutoff = 0.5 if cutoff is None else float(cutoff)
    factor = float(base[3]) if len(base) > 3 else 1.0
    tex = getattr(mat, "baseColorTexture", None)
    if tex is None and factor >= cutoff:
        return {}  # opaque everywhere: no mask to test
    key = ("alpha", ctx.image_key(tex), factor, wraps)
    if key not in ctx.cache:
        if tex is None:
            texels = np.full((1, 1, 3), factor, np.float32)
        else:
            a = alpha_channel(tex)
            texels = Texture.from_array(a, srgb=False, name=f"{name}.baseColorTexture.alpha").texels * factor
        ctx.cache[key] = Wrapped(np.ascontiguousarray(texels, np.float32), wraps[0], wraps[1],
                                 f"{name}.alpha")
    return {"alpha_map": ctx.cache[key], "alpha_cutoff": cutoff}


def alpha_channel(image) -> np.ndarray:
    """(h, w) uint8 or float alpha of an image (PIL or array), as stored (top row first); 255 where it has none."""
    if hasattr(image, "convert"):
        if image.mode in ("RGBA", "LA", "PA", "P", "RGBa", "La") or "transparency" in getattr(image, "info", {}):
            return np.asarray(image.convert("RGBA"))[..., 3]
        return np.full((image.size[1], image.size[0]), 255, np.uint8)
    a = np.asarray(image)
    if a.ndim == 3 and a.shape[2] in (2, 4):
        return a[..., -1]
    one = np.iinfo(a.dtype).max if a.dtype.kind in "ui" else 1.0
    return np.full(a.shape[:2], one, a.dtype)



def resample(a: np.ndarray, shape) -> np.ndarray:
    """``a`` (h, w, c) on an (H, W) grid, nearest texel centre (both cover the unit square)."""
    h, w = a.shape[:2]
    rows = np.minimum(((np.arange(shape[0]) + 0.5) * h / shape[0]).astype(np.int64), h - 1)
    cols = np.minimum(((np.arange(shape[1]) + 0.5) * w / shape[1]).astype(np.int64), w - 1)
    return a[rows][:, cols]
