"""Surface reflectance: the lecture's ka, kd, Ks and shininess t, per channel."""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from ..common.choices import SPECULAR_MODELS
from ..common.layout import (MAT_AO_STRENGTH, MAT_KA, MAT_KA_COLORS, MAT_KD, MAT_KE, MAT_KS, MAT_METALLIC,
                             MAT_MODEL, MAT_REFLECTIVITY, MAT_ROUGHNESS, MAT_SHININESS, MAT_SIZE, MODEL_CODE)
from ..common.validate import as_bool, as_choice, as_name, as_rgb, as_scalar
from ..common.warnings import AllMaskedWarning, ColourRangeWarning, NormalMapWarning

__all__ = ["Material", "SPECULAR_MODELS", "MAP_FIELDS", "MAX_NORMAL_SCALE", "overridden"]

MAP_FIELDS = ("ka_map", "kd_map", "ks_map", "ke_map", "ao_map")  # Material.maps' order: the TEXMAP_* columns
# |normal_scale| beyond which the kernels' float64 sum T x s + B y s + N z overflows in its norm (x, y in [-1, 1]):
# up to it the bent normal is its limit normalize(T x + B y) to rounding already.
MAX_NORMAL_SCALE = 1e150


def _warn_byte_range(rgb: np.ndarray, name: str, field: str) -> None:
    """Warn when coefficients look like 0-255 colour values: above 1 (up to 255),
    and whole numbers or above 2 (a reflectance above 1 reflects more than arrives)."""
    top = rgb.max()
    if 1.0 < top <= 255.0 and (np.all(rgb == np.round(rgb)) or top > 2.0):
        warnings.warn(
            f"{name} = {rgb.tolist()} looks like 0-255 colour values, but coefficients are fractions "
            f"(1 reflects everything): did you mean {field}={np.round(rgb / 255.0, 4).tolist()} ({field}/255)?",
            ColourRangeWarning, stacklevel=4)


@dataclass(frozen=True, eq=False)
class Material:
    """Coefficients of ``I = Ia ka + sum_i att(d) Ii (kd (n.s) + Ks (r.v)^t) + ke``
    (or, with ``specular="ggx"``, glTF's metallic-roughness BRDF in place of the bracket).

    Every coefficient is a scalar or an RGB triple (the lecture's
    ``k(lambda)`` sampled at three wavelengths) and must be ``>= 0``.

    Parameters
    ----------
    kd : float or (3,) float
        Diffuse albedo (Lambert). Default 0.8, or 1 with a ``kd_map``. A mesh
        with colours (:class:`~raycast_shade.Mesh` ``colors``) uses them as
        its kd instead.
    ka : float or (3,) float
        Ambient coefficient, multiplied by the scene's ambient intensity ``Ia``.
    ks : float or (3,) float
        Specular coefficient ``Ks``. Default 0, or 1 with a ``ks_map``.
    shininess : float
        Exponent ``t > 0``.
    specular : {"phong", "blinn", "ggx"}
        ``(r.v)^t`` as in the lecture, Blinn-Phong ``(n.h)^t``, or ``"ggx"``: the
        glTF 2.0 metallic-roughness BRDF (Lambert + Trowbridge-Reitz/GGX, Smith
        height-correlated, Schlick; see ``docs/pbr.md`` and
        :mod:`raycast_shade.shading.reflectance`) with ``kd`` the base colour,
        ``metallic`` and ``roughness``; a light ``Ii`` gives the irradiance
        ``pi Ii``, so a white Lambertian surface shows ``Ii (n.s)`` as with
        ``kd=1`` in the lecture's model. ``ggx`` has no ``ks`` (its specular
        colour is Fresnel's ``F0 = mix(0.04, kd, metallic)``), no ``ks_map``
        and no ``shininess``: ValueError if given.
    metallic, roughness : float
        ``ggx`` only, in [0, 1] (defaults 0 and 0.5): glTF's ``metallicFactor``
        and ``roughnessFactor`` (alpha = roughness^2; below 0.045 shaded as
        0.045). ValueError with another model (they would be ignored).
    metallic_roughness_map : Texture, optional
        ``ggx`` only: glTF's ``metallicRoughnessTexture``, linear (load it with
        ``srgb=False``): its green channel scales ``roughness``, its blue
        ``metallic`` per texel (it takes the ks map's column of the kernels).
    reflectivity : float
        Mirror fraction ``rho`` in [0, 1]: the pixel shows
        ``(1 - rho) * local + rho * reflected`` (see ``render(max_depth=...)``).
        0 is a matt/specular surface, 1 a perfect mirror.
    bump : HeightMap, optional
        Blinn bump map; needs per-vertex UVs on the mesh. Applies in Phong
        shading and to mirror reflections (see :mod:`raycast_shade.bump`).
    name : str
    kd_map, ka_map, ks_map : Texture, optional
        Colour textures sampled at the hit's UV (the mesh needs UVs): the
        point's kd is ``kd * kd_map(u, v)`` (likewise ka, ks), as OBJ's
        ``map_Kd`` scales ``Kd``. See ``docs/textures.md`` for what each
        shading method does with them.
    alpha_map : Texture, optional
        Coverage (glTF's alpha, the base colour's alpha times its texture's):
        its first channel, sampled bilinearly at level 0 at the hit's UV (the
        mesh needs UVs). Given together with ``alpha_cutoff``.
    alpha_cutoff : float, optional
        ``None``: opaque. Else rays (camera, shadow and mirror rays alike)
        pass through the points where ``alpha_map < alpha_cutoff`` (glTF's
        ``MASK``; 0.5 is glTF's default): see :mod:`raycast_shade.visibility.alpha`.
        A cutoff above every texel of ``alpha_map`` removes the whole model: an
        :class:`~raycast_shade.common.warnings.AllMaskedWarning` says so.
    ka_colors : bool
        The ambient term follows the mesh's colours: on a mesh with colours the
        point's ka is ``ka`` times its colour (as its kd is the colour), so
        ``ka=1`` gives an ambient term in the surface's own colour. False (the
        default): ``ka`` is used as given. :func:`raycast_shade.load_models`
        sets it (with ``ka=1``) for a coloured mesh whose file gives no ambient
        colour. No effect on a mesh without colours.
    ke : float or (3,) float
        Emission ``ke``: radiance the surface gives off by itself, added to
        the point's intensity whatever the lights (glTF ``emissiveFactor``,
        MTL ``Ke``). Default 0, or 1 with a ``ke_map``. ``>= 0``; may exceed 1
        (a lamp brighter than white).
    ke_map : Texture, optional
        Emission texture: the point's ke is ``ke * ke_map(u, v)`` (glTF
        ``emissiveTexture``, MTL ``map_Ke``); sampled per pixel in Phong and
        Gouraud shading, at the face centre in flat shading.
    ao_map : Texture, optional
        Ambient occlusion: its red channel ``ao`` (linear: load it with
        ``srgb=False``) scales the ambient term per texel, the lecture's
        "radiosity" approximation of the light that reaches a crevice: the
        point's ka is ``ka * (1 + ao_strength * (ao - 1))`` (glTF
        ``occlusionTexture``). The other terms are unchanged.
    ao_strength : float
        In [0, 1]: 0 ignores the map, 1 (the default) applies it fully
        (glTF's ``strength``). Other than 1 only with an ``ao_map``.
    normal_map : Texture, optional
        Tangent-space normal map (glTF ``normalTexture``), linear (load it with
        ``srgb=False``): a texel ``(r, g, b)`` bends the shading normal to
        ``normalize(T (2r - 1) s + B (2g - 1) s + N (2b - 1))`` in the frame of
        the mesh's tangents ``T`` (:class:`~raycast_shade.Mesh` ``tangents``, or
        computed from the UVs), ``B = w (N x T)``; sampled bilinearly at level 0.
        Phong shading and mirror reflections only (flat and Gouraud warn, as for
        ``bump``). The mesh needs UVs.
        The texels must lie in [0, 1] and must not have been decoded from sRGB
        (ValueError); a map that is grey everywhere (one channel, or a height
        map) or has no texel with ``b > 0.5`` (every normal into the surface)
        gives a :class:`~raycast_shade.common.warnings.NormalMapWarning`.
    normal_scale : float
        ``s`` above (glTF's ``normalTexture.scale``), default 1; 0 leaves the
        normal unbent; ``|s| <= MAX_NORMAL_SCALE`` (1e150), where the bent
        normal already is its limit ``normalize(T (2r - 1) + B (2g - 1))``
        (ValueError beyond). Other than 1 only with a ``normal_map``.
    double_sided : bool
        Whether the surface is meant to be seen from both sides (the default).
        ``False`` (glTF's ``doubleSided: false``, its default) changes nothing
        in the image: every surface is lit from the side it is seen from and
        back faces are drawn; ``render`` then warns (``SingleSidedWarning``)
        when the camera sees the back faces of such a model, which a culling
        renderer would not draw.
    """

    kd: object = None
    ka: object = 1.0
    ks: object = None
    shininess: float = 32.0
    specular: str = "phong"
    reflectivity: float = 0.0
    bump: object = None
    name: str = "material"
    kd_map: object = None
    ka_map: object = None
    ks_map: object = None
    alpha_map: object = None
    alpha_cutoff: object = None
    ka_colors: bool = False
    ke: object = None
    ke_map: object = None
    ao_map: object = None
    ao_strength: float = 1.0
    normal_map: object = None
    normal_scale: float = 1.0
    double_sided: bool = True
    metallic: float = 0.0
    roughness: float = 0.5
    metallic_roughness_map: object = None

    def __post_init__(self):
        set_ = object.__setattr__
        set_(self, "name", as_name(self.name, f"{type(self).__name__}.name"))  # first: every message uses it
        from .texture import Texture

        for field in MAP_FIELDS + ("alpha_map", "normal_map", "metallic_roughness_map"):
            tex = getattr(self, field)
            if tex is not None and not isinstance(tex, Texture):
                raise TypeError(f"{self.name}.{field}: expected a Texture, got {type(tex).__name__}")
        # A map's coefficient defaults to 1: the texture's own colours.
        if self.kd is None:
            set_(self, "kd", 1.0 if self.kd_map is not None else 0.8)
        set_(self, "specular", as_choice(self.specular, f"{self.name}.specular", SPECULAR_MODELS))
        if self.ks is None:
            set_(self, "ks", 1.0 if self.ks_map is not None or self.specular == "ggx" else 0.0)
        if self.ke is None:
            set_(self, "ke", 1.0 if self.ke_map is not None else 0.0)
        for field in ("kd", "ka", "ks"):
            set_(self, field, as_rgb(getattr(self, field), f"{self.name}.{field}"))
            _warn_byte_range(getattr(self, field), f"{self.name}.{field}", field)
        set_(self, "ke", as_rgb(self.ke, f"{self.name}.ke"))  # an emission may exceed 1: no 0-255 guess
        set_(self, "shininess", as_scalar(self.shininess, f"{self.name}.shininess", minimum=0.0, exclusive=True))
        set_(self, "ka_colors", as_bool(self.ka_colors, f"{self.name}.ka_colors"))
        set_(self, "double_sided", as_bool(self.double_sided, f"{self.name}.double_sided"))
        set_(self, "ao_strength", as_scalar(self.ao_strength, f"{self.name}.ao_strength", minimum=0.0, maximum=1.0))
        set_(self, "normal_scale", as_scalar(self.normal_scale, f"{self.name}.normal_scale"))
        if abs(self.normal_scale) > MAX_NORMAL_SCALE:
            raise ValueError(f"{self.name}.normal_scale: |s| must be <= {MAX_NORMAL_SCALE:g}, got "
                             f"{self.normal_scale:g}: beyond, the bent normal's float64 length overflows and the "
                             "normal would stay unbent, where at 1e150 it already is its limit "
                             "normalize(T (2r - 1) + B (2g - 1))")
        set_(self, "reflectivity", as_scalar(self.reflectivity, f"{self.name}.reflectivity", minimum=0.0, maximum=1.0))
        if self.bump is not None:
            from .heightmap import HeightMap

            if not isinstance(self.bump, HeightMap):
                raise TypeError(f"{self.name}.bump: expected a HeightMap, got {type(self.bump).__name__}")
        _check_alpha(self)
        _check_without_map(self)
        _check_ggx(self)
        if self.normal_map is not None:
            _check_normal_map(self.normal_map, f"{self.name}.normal_map")

    @property
    def maps(self) -> tuple:
        """``(ka_map, kd_map, ks_map, ke_map, ao_map)``, ``None`` where absent (the order of
        :data:`~raycast_shade.common.layout.TEXMAP_KA` and friends, :data:`MAP_FIELDS`); a ``ggx``
        material's ``metallic_roughness_map`` in the ks map's place."""
        ks_map = self.metallic_roughness_map if self.specular == "ggx" else self.ks_map
        return (self.ka_map, self.kd_map, ks_map, self.ke_map, self.ao_map)

    @property
    def has_emission(self) -> bool:
        return bool(np.any(self.ke > 0))

    @property
    def has_specular(self) -> bool:
        return self.specular == "ggx" or bool(np.any(self.ks > 0))

    def packed(self) -> np.ndarray:
        """(MAT_SIZE,) = (19,) float64: ka(3), kd(3), ks(3), t, model code, reflectivity, ka_colors flag,
        ke(3), occlusion strength, metallic, roughness (0 but for ``ggx``); the kernels' row
        (slots named in :mod:`raycast_shade.common.layout`)."""
        row = np.empty(MAT_SIZE)
        row[MAT_KA:MAT_KA + 3] = self.ka
        row[MAT_KD:MAT_KD + 3] = self.kd
        row[MAT_KS:MAT_KS + 3] = self.ks
        row[MAT_SHININESS] = self.shininess
        row[MAT_MODEL] = MODEL_CODE[self.specular]
        row[MAT_REFLECTIVITY] = self.reflectivity
        row[MAT_KA_COLORS] = 1.0 if self.ka_colors else 0.0
        row[MAT_KE:MAT_KE + 3] = self.ke
        row[MAT_AO_STRENGTH] = self.ao_strength
        ggx = self.specular == "ggx"
        row[MAT_METALLIC] = self.metallic if ggx else 0.0
        row[MAT_ROUGHNESS] = self.roughness if ggx else 0.0
        return row


def _check_alpha(mat: Material) -> None:
    """``alpha_map`` and ``alpha_cutoff`` come together (either alone would be silently ignored)."""
    if mat.alpha_cutoff is None:
        if mat.alpha_map is not None:
            raise ValueError(f"{mat.name}.alpha_map: given without alpha_cutoff (None means opaque); "
                             "set alpha_cutoff=0.5 (glTF's default) to mask")
        return
    object.__setattr__(mat, "alpha_cutoff", as_scalar(mat.alpha_cutoff, f"{mat.name}.alpha_cutoff", minimum=0.0))
    if mat.alpha_map is None:
        raise ValueError(f"{mat.name}.alpha_cutoff: given without an alpha_map (a Texture whose first channel "
                         "is the coverage)")
    # Rays pass where the sampled alpha < cutoff; bilinear samples of level 0 never exceed its largest texel
    # (one float32 step above it covers the float64 weights' rounding): then every point passes.
    top = np.float32(mat.alpha_map.texels[..., 0].max())
    if mat.alpha_cutoff > float(np.nextafter(top, np.float32(np.inf))):
        warnings.warn(f"{mat.name}.alpha_cutoff = {mat.alpha_cutoff:g} exceeds every texel of alpha_map "
                      f"{mat.alpha_map.name!r} (largest {float(top):g}): rays pass through the whole model, which "
                      "is not drawn and casts no shadow; coverage lies in [0, 1] (glTF's default cutoff is 0.5)",
                      AllMaskedWarning, stacklevel=4)


def _check_without_map(mat: Material) -> None:
    """``normal_scale`` and ``ao_strength`` scale their map: set without it they would be ignored."""
    for field, default, tex in (("normal_scale", 1.0, "normal_map"), ("ao_strength", 1.0, "ao_map")):
        if getattr(mat, field) != default and getattr(mat, tex) is None:
            article = "an" if tex[0] in "aeiou" else "a"
            raise ValueError(f"{mat.name}.{field}: {getattr(mat, field):g} given without {article} {tex}, which it "
                             f"scales (it would be ignored); give the {tex} too, or leave {field} at {default:g}")


def _check_ggx(mat: Material) -> None:
    """The GGX fields with ``specular="ggx"`` only, and the Phong ones it has no use for refused
    (either would be silently ignored)."""
    set_ = object.__setattr__
    for field in ("metallic", "roughness"):
        set_(mat, field, as_scalar(getattr(mat, field), f"{mat.name}.{field}", minimum=0.0, maximum=1.0))
    if mat.specular != "ggx":
        for field, default in (("metallic", 0.0), ("roughness", 0.5), ("metallic_roughness_map", None)):
            if getattr(mat, field) is not default and getattr(mat, field) != default:
                raise ValueError(f"{mat.name}.{field}: given with specular={mat.specular!r}, which has no use for "
                                 "it (it would be ignored); it belongs to specular='ggx'")
        return
    if not np.all(mat.ks == 1.0) or mat.ks_map is not None:
        raise ValueError(f"{mat.name}.ks: specular='ggx' has no ks nor ks_map (its specular colour is Fresnel's "
                         "F0 = mix(0.04, kd, metallic)); leave ks out, and give metallic_roughness_map for a map")
    if mat.shininess != 32.0:
        raise ValueError(f"{mat.name}.shininess: specular='ggx' has no shininess (it would be ignored); its lobe's "
                         "width is roughness")
    tex = mat.metallic_roughness_map
    if tex is not None and getattr(tex, "_decoded_srgb", False):
        raise ValueError(f"{mat.name}.metallic_roughness_map: texture {tex.name!r} was decoded from sRGB; its "
                         "channels are data (glTF: linear): load it with srgb=False")


def _check_normal_map(tex, name: str) -> None:
    """A tangent-space normal map stores ``(n + 1) / 2`` per texel, linear: refuse texels that cannot
    encode a component, and say so when no texel can be a surface's normal (see ``Material.normal_map``)."""
    if getattr(tex, "_decoded_srgb", False):
        raise ValueError(f"{name}: texture {tex.name!r} was decoded from sRGB (Texture.from_image's and "
                         "from_array's default); a normal map's texels are data, not colours: load it with "
                         "srgb=False")
    t = tex.texels
    top = float(t.max())
    if top > 1.0:
        raise ValueError(f"{name}: texels must lie in [0, 1] (each channel encodes a component c as "
                         f"(c + 1) / 2), got max {top:g} in texture {tex.name!r}")
    if np.all(t[..., 0] == t[..., 1]) and np.all(t[..., 1] == t[..., 2]):
        inward = " (all of them into the surface: blue < 0.5)" if t[..., 2].max() < 0.5 else ""
        warnings.warn(f"{name}: every texel of texture {tex.name!r} is grey (r = g = b): a one-channel image "
                      "or a height map, not a normal map; every normal is bent along +-(s T + s B + N) or "
                      f"left unbent{inward} (a flat normal map is (0.5, 0.5, 1); heights go to bump=HeightMap)",
                      NormalMapWarning, stacklevel=4)
    elif not np.any(t[..., 2] > 0.5):
        warnings.warn(f"{name}: no texel of texture {tex.name!r} has blue > 0.5: every normal points into the "
                      "surface or along it (z = 2b - 1 <= 0; a flat normal map is (0.5, 0.5, 1)); a two-channel "
                      "map whose z is to be reconstructed, or channels swapped?", NormalMapWarning, stacklevel=4)


def overridden(base: Material, given: dict) -> dict:
    """``base``'s fields as :class:`Material` keywords, with ``given`` winning key by key.

    A ``kd`` given replaces ``base``'s kd and kd_map alike (a ``ks`` its ks
    and ks_map): the override is the colour, not a factor on the file's
    texture. Where ``base``'s ka follows its kd (``ka == kd`` and the same
    map: a file without an ambient colour, see
    :func:`raycast_shade.load_models`), or follows the mesh's colours
    (``ka_colors``), a new kd or kd_map carries ka along, unless ``ka`` or
    ``ka_map`` is given too. A ``ka`` given is used as given: ``ka_colors``
    goes off with it (and with a ``kd``, which replaces the colours in scene
    files) unless ``ka_colors`` is given too.
    """
    import dataclasses

    out = {f.name: getattr(base, f.name) for f in dataclasses.fields(base)}
    if "kd" in given and "kd_map" not in given:
        out["kd_map"] = None
    if "ks" in given and "ks_map" not in given:
        out["ks_map"] = None
    follows = (np.array_equal(base.ka, base.kd) or base.ka_colors) and base.ka_map is base.kd_map
    if follows and "ka" not in given and "ka_map" not in given and ("kd" in given or "kd_map" in given):
        out["ka"] = given["kd"] if "kd" in given else base.ka  # (base.ka is base.kd, or 1 scaled by the colours)
        out["ka_map"] = given.get("kd_map")
        if "kd" in given:  # a kd replaces the colours too (scene files): ka is the new kd, not scaled by them
            out["ka_colors"] = False
    if "ka" in given and "ka_colors" not in given:  # an explicit ka is used as given
        out["ka_colors"] = False
    out.update(given)
    return out
