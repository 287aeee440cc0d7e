"""Scenes: models (mesh + material), lights, ambient light and a camera.

A scene packs its geometry once (re-centred, float64 for shading, float32 for
Embree) and builds its Embree BVH once; :meth:`Scene.replace` with the same
models, e.g. a new camera or new lights, reuses both.
"""

from __future__ import annotations

import dataclasses
import threading
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ..common.heap import release_free_heap
from ..common.validate import as_rgb
from .camera import Camera
from .tangents import pack_normal_maps
from ..common.layout import (BUMP_SIZE, COLOR_FACE, COLOR_NONE, COLOR_VERTEX, LIGHT_SIZE, MAT_REFLECTIVITY, MAT_SIZE,
                             TEX_SIZE, TEXMAP_COUNT)
from .lights import Light
from .material import MAP_FIELDS, Material
from .mesh import Mesh

__all__ = ["Model", "Scene", "SceneGeometry"]


def _is_trimesh(value) -> bool:
    """A trimesh.Trimesh or trimesh.Scene, told by its type's module so trimesh is not imported."""
    cls = type(value)
    return cls.__module__.split(".")[0] == "trimesh" and cls.__name__ in ("Trimesh", "Scene")


@dataclass(frozen=True, eq=False)
class Model:
    """A mesh with its material, placed in the world by a rigid pose.

    ``mesh`` may be a :class:`trimesh.Trimesh` (or ``trimesh.Scene``): it is
    converted with :meth:`Mesh.from_trimesh`. ``name`` (default: the mesh's
    name, which a loaded file sets from its node names) labels the model in
    data sets: models of one name share a semantic label
    (:mod:`raycast_shade.output.labels`).

    ``pose`` is the (4, 4) model-to-world transform ``[R t; 0 1]`` (``R`` a
    rotation: orthonormal to 1e-9, determinant +1), so the mesh stays in its
    own frame and a point ``x`` of it lies at ``R x + t`` in the world: the
    frame a pose data set (BOP, :mod:`raycast_shade.output.bop`) refers its
    poses to. The default, None, is the identity (the mesh given in world
    coordinates); the identity itself is stored as None, and such a model
    renders with the mesh's own arrays, bit for bit. Read the world-space
    arrays from :attr:`prepared`, the world box from :attr:`bounds`.
    """

    mesh: Mesh
    material: Material = dataclasses.field(default_factory=Material)
    name: str | None = None
    pose: np.ndarray | None = None

    def __post_init__(self):
        if _is_trimesh(self.mesh):
            object.__setattr__(self, "mesh", Mesh.from_trimesh(self.mesh))
        if not isinstance(self.mesh, Mesh):
            raise TypeError(f"model.mesh: expected a Mesh, got {type(self.mesh).__name__}")
        if not isinstance(self.material, Material):
            raise TypeError(f"model.material: expected a Material, got {type(self.material).__name__}")
        if self.name is None:
            object.__setattr__(self, "name", self.mesh.name)
        elif not isinstance(self.name, str) or not self.name.strip():
            raise TypeError(f"model.name: expected a non-empty str, got {self.name!r}")
        if self.pose is not None:
            object.__setattr__(self, "pose", _as_pose(self.pose))

    @property
    def model_to_world(self) -> np.ndarray:
        """(4, 4) float64 model-to-world transform (the identity when ``pose`` is None); a fresh copy."""
        return np.eye(4) if self.pose is None else self.pose.copy()

    @cached_property
    def prepared(self):
        """The mesh's :attr:`~raycast_shade.scene.mesh.Mesh.prepared` arrays moved into the world by
        ``pose`` (vertices, normals, face normals and tangents; the mesh's own tuple when ``pose``
        is None)."""
        prep = self.mesh.prepared
        if self.pose is None:
            return prep
        R, t = self.pose[:3, :3], self.pose[:3, 3]
        tangents = prep.tangents
        if tangents is not None:  # a rotation keeps the handedness w
            tangents = np.c_[tangents[:, :3] @ R.T, tangents[:, 3]]
        return prep._replace(vertices=prep.vertices @ R.T + t, normals=prep.normals @ R.T,
                             face_normals=prep.face_normals @ R.T, tangents=tangents)

    @cached_property
    def bounds(self) -> np.ndarray:
        """(2, 3) float64 world axis-aligned box ``[min, max]`` of the posed mesh."""
        if self.pose is None:
            return self.mesh.bounds
        v = self.prepared.vertices
        return np.stack([v.min(axis=0), v.max(axis=0)])


def _as_pose(value) -> np.ndarray | None:
    """A checked read-only (4, 4) rigid pose, or None for the identity."""
    from ..common.validate import as_array

    M = as_array(value, "model.pose", dtype=np.float64, shape=(4, 4), copy=True)
    if not np.array_equal(M[3], [0.0, 0.0, 0.0, 1.0]):
        raise ValueError(f"model.pose: last row must be [0, 0, 0, 1], got {M[3].tolist()}")
    R = M[:3, :3]
    err = float(np.abs(R @ R.T - np.eye(3)).max())
    if err > 1e-9 or np.linalg.det(R) < 0:
        raise ValueError("model.pose: its 3x3 part must be a rotation (orthonormal to 1e-9, determinant +1); "
                         f"got R R^T off the identity by {err:.3g}, determinant {np.linalg.det(R):.6g}")
    if np.array_equal(M, np.eye(4)):
        return None
    M.setflags(write=False)
    return M


# Vertices + faces from which a packed geometry gives the C heap's free pages back: below it the
# packing's temporaries are a few MB, and malloc_trim's walk of the heap would cost more than it frees.
_TRIM_ELEMENTS = 1 << 18


def _joined(arrays: list) -> np.ndarray:
    """``np.concatenate(arrays)``, or one array itself when it is already what that returns to the
    kernels (writeable, C-contiguous: the same Numba type, so no new compilation)."""
    a = arrays[0]
    if len(arrays) == 1 and a.flags.writeable and a.flags.c_contiguous and a.flags.aligned:
        return a
    return np.concatenate(arrays)


class SceneGeometry:
    """All models packed into flat arrays, re-centred on the scene's box.

    Geometry far from the origin loses float32 precision in Embree; subtracting
    the bounding-box centre in float64 first makes a scene at 1e5 render like
    one at the origin.

    Attributes
    ----------
    origin : (3,) float64
        The re-centring offset (world = local + origin).
    scale : float
        Bounding-box diagonal, ``> 0``.
    reach : float
        Largest absolute re-centred coordinate; Embree takes at most
        ``embree.MAX_COORDINATE``.
    vertices : (V, 3) float64
        Re-centred positions (after crease splitting).
    normals : (V, 3) float64
        Unit vertex normals (zero where undefined).
    uvs : (V, 2) float64
        Zero for models without UVs.
    faces : (F, 3) int64
        Global vertex indices.
    face_normals : (F, 3) float64
    vertex_offsets, face_offsets : (G + 1,) int64
        Range of each model.
    materials : (G, MAT_SIZE) = (G, 19) float64
        One packed material row per model (see :meth:`Material.packed`).
    face_model, vertex_model : (F,) int32, (V,) int32
        The model each face and vertex belongs to.
    bump_index : (G,) int32
        Row of each model's height map in ``bump_info``, or -1.
    bump_texels : (T,) float32
    bump_info : (B, BUMP_SIZE) = (B, 7) float64
        See :meth:`HeightMap.packed_info`.
    color_mode : (G,) int8
        Each model's colour source (``COLOR_NONE``, ``COLOR_VERTEX``, ``COLOR_FACE``).
    vertex_colors, face_colors : (V, 3), (F, 3) float64
        Linear kd per vertex / per face, zero where a model has none ((1, 3)
        placeholders when no model has any).
    tex_index : (G, TEXMAP_COUNT) = (G, 5) int32
        Row in ``tex_info`` of each model's ka, kd, ks, ke and occlusion map, or -1.
    tex_texels : (T,) float32
        Every texture's mip pyramid, RGB triples.
    tex_info : (K, TEX_SIZE) = (K, 8) float64
        See :meth:`Texture.packed_info`.
    nmap_index : (G,) int32
        Row of each model's normal map in ``nmap_info``, or -1.
    nmap_texels : (N,) float32
    nmap_info : (K, TEX_SIZE) float64
    nmap_scale : (G,) float64
        Each model's ``normal_scale`` (0 without a map).
    vertex_tangents : (V, 4) float64
        Tangent and handedness per vertex for the normal maps ((1, 4) zeros when none).
    textured : bool
        Whether any model has colours or maps (the kernels' third variant flag).
    alpha_masks : tuple of (Texture, float) or None
        Per model, its material's ``(alpha_map, alpha_cutoff)`` when it masks (the mesh checked
        to have UVs), else None: :mod:`raycast_shade.visibility.alpha` turns them into Embree filters.
    """

    def __init__(self, models):
        preps = [m.prepared for m in models]  # world space: each mesh moved by its model's pose
        nv = [len(p.vertices) for p in preps]
        nf = [len(p.faces) for p in preps]
        self.vertex_offsets = np.concatenate([[0], np.cumsum(nv)]).astype(np.int64)
        self.face_offsets = np.concatenate([[0], np.cumsum(nf)]).astype(np.int64)
        world = np.concatenate([p.vertices for p in preps])
        lo, hi = world.min(axis=0), world.max(axis=0)
        self.origin = 0.5 * (lo + hi)
        self.scale = float(max(np.linalg.norm(hi - lo), 1e-30))
        self.reach = float(np.max(np.maximum(hi - self.origin, self.origin - lo)))  # max |re-centred coordinate|
        self.vertices = world - self.origin
        del world
        # One model keeps its prepared arrays where they can be shared as they are (issue 41: the
        # 1.31M-triangle sphere's geometry held 0.14 GB of copies); nothing writes them after packing.
        self.normals = _joined([p.normals for p in preps])
        self.local_faces = preps[0].faces if len(preps) == 1 else np.concatenate([p.faces for p in preps])  # Python reads it
        self.faces = self.local_faces + np.repeat(self.vertex_offsets[:-1], nf)[:, None]  # a writeable copy: kernels read it
        self.face_normals = _joined([p.face_normals for p in preps])
        # Zero UVs stand in where a model has none; only bump-mapped models
        # read them, and those are checked to have real ones (one model: fresh zero pages, never made resident).
        self.uvs = _joined([p.uvs if p.uvs is not None else np.zeros((len(p.vertices), 2)) for p in preps])
        self.materials = np.stack([m.material.packed() for m in models])
        self.reflective = bool(np.any(self.materials[:, MAT_REFLECTIVITY] > 0))
        # Bump maps: all texels in one flat array, one info row per map.
        bump_index = np.full(len(models), -1, np.int32)
        texels, info, maps = [], [], {}
        for g, m in enumerate(models):
            hm = m.material.bump
            if hm is None:
                continue
            if preps[g].uvs is None:
                raise ValueError(
                    f"scene.models[{g}] ({m.mesh.name}): material {m.material.name!r} has a bump map "
                    "but the mesh has no UVs (see raycast_shade.bump.spherical_uvs and friends)"
                )
            if id(hm) not in maps:
                maps[id(hm)] = len(info)
                offset = sum(t.size for t in texels)
                texels.append(hm.heights.ravel())
                info.append(hm.packed_info(offset))
            bump_index[g] = maps[id(hm)]
        self.bump_index = bump_index
        self.bump_texels = np.concatenate(texels).astype(np.float32) if texels else np.zeros(1, np.float32)
        self.bump_info = np.stack(info) if info else np.zeros((1, BUMP_SIZE))
        self.has_bump = bool(info)
        # Normal maps: their texels, one info row per map, and every vertex's tangent frame.
        (self.nmap_index, self.nmap_texels, self.nmap_info, self.nmap_scale,
         self.vertex_tangents) = pack_normal_maps(models, preps)
        self.has_normal_map = bool((self.nmap_index >= 0).any())
        # Alpha masks (installed as Embree filters by visibility.alpha): (alpha_map, cutoff) or None per model.
        self.alpha_masks = tuple(_alpha_mask(g, m, preps[g]) for g, m in enumerate(models))
        self._pack_colors(models, preps, nv, nf)
        self._pack_textures(models, preps)
        self.face_model = np.repeat(np.arange(len(models), dtype=np.int32), nf)
        self.vertex_model = np.repeat(np.arange(len(models), dtype=np.int32), nv)
        self.n_models = len(models)
        self._memo = {}
        self._memo_lock = threading.Lock()
        if self.vertex_offsets[-1] + self.face_offsets[-1] >= _TRIM_ELEMENTS:
            release_free_heap()  # the packing's freed temporaries, kept resident by the C heap (common/heap.py)

    def _pack_colors(self, models, preps, nv, nf) -> None:
        modes = [p.color_mode for p in preps]
        self.color_mode = np.array([COLOR_VERTEX if m == "vertex" else COLOR_FACE if m == "face" else COLOR_NONE
                                    for m in modes], np.int8)
        some = [m is not None for m in modes]
        vc = [p.colors if m == "vertex" else np.zeros((n, 3)) for p, m, n in zip(preps, modes, nv)]
        fc = [p.colors if m == "face" else np.zeros((n, 3)) for p, m, n in zip(preps, modes, nf)]
        self.vertex_colors = np.concatenate(vc) if "vertex" in modes else np.zeros((1, 3))
        self.face_colors = np.concatenate(fc) if "face" in modes else np.zeros((1, 3))
        self.has_colors = any(some)

    def _pack_textures(self, models, preps) -> None:
        """All maps' pyramids in one flat array, one info row per texture (shared maps once)."""
        index = np.full((len(models), TEXMAP_COUNT), -1, np.int32)
        texels, info, seen, offset = [], [], {}, 0
        for g, m in enumerate(models):
            for slot, tex in enumerate(m.material.maps):
                if tex is None:
                    continue
                if preps[g].uvs is None:
                    field = MAP_FIELDS[slot]
                    raise ValueError(f"scene.models[{g}] ({m.mesh.name}): material {m.material.name!r} has a "
                                     f"{field} but the mesh has no UVs (see raycast_shade.bump.planar_uvs and friends)")
                if id(tex) not in seen:
                    seen[id(tex)] = len(info)
                    texels.append(tex.packed_texels())
                    info.append(tex.packed_info(offset))
                    offset += texels[-1].size
                index[g, slot] = seen[id(tex)]
        self.tex_index = index
        self.tex_texels = np.concatenate(texels).astype(np.float32) if texels else np.zeros(3, np.float32)
        self.tex_info = np.stack(info) if info else np.zeros((1, TEX_SIZE))
        self.textured = bool(info) or self.has_colors

    def memo(self, key: str, build):
        """``build(self)``, computed once per ``key`` and kept with the geometry.

        Thread-safe: concurrent first callers wait for the one build instead of
        each making their own (an Embree BVH built twice would leave one
        thread holding the handle of a scene freed under it). The acceleration
        structures of :mod:`raycast_shade.visibility.accel` live here, so they
        share the geometry's lifetime.
        """
        memo = self._memo
        if key in memo:
            return memo[key]
        with self._memo_lock:
            if key not in memo:
                memo[key] = build(self)
                if self.vertex_offsets[-1] + self.face_offsets[-1] >= _TRIM_ELEMENTS:
                    release_free_heap()  # a BVH build's freed temporaries (common/heap.py)
            return memo[key]

    def memoized(self, key: str) -> bool:
        """True once :meth:`memo` has built ``key``."""
        return key in self._memo

    def __getstate__(self):
        """Pickle the packed arrays only: the Embree handles in the memo cannot
        travel and are rebuilt on first use."""
        state = dict(self.__dict__)
        state.pop("_memo", None)
        state.pop("_memo_lock", None)
        return state

    def __setstate__(self, state):
        self.__dict__.update(state)
        self._memo = {}
        self._memo_lock = threading.Lock()

    def __copy__(self):
        """A shallow copy that shares every array and the memo of Embree structures (and its
        lock): a variant whose caller replaces some arrays (a material variant for the terms
        or the explorer) shades with the same BVH, no rebuild. Pickling, not this, drops the memo."""
        twin = object.__new__(type(self))
        twin.__dict__.update(self.__dict__)
        return twin

    @cached_property
    def tangents(self) -> np.ndarray:
        """(F, 6) float64 per-face ``Pu, Pv`` for bump mapping (zeros if no bumps)."""
        if not self.has_bump:
            return np.zeros((1, 6))
        from .heightmap import tangent_frames

        return tangent_frames(self.vertices, self.faces, self.uvs, self.face_normals)


def _alpha_mask(g: int, model, prep):
    """``(alpha_map, alpha_cutoff)`` of a masked model (checked to have UVs), else None."""
    mat = model.material
    if getattr(mat, "alpha_cutoff", None) is None:
        return None
    if prep.uvs is None:
        raise ValueError(f"scene.models[{g}] ({model.mesh.name}): material {mat.name!r} has an alpha_map "
                         "but the mesh has no UVs")
    return mat.alpha_map, float(mat.alpha_cutoff)


def as_geometry(value, name: str = "geometry") -> SceneGeometry:
    """A scene's packed geometry: ``scene.geometry``, or a Scene standing for it."""
    if isinstance(value, Scene):
        return value.geometry
    if not isinstance(value, SceneGeometry):
        raise TypeError(f"{name}: expected a SceneGeometry (scene.geometry) or a Scene, got {type(value).__name__}")
    return value


def _as_sequence(value, name):
    if isinstance(value, (str, bytes)):
        raise TypeError(f"{name}: expected a sequence, got {type(value).__name__}")
    try:
        return tuple(value)
    except TypeError:
        raise TypeError(f"{name}: expected a sequence, got {type(value).__name__}") from None


def _as_model(item, i):
    if isinstance(item, Model):
        return item
    if isinstance(item, Mesh) or _is_trimesh(item):
        return Model(item)
    if isinstance(item, tuple) and len(item) == 2:
        return Model(*item)
    raise TypeError(f"scene.models[{i}]: expected a Model, a Mesh, a trimesh.Trimesh or a (Mesh, Material) pair, "
                    f"got {type(item).__name__}")


@dataclass(frozen=True, eq=False)
class Scene:
    """What to render.

    Parameters
    ----------
    models : sequence of Model, Mesh, trimesh.Trimesh or (Mesh, Material)
        At least one.
    lights : sequence of Light (PointLight, SpotLight, DirectionalLight, AreaLight)
    camera : Camera
    ambient : float or (3,) float
        The scene's ambient intensity ``Ia`` (multiplies each material's ``ka``).
    background : float or (3,) float
        Linear colour where nothing is hit (also what a mirror shows there).
    """

    models: tuple
    lights: tuple = ()
    camera: Camera | None = None
    ambient: object = 0.1
    background: object = 0.0

    def __post_init__(self):
        set_ = object.__setattr__
        if isinstance(self.models, (Mesh, Model)) or _is_trimesh(self.models):
            set_(self, "models", (self.models,))
        models = tuple(_as_model(m, i) for i, m in enumerate(_as_sequence(self.models, "scene.models")))
        if not models:
            raise ValueError("scene.models: a scene needs at least one model")
        set_(self, "models", models)
        lights = self.lights
        if isinstance(lights, Light):
            lights = (lights,)
        lights = _as_sequence(lights, "scene.lights")
        for i, light in enumerate(lights):
            if not isinstance(light, Light):
                raise TypeError(f"scene.lights[{i}]: expected a PointLight or DirectionalLight, got {type(light).__name__}")
        set_(self, "lights", lights)
        if self.camera is not None and not isinstance(self.camera, Camera):
            raise TypeError(f"scene.camera: expected a Camera, got {type(self.camera).__name__}")
        set_(self, "ambient", as_rgb(self.ambient, "scene.ambient"))
        set_(self, "background", as_rgb(self.background, "scene.background"))
        set_(self, "_geometry_lock", threading.Lock())
        set_(self, "_geometry", None)  # the packed geometry once built: see geometry

    @property
    def geometry(self) -> SceneGeometry:
        """The packed geometry, built on first use and kept (in the private ``_geometry``).

        Built once under the scene's lock: threads rendering a new scene at
        once share one :class:`SceneGeometry`, hence one Embree BVH (its
        :meth:`~SceneGeometry.memo`), instead of racing to build and replace it.
        """
        geo = self._geometry
        if geo is None:
            with self._geometry_lock:
                geo = self._geometry
                if geo is None:
                    geo = SceneGeometry(self.models)
                    object.__setattr__(self, "_geometry", geo)  # frozen: the one write, under the lock
        return geo

    @property
    def has_geometry(self) -> bool:
        """Whether :attr:`geometry` has been built (reading this does not build it)."""
        return self._geometry is not None

    def __getstate__(self):
        """Pickle the definition only (models, lights, camera, ambient,
        background): the packed geometry and its Embree BVH are rebuilt once,
        on first render, wherever the scene is unpickled; the lock is new there."""
        state = dict(self.__dict__)
        state.pop("_geometry", None)
        state.pop("_geometry_lock", None)
        return state

    def __setstate__(self, state):
        self.__dict__.update(state)
        object.__setattr__(self, "_geometry_lock", threading.Lock())
        object.__setattr__(self, "_geometry", None)

    def replace(self, *, geometry: SceneGeometry | None = None, **changes) -> "Scene":
        """A copy with some fields changed; keeps the packed geometry and
        Embree BVH when ``models`` is unchanged.

        Parameters
        ----------
        geometry : SceneGeometry, optional
            The copy's packed geometry instead: a variant of this scene's geometry
            with other material rows or colours, sharing its arrays and BVH
            (:func:`raycast_shade.shading.terms.with_materials`), for the same meshes
            (``models`` may change their materials only).
        **changes
            Fields of the dataclass (``models``, ``lights``, ``camera``, ...).
        """
        new = dataclasses.replace(self, **changes)
        if geometry is not None:
            if not isinstance(geometry, SceneGeometry):
                raise TypeError(f"geometry: expected a SceneGeometry, got {type(geometry).__name__}")
            if geometry.n_models != len(new.models):
                raise ValueError(f"geometry: packs {geometry.n_models} models, the scene has {len(new.models)}")
        keep = geometry if geometry is not None else None if "models" in changes else self._geometry
        if keep is not None:
            object.__setattr__(new, "_geometry", keep)
        return new

    def packed_lights(self) -> np.ndarray:
        """The kernels' light rows, positions re-centred like the geometry.

        Each light packs itself (``light.pack(origin)``).

        Returns
        -------
        (L, LIGHT_SIZE) = (L, 24) float64
            Per light, the slots of :mod:`raycast_shade.common.layout` (its module docstring
            lists them): kind, position or direction towards the light, radiance, attenuation
            law and ``k``, shadows, a spot's axis, cones and exponent, an area light's axes and
            shape, and every light's sample count.
        """
        origin = self.geometry.origin
        rows = np.zeros((len(self.lights), LIGHT_SIZE))
        for i, light in enumerate(self.lights):
            rows[i] = light.pack(origin)
        return rows
