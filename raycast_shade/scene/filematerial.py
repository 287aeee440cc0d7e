"""A file's materials in the lecture's terms: the MTL, trimesh and glTF mappers behind
:func:`raycast_shade.load_models` (the mapping table is in ``docs/textures.md``), and
:class:`FileContext`, what the loader learns from the file itself (:mod:`.fileparse`).
"""

from __future__ import annotations

import math
import os

import numpy as np

from . import fileparse
from .material import Material
from .specgloss import from_spec_gloss
from .texture import Texture
from .wrapped import DIELECTRIC_F0 as _DIELECTRIC_F0, MAX_SHININESS as _MAX_SHININESS, Wrapped, transform_maps
from .wrapped import shininess_of_roughness as _shininess
from .wrapped import alpha_mask as _alpha_mask, resample as _resample

__all__ = ["FileContext", "Wrapped", "from_mtl_cached", "from_simple", "from_pbr", "is_placeholder"]

# MTL keys with no effect in the file's own model when they hold these values.
_MTL_HARMLESS = {"d": 1.0, "tr": 0.0}
_MTL_READ = ("kd", "ka", "ks", "ke", "ns", "illum", "ni", "map_kd", "map_ka", "map_ks", "map_ke", "newmtl")


def _rgb(value) -> np.ndarray:
    v = np.atleast_1d(np.asarray(value, np.float64)).ravel()
    return np.repeat(v[:1], 3) if v.size == 1 else v[:3]


def _numbers(tokens):
    try:
        return [float(t) for t in tokens]
    except (TypeError, ValueError):
        return None


class FileContext:
    """What the file itself says beyond trimesh's reading: references, samplers, colours;
    plus the textures decoded so far (one per source image, however many meshes share it)."""

    def __init__(self, path: str | None, base: str = "", base_dir: str = ".", gltf: dict | None = None,
                 reflectance: str = "phong"):
        """``path=None``: no file to read (a trimesh visual on its own), references relative to ``base_dir``;
        ``gltf``: the JSON checked by :func:`.filecheck.check_mesh_file`; ``reflectance``: see load_models."""
        self.path, self.base = path or "", base
        self.base_dir = os.path.dirname(os.path.abspath(path)) if path else base_dir
        self.ext = os.path.splitext(path)[1].lower() if path else ""
        self.undefined = []
        self.missing = []  # "name (where)" of referenced files that are absent
        self.mtl = {}  # OBJ: name -> fileparse.MtlMaterial
        self.usemtl = []
        self.gltf = gltf
        self._off = None
        self.reflectance, self.cache = reflectance, {}
        self._keep = []  # the objects whose id() keys the cache stay alive with it
        if self.ext == ".obj":
            self._obj()
        elif self.ext in (".gltf", ".glb"):
            self._gltf()
        elif self.ext == ".ply":
            for name in fileparse.ply_texture_files(path):
                if not os.path.exists(os.path.join(self.base_dir, name)):
                    self.missing.append(f"{name} (TextureFile in {os.path.basename(path)}'s header)")

    @property
    def off(self):
        """An OFF file's colours (:func:`.fileparse.off_colors`; None for other files), read when first asked
        for: after the geometry, so a broken file is named by its reader as ``Mesh.load`` names it."""
        if self.ext == ".off" and self._off is None:
            self._off = fileparse.off_colors(self.path)
        return self._off

    def _obj(self):
        mtllibs, self.usemtl = fileparse.obj_references(self.path)
        me = os.path.basename(self.path)
        for names, line in mtllibs:
            files = [names] if os.path.exists(os.path.join(self.base_dir, names)) else names.split()
            for name in files:
                full = os.path.join(self.base_dir, name)
                if not os.path.isfile(full):
                    self.missing.append(f"{name} (mtllib, {me}:{line})")
                    continue
                for key, mat in fileparse.parse_mtl(full).items():
                    self.mtl.setdefault(key, mat)
        undefined = {}
        for name, line in self.usemtl:
            if name not in self.mtl:
                undefined.setdefault(name, line)
        self.undefined = [f"usemtl {n} ({me}:{line})" for n, line in undefined.items()]

    def _gltf(self):
        if self.gltf is None:
            self.gltf = fileparse.gltf_header(self.path)
        if not isinstance(self.gltf, dict):  # unreadable: trimesh's reading names why
            self.gltf = None
            return
        me = os.path.basename(self.path)
        self._check_gltf_materials()
        for i, buf in enumerate(self.gltf.get("buffers", []) or []):
            uri = buf.get("uri") if isinstance(buf, dict) else None
            if isinstance(uri, str) and not uri.startswith("data:"):
                from urllib.parse import unquote

                if not os.path.isfile(os.path.join(self.base_dir, unquote(uri))):
                    raise ValueError(f"{me}: buffers[{i}]: the file {unquote(uri)} is missing (it holds the "
                                     "geometry: nothing can be drawn without it)")
        for i, img in enumerate(self.gltf.get("images", []) or []):
            uri = img.get("uri") if isinstance(img, dict) else None
            if isinstance(uri, str) and not uri.startswith("data:"):
                from urllib.parse import unquote

                if not os.path.isfile(os.path.join(self.base_dir, unquote(uri))):
                    self.missing.append(f"{unquote(uri)} (images[{i}] of {me})")

    def _check_gltf_materials(self):
        """Every material factor the mapping reads, checked against the spec's range, naming the field."""
        me = os.path.basename(self.path)
        for i, m in enumerate(self.gltf.get("materials", []) or []):
            if not isinstance(m, dict):
                raise ValueError(f"{me}: materials[{i}]: expected an object, got {type(m).__name__}")
            pbr = m.get("pbrMetallicRoughness") or {}
            for where, value, n, hi in (
                    ("pbrMetallicRoughness.baseColorFactor", pbr.get("baseColorFactor"), 4, 1.0),
                    ("pbrMetallicRoughness.metallicFactor", pbr.get("metallicFactor"), 1, 1.0),
                    ("pbrMetallicRoughness.roughnessFactor", pbr.get("roughnessFactor"), 1, 1.0),
                    ("emissiveFactor", m.get("emissiveFactor"), 3, 1.0),
                    ("occlusionTexture.strength", (m.get("occlusionTexture") or {}).get("strength")
                     if isinstance(m.get("occlusionTexture"), dict) else None, 1, 1.0),
                    ("extensions.KHR_materials_emissive_strength.emissiveStrength",
                     ((m.get("extensions") or {}).get("KHR_materials_emissive_strength") or {}).get("emissiveStrength"),
                     1, math.inf),
                    ("alphaCutoff", m.get("alphaCutoff"), 1, math.inf)):
                if value is None:
                    continue
                vals = value if isinstance(value, list) else [value]
                ok = len(vals) == n and all(isinstance(v, (int, float)) and not isinstance(v, bool)
                                            and math.isfinite(v) and 0.0 <= v <= hi for v in vals)
                if not ok:
                    rng = f"[0, {hi:g}]" if math.isfinite(hi) else ">= 0"
                    raise ValueError(f"{me}: materials[{i}].{where}: expected {n} number(s) in {rng}, got {value!r}")
            mode = m.get("alphaMode", "OPAQUE")
            if mode not in ("OPAQUE", "MASK", "BLEND"):
                raise ValueError(f"{me}: materials[{i}].alphaMode: expected OPAQUE, MASK or BLEND, got {mode!r}")

    def gltf_material(self, mat):
        """The file's JSON for a trimesh PBRMaterial (by name, then by its factors), or None."""
        mats = (self.gltf or {}).get("materials", []) or []
        name = getattr(mat, "name", None)
        named = [m for m in mats if isinstance(m, dict) and name is not None and m.get("name") == name]
        if len(named) == 1:
            return named[0]
        has_tex = getattr(mat, "baseColorTexture", None) is not None
        candidates = named or [m for m in mats if isinstance(m, dict)]
        sg = "KHR_materials_pbrSpecularGlossiness"  # trimesh's base colour then comes from its diffuse texture
        candidates = [m for m in candidates
                      if ("baseColorTexture" in (m.get("pbrMetallicRoughness") or {})
                          or "diffuseTexture" in ((m.get("extensions") or {}).get(sg) or {})) == has_tex]
        return candidates[0] if candidates else None

    def sampler(self, texinfo):
        """(wrap_s, wrap_t, notes) of a glTF textureInfo (repeat, clamp or mirror)."""
        notes = []
        if not isinstance(texinfo, dict) or self.gltf is None:
            return "repeat", "repeat", notes
        try:
            tex = self.gltf["textures"][texinfo["index"]]
            smp = self.gltf["samplers"][tex["sampler"]] if "sampler" in tex else {}
        except (KeyError, IndexError, TypeError):
            return "repeat", "repeat", notes
        return (fileparse.GL_WRAPS.get(smp.get("wrapS", 10497), "repeat"),
                fileparse.GL_WRAPS.get(smp.get("wrapT", 10497), "repeat"), notes)

    def image_key(self, image):
        """An image's identity by content (a file may store one picture several times, and
        trimesh may hand one image object to several materials): its mode, size and digest."""
        if image is None:
            return None
        memo = self.cache.setdefault("ids", {})
        if id(image) not in memo:
            import hashlib

            self._keep.append(image)
            raw = image.tobytes() if hasattr(image, "tobytes") else np.ascontiguousarray(image).tobytes()
            memo[id(image)] = (getattr(image, "mode", None), getattr(image, "size", np.shape(image)),
                               hashlib.sha1(raw).hexdigest())
        return memo[id(image)]

    def linear(self, image, name: str, srgb: bool = True):
        """An image's linear texels (row 0 at v = 0), decoded once per picture."""
        key = ("linear", self.image_key(image), srgb)
        if key not in self.cache:
            self.cache[key] = Texture.from_array(image, srgb=srgb, alpha="ignore", name=name).texels
        return self.cache[key]

    def wrapped(self, key, build):
        """A :class:`Wrapped` or :class:`Texture` built once per key."""
        if key not in self.cache:
            self.cache[key] = build()
        return self.cache[key]


def is_placeholder(mat) -> bool:
    """trimesh's stand-in for "no material" (UVs without one): a 2 x 2 image of grey 100."""
    image = getattr(mat, "image", None)
    if image is None or getattr(mat, "kwargs", None):
        return False
    a = np.asarray(image.convert("RGBA") if hasattr(image, "convert") else image)
    return a.shape[:2] == (2, 2) and bool(np.all(a.reshape(-1, a.shape[-1])[:, :4] == (100, 100, 100, 255)))


def _map_options(tokens, where: str, lost: list):
    """``(file name, Texture keywords)`` of the tokens after ``map_Kd``: ``-s u [v [w]]`` is the
    tiling, ``-clamp on|off`` the wrap; other options are named in ``lost``."""
    tokens = list(tokens)
    kw, i = {}, 0
    while i < len(tokens) - 1 and tokens[i].startswith("-"):
        opt = tokens[i].lower()
        if opt == "-s":
            nums = []
            i += 1
            while i < len(tokens) - 1 and _numbers([tokens[i]]) is not None and len(nums) < 3:
                nums.append(float(tokens[i]))
                i += 1
            if not nums or not all(math.isfinite(n) and n > 0 for n in nums):
                raise ValueError(f"{where}: -s expects 1 to 3 numbers > 0, got {nums}")
            kw["tiling"] = (nums[0], nums[1] if len(nums) > 1 else nums[0])
            continue
        if opt == "-clamp":
            flag = tokens[i + 1].lower()
            if flag not in ("on", "off"):
                raise ValueError(f"{where}: -clamp expects on or off, got {tokens[i + 1]!r}")
            kw["wrap"] = "clamp" if flag == "on" else "repeat"
            i += 2
            continue
        # Options with one value or three (-o, -t) or none: step over the numbers they take.
        j = i + 1
        while j < len(tokens) - 1 and (_numbers([tokens[j]]) is not None or tokens[j].lower() in ("on", "off")):
            j += 1
        lost.append(f"{where} option {' '.join(tokens[i:j])}")
        i = j
    return " ".join(tokens[i:]), kw


def _from_mtl(mat, ctx: FileContext, lost: list) -> dict:
    """OBJ/MTL, from the MTL file itself: every value checked, naming the file and line."""
    f = mat.fields
    kw = {"name": mat.name}
    for key in ("kd", "ka", "ks", "ke"):
        if key in f:
            kw[key] = fileparse.mtl_color(mat, key)
    if "ns" in f:
        ns = fileparse.mtl_number(mat, "ns")
        if ns > 0:
            kw["shininess"] = min(ns, _MAX_SHININESS)
        else:
            lost.append(f"Ns {ns:g} at {mat.where('ns')} (the shininess must be > 0; kept {Material().shininess:g})")
    if "illum" in f:
        code = fileparse.mtl_number(mat, "illum")
        if code in (0, 1):
            kw["ks"] = 0.0  # colour (and ambient) only: no highlight
        elif code != 2:
            lost.append(f"illum {code:g} at {mat.where('illum')} (reflection/refraction models; shaded as illum 2)")
    if "ni" in f:
        fileparse.mtl_number(mat, "ni")  # refraction index: only meaningful with transparency, reported there
    for key in ("map_kd", "map_ka", "map_ks", "map_ke"):
        if key not in f:
            continue
        where = f"{mat.where(key)}: {key}"
        name, opts = _map_options(f[key][0], where, lost)
        full = os.path.normpath(os.path.join(ctx.base_dir, name.replace("\\", "/")))
        if not name:
            raise ValueError(f"{where}: no image file named")
        if not os.path.isfile(full):
            ctx.missing.append(f"{name} ({key}, {mat.where(key)})")
            continue

        def build(full=full, opts=opts, key=key):
            try:
                return Texture.from_image(full, name=f"{mat.name}.{key}", **opts)
            except ValueError as exc:
                return exc

        tex = ctx.wrapped(("mtl", full, tuple(sorted(opts.items()))), build)
        if isinstance(tex, ValueError):
            lost.append(f"{key} {name} at {mat.where(key)}: not a readable image ({tex})")
            continue
        kw[key[4:] + "_map"] = tex
    for key, (tokens, line) in f.items():
        if key in _MTL_READ:
            continue
        nums = _numbers(tokens)
        if key in _MTL_HARMLESS and nums and all(n == _MTL_HARMLESS[key] for n in nums):
            continue
        lost.append(f"{key} {' '.join(tokens)}".strip() + f" at {os.path.basename(mat.path)}:{line}")
    return kw


def from_mtl_cached(ctx: FileContext, name: str, lost: list) -> dict:
    """An MTL material's keywords, read and checked once per file (its notes into ``lost``)."""
    key = ("mtl-material", name)
    if key not in ctx.cache:
        notes = []
        ctx.cache[key] = (_from_mtl(ctx.mtl[name], ctx, notes), notes)
    kw, notes = ctx.cache[key]
    lost += notes
    return dict(kw)


def from_simple(mat, name: str, lost: list, ctx: FileContext) -> dict:
    """OBJ/MTL through trimesh's copy (an MTL the file system does not hold, as inside a zip)."""
    raw = dict(getattr(mat, "kwargs", {}) or {})
    kw = {"name": name}
    for key in ("kd", "ka", "ks", "ke"):
        if key in raw:
            kw[key] = np.clip(_rgb(raw.pop(key)), 0.0, None)
    if "ns" in raw:
        ns = float(np.atleast_1d(raw.pop("ns"))[0])
        if ns > 0:
            kw["shininess"] = min(ns, _MAX_SHININESS)
        else:
            lost.append(f"Ns {ns:g} (the shininess must be > 0; kept {Material().shininess:g})")
    illum = raw.pop("illum", None)
    if illum is not None:
        code = int(float(illum[0]))
        if code in (0, 1):
            kw["ks"] = 0.0
        elif code != 2:
            lost.append(f"illum {code} (reflection/refraction models; shaded as illum 2)")
    raw.pop("ni", None)
    image = getattr(mat, "image", None)
    if image is not None:
        kw["kd_map"] = ctx.wrapped(("simple", ctx.image_key(image)), lambda: Texture(
            ctx.linear(image, f"{name}.map_Kd"), name=f"{name}.map_Kd", decoded_from_srgb=True))
        raw.pop("map_kd", None)
    for key in ("map_ka", "map_ks", "map_ke"):
        if key in raw:
            lost.append(f"{key} {' '.join(map(str, raw.pop(key)))} (the MTL file is not on disk)")
    for key, value in raw.items():
        nums = _numbers(value) if isinstance(value, (list, tuple)) else None
        if key in _MTL_HARMLESS and nums and all(n == _MTL_HARMLESS[key] for n in nums):
            continue
        shown = " ".join(map(str, value)) if isinstance(value, (list, tuple)) else value
        lost.append(f"{key} {shown}".strip())
    return kw


def _factor(value, n: int, default) -> np.ndarray:
    if value is None:
        return np.array(default, np.float64)
    v = np.asarray(value)
    v = v.astype(np.float64) / 255.0 if v.dtype.kind in "ui" else v.astype(np.float64)
    return np.atleast_1d(v)[:n]


def from_pbr(mat, name: str, lost: list, ctx: FileContext) -> dict:
    """glTF metallic-roughness onto ka, kd, ks, t (see the module docstring), or with
    ``ctx.reflectance == "pbr"`` as itself: a ``specular="ggx"`` material. Where the maps read a UV set
    after the first, the keywords also hold ``wrapped.UV_SET`` (``(n, slot)``), which
    :func:`~raycast_shade.load_models` takes out to read that set (not a :class:`Material` keyword)."""
    js = ctx.gltf_material(mat) or {}
    kw = {"name": name, "specular": "blinn", "double_sided": bool(js.get("doubleSided", False))}
    sg = (js.get("extensions") or {}).get("KHR_materials_pbrSpecularGlossiness")
    if isinstance(sg, dict):  # read from the file itself: trimesh's conversion bypasses the texture path
        kw.update(from_spec_gloss(mat, js, sg, name, lost, ctx))
        slots = {k: sg.get(k) for k in ("diffuseTexture", "specularGlossinessTexture")}
    else:
        kw.update(_metal_rough(mat, js, name, lost, ctx))
        slots = {k: (js.get("pbrMetallicRoughness") or {}).get(k)
                 for k in ("baseColorTexture", "metallicRoughnessTexture")}
    _normal(mat, js, name, kw, lost, ctx)
    _emission(mat, js, name, kw, lost, ctx)
    _occlusion(mat, js, name, kw, lost, ctx)
    slots.update({k: js.get(k) for k in ("normalTexture", "occlusionTexture", "emissiveTexture")})
    mats = (ctx.gltf or {}).get("materials", []) or []
    index = next((i for i, m in enumerate(mats) if m is js), None)
    transform_maps(kw, slots, f"{os.path.basename(ctx.path) or 'file'}: materials[{index}]", lost, ctx.cache)
    return kw


def _metal_rough(mat, js: dict, name: str, lost: list, ctx: FileContext) -> dict:
    """The core metallic-roughness part of :func:`from_pbr`: colours, specular, alpha mask."""
    pbr = js.get("pbrMetallicRoughness") or {}
    base = _factor(mat.baseColorFactor, 4, [1.0, 1.0, 1.0, 1.0])
    rgb = base[:3]
    m = 1.0 if mat.metallicFactor is None else float(mat.metallicFactor)
    r = 1.0 if mat.roughnessFactor is None else float(mat.roughnessFactor)
    tex, mr = getattr(mat, "baseColorTexture", None), getattr(mat, "metallicRoughnessTexture", None)
    wrap_s, wrap_t, notes = ctx.sampler(pbr.get("baseColorTexture"))
    lost += notes
    kw = {}
    kw.update(_alpha_mask(mat, js, base, name, lost, ctx, (wrap_s, wrap_t)))
    if getattr(ctx, "reflectance", "phong") == "pbr":
        kw.update(_ggx(mat, pbr, rgb, (m, r), name, lost, ctx, (wrap_s, wrap_t)))
    elif mr is None:
        alpha = r * r
        kw["kd"] = rgb * ((1.0 - m) + m * alpha)
        kw["ks"] = _DIELECTRIC_F0 * (1.0 - m) + rgb * m * (1.0 - alpha)
        kw["ka"] = rgb
        kw["shininess"] = _shininess(r)
        if tex is not None:
            texels = ctx.linear(tex, f"{name}.baseColorTexture")
            t = ctx.wrapped(("pbr", ctx.image_key(tex), wrap_s, wrap_t),
                            lambda: Wrapped(texels, wrap_s, wrap_t, f"{name}.baseColorTexture", srgb=True))
            kw["kd_map"] = kw["ka_map"] = t
            if m > 0:
                kw["ks_map"] = t  # the metallic part is the base colour's (the dielectric 0.04 scaled too)
    else:
        # Per texel: the metallic (blue) and roughness (green) channels, linear, on the base's grid.
        key = ("mr", ctx.image_key(tex), ctx.image_key(mr), m, r, tuple(rgb), wrap_s, wrap_t)
        if key not in ctx.cache:
            mrt = ctx.linear(mr, f"{name}.metallicRoughnessTexture", srgb=False)
            if tex is not None:
                col = ctx.linear(tex, f"{name}.baseColorTexture")
                if mrt.shape[:2] != col.shape[:2]:
                    mrt = _resample(mrt, col.shape[:2])
            else:
                col = np.ones(mrt.shape, np.float32)
            mm = np.clip(m * mrt[..., 2:3].astype(np.float64), 0.0, 1.0)
            rr = np.clip(r * mrt[..., 1:2].astype(np.float64), 0.0, 1.0)
            aa = rr * rr
            kd_t = col * ((1.0 - mm) + mm * aa)
            ks_t = _DIELECTRIC_F0 * (1.0 - mm) + col * rgb * mm * (1.0 - aa)
            ctx.cache[key] = (Wrapped(kd_t, wrap_s, wrap_t, f"{name}.baseColor*(1-m+m*alpha)", srgb=True),
                              Wrapped(ks_t, wrap_s, wrap_t, f"{name}.specular(metallicRoughness)", srgb=True),
                              Wrapped(col, wrap_s, wrap_t, f"{name}.baseColorTexture", srgb=True) if tex is not None else None,
                              float(np.median(rr)))
        kd_w, ks_w, col_w, r_med = ctx.cache[key]
        kw.update(kd=rgb, ks=1.0, kd_map=kd_w, ks_map=ks_w, ka=rgb, shininess=_shininess(r_med))
        if col_w is not None:
            kw["ka_map"] = col_w
        lost.append(f"metallicRoughnessTexture: per-texel kd and ks, one exponent from the median "
                    f"roughness {r_med:.3g} (approximated)")
    return kw


def _ggx(mat, pbr: dict, rgb, mr_factors, name: str, lost: list, ctx: FileContext, wraps) -> dict:
    """glTF metallic-roughness as itself: base colour (texture sRGB) as kd and ka, factors, and the
    ``metallicRoughnessTexture`` (linear, its own sampler) that scales them per texel."""
    kw = {"specular": "ggx", "kd": rgb, "ka": rgb, "metallic": mr_factors[0], "roughness": mr_factors[1]}
    tex = getattr(mat, "baseColorTexture", None)
    if tex is not None:
        texels = ctx.linear(tex, f"{name}.baseColorTexture")
        kw["kd_map"] = kw["ka_map"] = ctx.wrapped(("pbr", ctx.image_key(tex), *wraps), lambda: Wrapped(
            texels, wraps[0], wraps[1], f"{name}.baseColorTexture", srgb=True))
    mr, _ = _linear_map(mat, pbr, name, "metallicRoughnessTexture", lost, ctx)  # its info is pbr's
    if mr is not None:
        kw["metallic_roughness_map"] = mr
    return kw


def _linear_map(mat, js: dict, name: str, slot: str, lost: list, ctx: FileContext):
    """glTF texture ``slot`` of a material (linear, its own sampler): the
    wrapped texels and the texture-info dict, or ``(None, {})`` without the slot."""
    tex = getattr(mat, slot, None)
    if tex is None:
        return None, {}
    info = js.get(slot) if isinstance(js.get(slot), dict) else {}
    wrap_s, wrap_t, notes = ctx.sampler(info)
    lost += notes
    texels = ctx.linear(tex, f"{name}.{slot}", srgb=False)
    key = (slot.replace("Texture", ""), ctx.image_key(tex), wrap_s, wrap_t)
    return ctx.wrapped(key, lambda: Wrapped(texels, wrap_s, wrap_t, f"{name}.{slot}")), info


def _occlusion(mat, js: dict, name: str, kw: dict, lost: list, ctx: FileContext) -> None:
    """glTF ``occlusionTexture`` (linear, red channel, its own sampler) into ``kw["ao_map"]`` and
    its ``strength`` (default 1) into ``kw["ao_strength"]``."""
    wrapped, info = _linear_map(mat, js, name, "occlusionTexture", lost, ctx)
    if wrapped is None:
        return
    kw["ao_map"] = wrapped
    kw["ao_strength"] = float(info.get("strength", 1.0))  # checked with the file's materials


def _normal(mat, js: dict, name: str, kw: dict, lost: list, ctx: FileContext) -> None:
    """glTF ``normalTexture`` (linear, its own sampler) into ``kw["normal_map"]`` and its ``scale``
    (default 1) into ``kw["normal_scale"]``; the mesh's ``TANGENT`` is read by :func:`load_models`."""
    wrapped, info = _linear_map(mat, js, name, "normalTexture", lost, ctx)
    if wrapped is None:
        return
    kw["normal_map"] = wrapped
    scale = info.get("scale", 1.0)
    if isinstance(scale, bool) or not isinstance(scale, (int, float)) or not math.isfinite(scale):
        raise ValueError(f"{os.path.basename(ctx.path)}: material {name!r}: normalTexture.scale: expected a "
                         f"finite number, got {scale!r}")
    kw["normal_scale"] = float(scale)


def _emission(mat, js: dict, name: str, kw: dict, lost: list, ctx: FileContext) -> None:
    """glTF ``emissiveFactor`` (times ``KHR_materials_emissive_strength``) into ``kw["ke"]`` and
    ``emissiveTexture`` (sRGB, its own sampler) into ``kw["ke_map"]``. The factor defaults to
    0, so a texture without a factor emits nothing, as the spec says (and is not packed)."""
    ke = _factor(getattr(mat, "emissiveFactor", None), 3, [0.0, 0.0, 0.0])
    strength = ((js.get("extensions") or {}).get("KHR_materials_emissive_strength") or {}).get("emissiveStrength")
    if strength is not None:  # checked with the file's materials (FileContext)
        ke = ke * float(strength)
    if not np.any(ke > 0):
        return
    kw["ke"] = ke
    tex = getattr(mat, "emissiveTexture", None)
    if tex is None:
        return
    wrap_s, wrap_t, notes = ctx.sampler(js.get("emissiveTexture"))
    lost += notes
    texels = ctx.linear(tex, f"{name}.emissiveTexture")
    kw["ke_map"] = ctx.wrapped(("pbr", ctx.image_key(tex), wrap_s, wrap_t),
                               lambda: Wrapped(texels, wrap_s, wrap_t, f"{name}.emissiveTexture", srgb=True))
