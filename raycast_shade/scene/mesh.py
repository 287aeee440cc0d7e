"""Triangle meshes: validated arrays, file loading, shading-ready normals."""

from __future__ import annotations

import os
import warnings
from dataclasses import dataclass, field
from functools import cached_property
from typing import NamedTuple

import numpy as np

from ..common.validate import as_array, as_bool, as_choice, as_name, as_scalar, pow2_scaled
from ..common.stack import user_stacklevel
from ..common.warnings import CreaseWarning, DroppedOnLoadWarning, ZeroNormalWarning
from .normals import WEIGHTINGS, WindingWarning, face_normals, reversed_duplicates, vertex_normals, winding_conflicts
from .pitfalls import SHARP_DEGREES, sharp_edges
from .tangents import check_tangents

__all__ = ["Mesh", "PreparedMesh", "ZeroNormalWarning", "COLOR_MODES"]

COLOR_MODES = ("auto", "vertex", "face")


class PreparedMesh(NamedTuple):
    """The arrays the renderer uses, after normals are resolved.

    Attributes
    ----------
    vertices : (V, 3) float64
    faces : (F, 3) int64
    normals : (V, 3) float64
        Unit vertex normals, or zero where none is defined.
    uvs : (V, 2) float64 or None
    face_normals : (F, 3) float64
        True geometric normals (right-hand rule), zero for degenerate faces.
    colors : (V, 3) or (F, 3) float64 or None
        Linear kd per (split) vertex or per face, as ``color_mode`` says.
    color_mode : {"vertex", "face"} or None
    tangents : (V, 4) float64 or None
        The mesh's tangents (xyz, handedness w) per (split) vertex, as given.
    """

    vertices: np.ndarray
    faces: np.ndarray
    normals: np.ndarray
    uvs: np.ndarray | None
    face_normals: np.ndarray
    colors: np.ndarray | None = None
    color_mode: str | None = None
    tangents: np.ndarray | None = None


def _readonly(a):
    if a is not None:
        a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class Mesh:
    """A triangle mesh.

    Every array is copied on construction and kept read-only: a later change
    to the caller's array does not reach the mesh.

    Parameters
    ----------
    vertices : (V, 3) array_like of float
        Finite positions.
    faces : (F, 3) array_like of int
        Vertex indices, ``0 <= i < V``, counter-clockwise seen from the front.
    normals : (V, 3) array_like of float, optional
        Vertex normals, any non-zero length. When absent they are averaged from
        the faces. Zero rows are allowed (the face normal is used there) and
        counted in a :class:`ZeroNormalWarning`.
    uvs : (V, 2) array_like of float, optional
        Per-vertex texture coordinates.
    weighting : {"angle", "area", "uniform"}
        Weight of each face in a computed vertex normal.
    crease_angle : float, optional
        Degrees in (0, 180]. Split vertices where faces meet at a sharper
        angle, so hard edges stay hard. Ignored when ``normals`` is given.
    name : str
        For messages and reports.
    colors : (V, 3) or (F, 3) array_like of float, optional
        Linear RGB per vertex (interpolated over each face) or per face (one
        per face), used as the diffuse coefficient kd in place of the
        material's (a ``kd_map`` still multiplies it). Values ``>= 0``.
    color_mode : {"auto", "vertex", "face"} or None
        Which ``colors`` are; ``"auto"`` tells by the row count (an error
        when the mesh has as many vertices as faces). None is ``"auto"``: it
        is what a mesh without colours stores, so ``dataclasses.replace``
        of such a mesh validates again.
    tangents : (V, 4) array_like of float, optional
        Per-vertex tangent ``xyz`` (along increasing u) and handedness ``w``
        (+1 or -1: the bitangent is ``w (n x t)``), as glTF's ``TANGENT``; read
        by a material's ``normal_map``, kept as written. When absent, a normal
        map's tangents are computed from the UVs
        (:func:`raycast_shade.scene.tangents.vertex_tangents`). A zero
        tangent, or one along its vertex's normal, is refused (here when
        the normals are given, else when a frame is prepared).
    """

    vertices: np.ndarray
    faces: np.ndarray
    normals: np.ndarray | None = None
    uvs: np.ndarray | None = None
    weighting: str = "angle"
    crease_angle: float | None = None
    name: str = field(default="mesh")
    colors: np.ndarray | None = None
    color_mode: str = "auto"
    tangents: np.ndarray | None = None

    def __post_init__(self):
        set_ = object.__setattr__
        set_(self, "name", as_name(self.name, f"{type(self).__name__}.name"))  # first: every message uses it
        v = as_array(self.vertices, f"{self.name}.vertices", dtype=np.float64, shape=(None, 3), copy=True)
        if v.shape[0] == 0:
            raise ValueError(f"{self.name}.vertices: the mesh has no vertices")
        f = as_array(self.faces, f"{self.name}.faces", dtype=np.int64, shape=(None, 3), copy=True)
        if f.shape[0] == 0:
            raise ValueError(f"{self.name}.faces: the mesh has no faces")
        if f.min() < 0:
            i = int(np.argmin(f.min(axis=1)))
            raise ValueError(f"{self.name}.faces: negative vertex index in face {i}: {f[i].tolist()}")
        if f.max() >= v.shape[0]:
            i = int(np.argmax(f.max(axis=1)))
            raise ValueError(
                f"{self.name}.faces: face {i} indexes vertex {int(f[i].max())}, "
                f"but there are only {v.shape[0]} vertices"
            )
        set_(self, "vertices", _readonly(v))
        set_(self, "faces", _readonly(f))
        if self.normals is not None:
            n = as_array(self.normals, f"{self.name}.normals", dtype=np.float64, shape=(v.shape[0], 3), copy=True)
            zero = int(np.count_nonzero(~n.any(axis=1)))
            if zero:
                warnings.warn(f"{self.name}.normals: {zero} of {len(n)} vertex normal(s) are zero; the face "
                              "normal is used at those vertices", ZeroNormalWarning, stacklevel=3)
            set_(self, "normals", _readonly(n))
        if self.uvs is not None:
            uv = as_array(self.uvs, f"{self.name}.uvs", dtype=np.float64, shape=(v.shape[0], 2), copy=True)
            set_(self, "uvs", _readonly(uv))
        if self.tangents is not None:
            t = as_array(self.tangents, f"{self.name}.tangents", dtype=np.float64, shape=(v.shape[0], 4), copy=True)
            if not np.all(np.isfinite(t)):
                raise ValueError(f"{self.name}.tangents: must be finite")
            bad = np.flatnonzero(np.abs(t[:, 3]) != 1.0)
            if len(bad):
                raise ValueError(f"{self.name}.tangents: the handedness w (column 3) must be +1 or -1, got "
                                 f"{t[bad[0], 3]} at vertex {int(bad[0])}")
            check_tangents(t, self.normals, f"{self.name}.tangents")
            set_(self, "tangents", _readonly(t))
        _set_colors(self, v.shape[0], f.shape[0])
        set_(self, "weighting", as_choice(self.weighting, f"{self.name}.weighting", WEIGHTINGS))
        if self.crease_angle is not None:
            set_(
                self,
                "crease_angle",
                as_scalar(self.crease_angle, f"{self.name}.crease_angle", minimum=0.0, exclusive=True, maximum=180.0),
            )

    # -- construction -----------------------------------------------------------------
    @classmethod
    def from_trimesh(cls, tm, *, use_normals: bool | None = None, srgb_colors: bool = True, **kwargs) -> "Mesh":
        """Wrap a :class:`trimesh.Trimesh`, or flatten a :class:`trimesh.Scene`.

        ``use_normals=None`` keeps vertex normals only when the source file
        supplied them (for a scene: every mesh in it); ``True`` always takes
        trimesh's, ``False`` never. UVs come from ``visual.uv`` and colours
        from the visual's vertex or face colours (or a glTF ``COLOR_0`` next
        to a texture) when every mesh has them; 8-bit colours are decoded
        from sRGB unless ``srgb_colors=False`` (glTF stores linear ones). A
        scene's meshes are placed by their node transforms, normals by the
        inverse transpose, and the faces of a mirrored instance are turned
        over so that they keep facing out. Materials are not part of a mesh:
        :func:`raycast_shade.load_models` brings them in.
        """
        import trimesh

        use_normals = use_normals_flag(use_normals)
        srgb_colors = as_bool(srgb_colors, "srgb_colors")
        dropped = []
        if isinstance(tm, trimesh.Trimesh):
            instances = [(tm, np.eye(4))]
        elif isinstance(tm, trimesh.Scene):
            instances = []
            for node in tm.graph.nodes_geometry:
                transform, geometry_name = tm.graph[node]
                geometry = tm.geometry.get(geometry_name)
                if isinstance(geometry, trimesh.Trimesh) and len(geometry.faces):
                    instances.append((geometry, np.asarray(transform, np.float64)))
                else:
                    dropped.append(f"{geometry_name!r} ({type(geometry).__name__}, no triangles)")
            if not instances:
                raise ValueError("the trimesh scene holds no triangle meshes")
        else:
            raise TypeError(f"tm: expected a trimesh.Trimesh or trimesh.Scene, got {type(tm).__name__}")
        name = kwargs.get("name", "mesh")
        parts = [_instance(g, m, use_normals) + visual_colors(g, srgb_colors, name) for g, m in instances]
        offsets = np.cumsum([0] + [len(p[0]) for p in parts[:-1]])
        vertices = np.concatenate([p[0] for p in parts])
        faces = np.concatenate([p[1] + o for p, o in zip(parts, offsets)])
        normals = np.concatenate([p[2] for p in parts]) if all(p[2] is not None for p in parts) else None
        uvs = np.concatenate([p[3] for p in parts]) if all(p[3] is not None for p in parts) else None
        modes = {p[5] for p in parts}
        colors, mode = None, None
        if len(modes) == 1 and None not in modes:
            colors, mode = np.concatenate([p[4] for p in parts]), modes.pop()
        elif any(p[5] is not None for p in parts):
            dropped.append("the colours (the meshes do not all have colours of one kind, per vertex or per face)")
        if normals is None and any(p[2] is not None for p in parts):
            dropped.append("the vertex normals (only some of the meshes have them; they are averaged instead)")
        if uvs is None and any(p[3] is not None for p in parts):
            dropped.append("the UVs (only some of the meshes have them)")
        if dropped:
            warnings.warn(f"{name}: dropped {'; '.join(dropped)}: export the file with "
                          "triangle meshes only, each with the same attributes, to keep everything",
                          DroppedOnLoadWarning, stacklevel=2)
        if colors is not None:
            kwargs.setdefault("colors", colors)
            kwargs.setdefault("color_mode", mode)
        return cls(vertices, faces, normals=normals, uvs=uvs, **kwargs)

    @classmethod
    def load(cls, path, *, merge: bool = False, **kwargs) -> "Mesh":
        """Load any file trimesh reads (OBJ, PLY, STL, OFF, GLB/glTF, ...).

        Vertices are kept as written: a cube whose faces have vertices of
        their own keeps its hard edges (``merge=True`` welds coincident
        vertices, as ``trimesh.load`` does; an STL file, a triangle soup with
        no shared vertices at all, is always welded). Vertex normals stored
        in the file are kept (``use_normals=None``, see
        :meth:`from_trimesh`), and so are vertex or face colours; a file with
        several meshes becomes one. Materials and textures need
        :func:`raycast_shade.load_models`: here they are dropped with a
        :class:`DroppedOnLoadWarning`.

        Raises
        ------
        ValueError
            When the file is missing, unreadable or holds no triangles, or
            when vertices are not finite (trimesh would drop their faces).
        """
        if "use_normals" in kwargs:  # checked before the file is read
            kwargs["use_normals"] = use_normals_flag(kwargs["use_normals"])
        from .filecheck import naming_file

        with naming_file(path):  # a reader's IndexError or KeyError too: a ValueError naming the file
            tm, srgb = read_trimesh(path, merge)
            kwargs.setdefault("name", os.path.basename(os.fspath(path)))
            meshes = tm.geometry.values() if _is_scene(tm) else [tm]
            lost = sorted({d for m in meshes for d in _material_names(m)})
            if lost:
                warnings.warn(f"{kwargs['name']}: dropped the material(s) {', '.join(lost)} (Mesh.load keeps "
                              "geometry, UVs and colours): use raycast_shade.load_models to bring materials and textures in",
                              DroppedOnLoadWarning, stacklevel=2)
            if os.fspath(path).lower().endswith(".off") and not _is_scene(tm):  # trimesh drops OFF colours
                from .fileparse import off_colors, off_mesh_colors

                colors, mode = off_mesh_colors(off_colors(os.fspath(path)), len(tm.vertices), len(tm.faces),
                                               kwargs["name"])
                if colors is not None and "colors" not in kwargs:
                    kwargs["colors"], kwargs["color_mode"] = colors, mode
            mesh = cls.from_trimesh(tm, srgb_colors=srgb, **kwargs)
            dup = reversed_duplicates(mesh.faces, mesh.vertices)
            if dup.any():
                warnings.warn(f"{mesh.name}: dropped {int(dup.sum())} face(s) repeating another with the opposite "
                              "winding (two-sided surfaces are lit from the side seen, and the pair cancels "
                              "averaged normals)", DroppedOnLoadWarning, stacklevel=2)
                colors = mesh.colors
                if colors is not None and mesh.color_mode == "face":
                    colors = colors[~dup]
                mesh = cls(mesh.vertices, mesh.faces[~dup], normals=mesh.normals, uvs=mesh.uvs,
                           weighting=mesh.weighting, crease_angle=mesh.crease_angle, name=mesh.name, colors=colors,
                           color_mode=mesh.color_mode or "auto", tangents=mesh.tangents)
            return mesh

    # -- derived ------------------------------------------------------------------------
    @cached_property
    def bounds(self) -> np.ndarray:
        """(2, 3) float64 axis-aligned bounding box (read-only; computed once: the vertices are
        read-only, and every render's pitfall check reads it, 23 ms a frame at 1.31 M faces)."""
        return _readonly(np.stack([self.vertices.min(axis=0), self.vertices.max(axis=0)]))

    @cached_property
    def prepared(self) -> PreparedMesh:
        """Normals resolved (given, or averaged with weighting and crease)."""
        if self.normals is not None:
            # Scaled by powers of two first: normals of length 1e-200 or 1e300 stay directions.
            scaled = pow2_scaled(self.normals)
            length = np.linalg.norm(scaled, axis=1, keepdims=True)
            normals = np.divide(scaled, length, out=np.zeros_like(scaled), where=length > 0)
            verts, faces, uvs = self.vertices, self.faces, self.uvs
        else:
            # Split vertices copy positions and faces keep their corners, so these
            # face normals are also the split mesh's.
            fn, _ = face_normals(self.vertices, self.faces)
            conflicts = winding_conflicts(self.vertices, self.faces, fn)
            if conflicts:
                warnings.warn(
                    f"{self.name}: {conflicts} edge(s) join faces wound in opposite directions, so the "
                    "computed vertex normals cancel there; make the winding consistent first (for "
                    "example trimesh.repair.fix_winding) or pass normals",
                    WindingWarning,
                    stacklevel=user_stacklevel(),
                )
            twins = int(np.count_nonzero(reversed_duplicates(self.faces, self.vertices)))
            if twins:
                warnings.warn(
                    f"{self.name}: {twins} face(s) repeat another face with the opposite winding (the same "
                    "triangle twice, a two-sided sheet), so the computed vertex normals cancel around them; "
                    "drop one of each pair (raycast_shade.scene.normals.reversed_duplicates finds them; "
                    "load_models and Mesh.load drop them) or pass normals",
                    WindingWarning,
                    stacklevel=user_stacklevel(),
                )
            if self.crease_angle is None:
                sharp = sharp_edges(self.vertices, self.faces, fn)
                if sharp:
                    warnings.warn(
                        f"{self.name}: {sharp} edge(s) join faces at more than {SHARP_DEGREES:g} degrees, and "
                        "the computed vertex normals average across them, rounding hard edges off: pass "
                        "crease_angle=30 (degrees; on the command line --crease-angle 30) to keep them hard, "
                        "or normals",
                        CreaseWarning,
                        stacklevel=user_stacklevel(),
                    )
            verts, faces, normals, source = vertex_normals(
                self.vertices, self.faces, self.weighting, self.crease_angle
            )
            uvs = None if self.uvs is None else self.uvs[source]
            colors = self.colors
            if colors is not None and self.color_mode == "vertex":
                colors = colors[source]
            tangents = None if self.tangents is None else self.tangents[source]
            return PreparedMesh(verts, faces, normals, uvs, fn, colors, self.color_mode, tangents)
        fn, _ = face_normals(verts, faces)
        return PreparedMesh(verts, faces, normals, uvs, fn, self.colors, self.color_mode, self.tangents)

    def __repr__(self) -> str:
        return f"Mesh(name={self.name!r}, vertices={len(self.vertices)}, faces={len(self.faces)})"


def _is_scene(tm) -> bool:
    import trimesh

    return isinstance(tm, trimesh.Scene)


def use_normals_flag(value):
    """``use_normals`` checked: None (the file decides), True or False; never 0, 1 or a string."""
    return None if value is None else as_bool(value, "use_normals")


def read_trimesh(path, merge: bool = False, *, checked: bool = False, gltf: dict | None = None):
    """``trimesh.load`` a file, keeping its vertices as written.

    The file is checked first (:mod:`.filecheck`: content against extension, an OBJ's lines, face
    indices): trimesh never reads it as something it is not. ``merge`` welds coincident vertices;
    ``checked``: the caller has run :func:`~raycast_shade.scene.filecheck.check_mesh_file` (``gltf``: the
    JSON it returned). glTF geometry trimesh reads wrong is made plain first (:mod:`.gltfgeometry`).

    Returns
    -------
    tm : trimesh.Trimesh or trimesh.Scene
    srgb : bool
        Whether the format's 8-bit colours are sRGB-encoded (all but glTF).

    Raises
    ------
    ValueError
        Missing, unreadable, content its extension belies, a bad OBJ line, a
        face index out of range, no triangles, or non-finite vertices.
    """
    import trimesh

    from .filecheck import check_face_indices, check_mesh_file, locate_bad_index
    from .fileparse import load_obj, load_off
    from .gltfgeometry import load_gltf_trimesh

    merge = as_bool(merge, "merge")
    path = os.fspath(path)
    if not checked:
        gltf = check_mesh_file(path)
    elif gltf is None and path.lower().endswith((".gltf", ".glb")):
        gltf = check_mesh_file(path)
    try:
        # Not force="mesh": trimesh 5 then concatenates through a scene and drops the file's normals.
        # Not processed: processing welds split vertices (rounding hard edges off) and drops faces
        # on NaN/inf vertices without a word.
        if gltf is not None:
            tm = load_gltf_trimesh(path, gltf)
        else:
            readers = {".obj": load_obj, ".off": load_off}  # the formats whose polygons the library triangulates
            tm = readers.get(os.path.splitext(path)[1].lower(), lambda p: trimesh.load(p, process=False))(path)
    except ImportError as exc:
        raise MissingReaderError(f"cannot read mesh file {path}: {_install_hint(exc)}") from None
    except ValueError as exc:
        if str(exc).startswith(os.path.basename(path) + ":"):  # our own, naming the file and line
            raise
        raise ValueError(f"cannot read mesh file {path}: {exc}") from None
    except Exception as exc:
        where = locate_bad_index(path) if isinstance(exc, IndexError) else None
        raise ValueError(where or f"cannot read mesh file {path}: {exc}") from None
    meshes = tm.geometry.values() if isinstance(tm, trimesh.Scene) else [tm]
    check_face_indices(path, meshes)  # before anything indexes vertices by them
    _refuse_non_finite(path, meshes)
    ext = os.path.splitext(path)[1].lower()
    stl_inside = _archive_holds_stl(path)
    for m in meshes:
        soup = stl_inside and isinstance(m, trimesh.Trimesh) and len(m.vertices) == 3 * len(m.faces)
        if isinstance(m, trimesh.Trimesh) and (merge or ext == ".stl" or soup):
            m.process()  # what trimesh.load(path) would have done: merge duplicate vertices
    if not any(isinstance(m, trimesh.Trimesh) and len(m.faces) for m in meshes):
        raise ValueError(f"mesh file {path} holds no triangles")
    if isinstance(tm, trimesh.Scene) and not any(len(getattr(tm.geometry.get(tm.graph[n][1]), "faces", ()))
                                                 for n in tm.graph.nodes_geometry):
        raise ValueError(f"mesh file {path}: no node of its scene places a mesh with triangles (nothing to draw)")
    return tm, ext not in (".glb", ".gltf")


class MissingReaderError(ImportError, ValueError):
    """A mesh format whose optional reader is not installed (the message names the pip package);
    a ValueError too, so that callers that report bad input report it the same way."""


# Python modules trimesh's optional readers import, and the pip package that provides each.
_PIP_NAMES = {"lxml": "lxml", "collada": "pycollada", "networkx": "networkx", "shapely": "shapely",
              "rtree": "rtree", "scipy": "scipy", "PIL": "pillow", "cascadio": "cascadio", "gmsh": "gmsh",
              "meshio": "meshio", "mapbox_earcut": "mapbox-earcut", "manifold3d": "manifold3d",
              "xxhash": "xxhash", "jsonschema": "jsonschema", "svg": "svg.path", "openctm": "openctm"}


def _install_hint(exc: ImportError) -> str:
    """The missing module and the pip package to install, from an ImportError."""
    module = getattr(exc, "name", None)
    if not module:
        import re

        m = re.search(r"No module named '([^']+)'|pip install ([\w.\-]+)", str(exc))
        module = (m.group(1) or m.group(2)) if m else None
    if not module:
        return f"an optional reader is not installed ({exc})"
    top = module.split(".")[0]
    package = _PIP_NAMES.get(top, top)
    return f"this format needs the optional package {package!r} (module {top!r}): pip install {package}"


def _archive_holds_stl(path: str) -> bool:
    """Whether a zip or tar archive holds an STL file (its meshes come as triangle soups)."""
    import tarfile
    import zipfile

    try:
        if zipfile.is_zipfile(path):
            with zipfile.ZipFile(path) as z:
                names = z.namelist()
        elif tarfile.is_tarfile(path):
            with tarfile.open(path) as t:
                names = t.getnames()
        else:
            return False
    except (OSError, zipfile.BadZipFile, tarfile.TarError):
        return False
    return any(n.lower().endswith(".stl") and "__macosx" not in n.lower() for n in names)


def _material_names(tm) -> list:
    """Names of the materials a trimesh's visual carries (none for plain colours)."""
    mat = getattr(getattr(tm, "visual", None), "material", None)
    if mat is None:
        return []
    return [repr(getattr(mat, "name", None) or type(mat).__name__)]


def visual_colors(tm, srgb: bool, name: str, alpha: str = "warn") -> tuple:
    """A trimesh's colours as ``(colors (N, 3) float64 linear, mode)``, or ``(None, None)``.

    Vertex or face colours of a ``ColorVisuals``, or the vertex colours a
    ``TextureVisuals`` keeps next to its texture (glTF ``COLOR_0``); 8-bit
    values are divided by 255 and, with ``srgb``, decoded to linear. An alpha
    channel that is not opaque is dropped with a warning (``alpha="ignore"``:
    silently, where the file says alpha means nothing, as glTF's ``OPAQUE``).
    """
    vis = getattr(tm, "visual", None)
    raw, mode = None, None
    if vis is None:
        return None, None
    if getattr(vis, "kind", None) in ("vertex", "face") and hasattr(vis, "vertex_colors"):
        mode = vis.kind
        raw = vis.vertex_colors if mode == "vertex" else vis.face_colors
    else:
        attrs = getattr(vis, "vertex_attributes", None)
        if attrs is not None and "color" in attrs:
            raw, mode = attrs["color"], "vertex"
    if raw is None:
        return None, None
    raw = np.asarray(raw)
    c = raw.astype(np.float64) / np.iinfo(raw.dtype).max if raw.dtype.kind in "ui" else raw.astype(np.float64)
    if c.ndim != 2 or c.shape[1] not in (3, 4):
        return None, None
    if c.shape[1] == 4:
        if alpha == "warn" and np.any(c[:, 3] < 1.0):
            warnings.warn(f"{name}: dropped the colours' alpha (transparency is not modelled)",
                          DroppedOnLoadWarning, stacklevel=4)
        c = c[:, :3]
    if srgb:
        from .texture import srgb_to_linear

        c = srgb_to_linear(np.clip(c, 0.0, 1.0))
    return c, mode


def _set_colors(mesh, nv: int, nf: int) -> None:
    """Validate ``mesh.colors`` and resolve ``color_mode`` (None without colours)."""
    from .material import _warn_byte_range

    set_ = object.__setattr__
    # None is what a mesh without colours stores: dataclasses.replace hands it back.
    mode = as_choice("auto" if mesh.color_mode is None else mesh.color_mode, f"{mesh.name}.color_mode",
                     COLOR_MODES)
    if mesh.colors is None:
        set_(mesh, "color_mode", None)
        return
    c = as_array(mesh.colors, f"{mesh.name}.colors", dtype=np.float64, shape=(None, 3), copy=True)
    if mode == "auto":
        if len(c) == nv == nf:
            raise ValueError(f"{mesh.name}.colors: the mesh has as many vertices as faces ({nv}); pass "
                             "color_mode='vertex' or 'face'")
        mode = "vertex" if len(c) == nv else "face" if len(c) == nf else None
    want = nv if mode == "vertex" else nf
    if mode is None or len(c) != want:
        raise ValueError(f"{mesh.name}.colors: expected one row per vertex ({nv}) or per face ({nf}), "
                         f"got {len(c)}")
    if c.size and c.min() < 0:
        raise ValueError(f"{mesh.name}.colors: must be >= 0, got min {c.min():g}")
    if c.size:
        _warn_byte_range(c, f"{mesh.name}.colors", "colors")
    set_(mesh, "colors", _readonly(c))
    set_(mesh, "color_mode", mode)


def _refuse_non_finite(path, meshes) -> None:
    """A ValueError naming the file and the counts if any vertex is NaN or inf."""
    bad_vertices = bad_faces = 0
    for m in meshes:
        v = np.asarray(getattr(m, "vertices", np.zeros((0, 3))), np.float64)
        if v.ndim != 2 or not len(v):
            continue
        finite = np.isfinite(v).all(axis=1)
        if finite.all():
            continue
        bad_vertices += int(np.count_nonzero(~finite))
        faces = np.asarray(getattr(m, "faces", np.zeros((0, 3), np.int64)))
        if faces.ndim == 2 and faces.size:
            inside = (faces >= 0) & (faces < len(v))
            touch = ~finite[np.where(inside, faces, 0)] & inside
            bad_faces += int(np.count_nonzero(touch.any(axis=1)))
    if bad_vertices:
        raise ValueError(f"mesh file {path}: {bad_vertices} vertex(es) with non-finite coordinates (NaN or inf), "
                         f"used by {bad_faces} face(s); fix or remove them in the file (they cannot be rendered, "
                         "and dropping them would change the mesh without a word)")


def _instance(tm, transform, use_normals):
    """One placed trimesh: (vertices, faces, normals or None, uvs or None) as float64/int64."""
    rot = transform[:3, :3]
    vertices = np.asarray(tm.vertices, np.float64) @ rot.T + transform[:3, 3]
    faces = np.asarray(tm.faces, np.int64)
    if np.linalg.det(rot) < 0:
        faces = faces[:, ::-1]  # a mirror turns the right-hand rule inside out
    normals = None
    # In trimesh's cache only when the file (or the user) gave normals; "in" first drops stale entries.
    cached = tm._cache.cache.get("vertex_normals") if "vertex_normals" in tm._cache else None
    if use_normals or (use_normals is None and cached is not None and cached.shape == tm.vertices.shape):
        n = np.asarray(tm.vertex_normals, np.float64) @ np.linalg.inv(rot)
        length = np.linalg.norm(n, axis=1, keepdims=True)
        normals = np.divide(n, length, out=np.zeros_like(n), where=length > 0)
    uvs = None
    uv = getattr(getattr(tm, "visual", None), "uv", None)
    if uv is not None and len(uv) == len(tm.vertices):
        uvs = np.asarray(uv, dtype=np.float64)
    return vertices, faces, normals, uvs
