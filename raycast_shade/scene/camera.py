"""Cameras: perspective and orthographic look-at, with the image size."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..common.choices import PROJECTIONS
from ..common.validate import as_bool, as_choice, as_int, as_scalar, as_vec3, check_memory, pow2_scaled
from .framememory import FRAME_BYTES_PER_PIXEL, frame_bytes

__all__ = ["Camera", "PROJECTIONS", "FRAME_BYTES_PER_PIXEL"]

# What one rendered frame holds per pixel (hit buffer, image, normals, 8-bit image) and what
# buffers, samples and terms add: scene.framememory. render() refuses a camera whose frame
# exceeds common.validate.memory_limit() before allocating any of it.



@dataclass(frozen=True, eq=False)
class Camera:
    """A look-at camera.

    Pixel ``(x, y)`` (``y`` down) has its centre at ``(x + 0.5, y + 0.5)``.

    Parameters
    ----------
    eye, target : (3,) float
        Must differ.
    up : (3,) float
        Must not be parallel to ``target - eye``.
    fov : float
        Vertical field of view in degrees, in (0, 180) (perspective).
    width, height : int
        Image size in pixels, ``> 0``.
    projection : {"perspective", "orthographic"}
    ortho_height : float
        Height of the view in world units (orthographic), ``> 0``.
    fx, fy, cx, cy : float, optional
        Intrinsics in pixels, OpenCV's convention (pixel centres at integer
        coordinates; :mod:`raycast_shade.scene.projection`): all four or
        none. ``fx, fy > 0`` (orthographic: pixels per world unit); the
        principal point may be anywhere. Given, they define the projection
        and ``fov`` (``ortho_height``) is set to the vertical extent they
        imply. See :meth:`from_opencv`, ``docs/vision.md``.
    distortion : sequence of float, optional
        Lens distortion coefficients (perspective only), OpenCV's models in
        normalised coordinates: ``distortion_model="opencv"`` takes
        ``(k1, k2, p1, p2)`` or ``(k1, k2, p1, p2, k3)``; ``"fisheye"``
        (``cv2.fisheye``) takes ``(k1, k2, k3, k4)``. The rays pass through
        the distorted pixel centres exactly
        (:mod:`raycast_shade.visibility.distortion`): every buffer is that of
        the distorted image, with no warp. None (or all zero): a pinhole. A
        radial model that folds inside the frame (OpenCV ``k1 = -50``)
        leaves the pixels beyond the fold empty: a
        :class:`~raycast_shade.common.warnings.LensFoldWarning` gives the
        share of the frame with rays (:mod:`raycast_shade.scene.lens`).
    distortion_model : {"opencv", "fisheye"}
    """

    eye: np.ndarray
    target: np.ndarray = (0.0, 0.0, 0.0)
    up: np.ndarray = (0.0, 1.0, 0.0)
    fov: float = 45.0
    width: int = 640
    height: int = 480
    projection: str = "perspective"
    ortho_height: float = 2.0
    fx: float | None = None
    fy: float | None = None
    cx: float | None = None
    cy: float | None = None
    distortion: tuple | None = None
    distortion_model: str = "opencv"

    def __post_init__(self):
        set_ = object.__setattr__
        eye = as_vec3(self.eye, "camera.eye")
        target = as_vec3(self.target, "camera.target")
        up = as_vec3(self.up, "camera.up", nonzero=True)
        set_(self, "eye", eye)
        set_(self, "target", target)
        set_(self, "up", up)
        with np.errstate(over="ignore"):  # eye 1e308 and target -1e308: the difference is inf
            fwd = target - eye
        if not np.all(np.isfinite(fwd)):
            raise ValueError("camera.eye: target - eye overflows float64; bring eye and target closer")
        # Relative to the coordinates only: a scene 1e-12 across is a scene, not a coincidence.
        # Max-norm, not the Euclidean one, whose squares underflow to 0 at 1e-200.
        scale = max(np.abs(eye).max(), np.abs(target).max())
        if not np.abs(fwd).max() > 1e-12 * scale:
            raise ValueError("camera.eye: eye and target coincide; the view direction is undefined")
        fwd = pow2_scaled(fwd)
        fwd = fwd / np.linalg.norm(fwd)
        up_dir = pow2_scaled(up)
        side = np.cross(fwd, up_dir / np.linalg.norm(up_dir))
        if not np.linalg.norm(side) > 1e-9:
            raise ValueError("camera.up: parallel to the view direction (target - eye)")
        set_(self, "fov", as_scalar(self.fov, "camera.fov", minimum=0.0, exclusive=True))
        if not self.fov < 180.0:
            raise ValueError(f"camera.fov: must be < 180 degrees, got {self.fov}")
        set_(self, "width", as_int(self.width, "camera.width", minimum=1))
        set_(self, "height", as_int(self.height, "camera.height", minimum=1))
        set_(self, "projection", as_choice(self.projection, "camera.projection", PROJECTIONS))
        set_(self, "ortho_height", as_scalar(self.ortho_height, "camera.ortho_height", minimum=0.0, exclusive=True))
        self._check_intrinsics()
        self._check_distortion()

    # -- lens distortion (raycast_shade.visibility.distortion) ----------------------------------------

    def _check_distortion(self):
        from ..common.validate import as_array

        model = as_choice(self.distortion_model, "camera.distortion_model", ("opencv", "fisheye"))
        object.__setattr__(self, "distortion_model", model)
        if self.distortion is None:
            return
        if isinstance(self.distortion, (str, bytes)):
            raise TypeError("camera.distortion: expected coefficients (numbers), got a string")
        k = as_array(self.distortion, "camera.distortion", dtype=np.float64).ravel()
        counts = (4, 5) if model == "opencv" else (4,)
        if len(k) not in counts:
            names = "(k1, k2, p1, p2) or (k1, k2, p1, p2, k3)" if model == "opencv" else "(k1, k2, k3, k4)"
            raise ValueError(f"camera.distortion: the {model} model takes {names}, got {len(k)} values")
        if self.orthographic and np.any(k != 0.0):
            raise ValueError("camera.distortion: lens distortion needs a perspective camera")
        object.__setattr__(self, "distortion", tuple(float(c) for c in k))
        if self.distorted:  # a fold inside the frame: say how much of it has rays, before any is cast
            from .lens import warn_fold

            warn_fold(self)

    @property
    def distorted(self) -> bool:
        """True if the camera has non-zero distortion coefficients (its rays are not a pinhole's)."""
        return self.distortion is not None and any(c != 0.0 for c in self.distortion)

    def _check_intrinsics(self):
        set_ = object.__setattr__
        given = [k for k in ("fx", "fy", "cx", "cy") if getattr(self, k) is not None]
        if not given:
            return
        if len(given) != 4:
            missing = [k for k in ("fx", "fy", "cx", "cy") if k not in given]
            raise ValueError(f"camera.{missing[0]}: intrinsics need all of fx, fy, cx, cy, got only {given}")
        for k in ("fx", "fy"):
            set_(self, k, as_scalar(getattr(self, k), f"camera.{k}", minimum=0.0, exclusive=True))
        for k in ("cx", "cy"):
            set_(self, k, as_scalar(getattr(self, k), f"camera.{k}"))
        if self.orthographic:
            set_(self, "ortho_height", self.height / self.fy)
        else:
            set_(self, "fov", float(np.degrees(2.0 * np.arctan(0.5 * self.height / self.fy))))

    @property
    def basis(self):
        """Orthonormal ``(right, up, forward)``, each (3,) float64, read-only."""
        # Computed once: eye, target and up are read-only copies, and a frame asks for the basis
        # about six times (0.13 ms each: np.cross is slow on 3-vectors), 6% of a 640x480 frame.
        b = getattr(self, "_basis", None)  # two threads may both compute it: the same bits
        if b is None:
            # Powers of two first (exact, so the bits are those of the plain formula):
            # an up of 1e-200 or a view of 1e300 would under/overflow in the norms.
            fwd = pow2_scaled(self.target - self.eye)
            fwd = fwd / np.linalg.norm(fwd)
            right = np.cross(fwd, pow2_scaled(self.up))
            right /= np.linalg.norm(right)
            up = np.cross(right, fwd)
            for a in (right, up, fwd):
                a.setflags(write=False)
            b = (right, up, fwd)
            object.__setattr__(self, "_basis", b)
        return b

    def check_frame_memory(self, buffers=(), samples: int = 1, terms=None, lights: int = 0,
                           band_rows: int = 0, reused=()) -> None:
        """Refuse (ValueError, with the figure) a frame larger than
        :func:`~raycast_shade.common.validate.memory_limit`.

        Parameters
        ----------
        buffers, samples, terms, lights, band_rows, reused
            What the frame is asked for and how it is rendered, as
            :func:`~raycast_shade.scene.framememory.frame_bytes` counts it
            (the default: the plain frame, ``FRAME_BYTES_PER_PIXEL``).
        """
        need = frame_bytes(self.width, self.height, buffers, samples, terms, lights, band_rows, reused)
        check_memory(need, f"camera.width x camera.height: {self.width} x {self.height} pixels", "a frame")

    @property
    def orthographic(self) -> bool:
        return self.projection == "orthographic"

    def half_extents(self):
        """Half the image plane's width and height at unit distance
        (perspective) or in world units (orthographic)."""
        if self.fx is not None:
            return 0.5 * self.width / self.fx, 0.5 * self.height / self.fy
        aspect = self.width / self.height
        if self.orthographic:
            h = 0.5 * self.ortho_height
        else:
            h = float(np.tan(np.radians(self.fov) / 2.0))
        return h * aspect, h

    def replace(self, **changes) -> "Camera":
        from dataclasses import replace

        return replace(self, **changes)

    # -- matrices (raycast_shade.scene.projection; docs/vision.md) -----------------------------------

    @classmethod
    def from_opencv(cls, K, R, t, width, height, *, projection="perspective", dist=None,
                    fisheye: bool = False) -> "Camera":
        """A camera from OpenCV's intrinsics ``K`` (3, 3, zero skew) and
        world-to-camera ``R`` (3, 3), ``t`` (3,) or (3, 1): ``x_cam = R x_world + t``,
        camera ``x`` right, ``y`` down, ``z`` forward; pixel centres at
        integer coordinates. ``dist``: OpenCV's distortion coefficients
        (``cv2.projectPoints``' ``distCoeffs``, 4 or 5 values; with
        ``fisheye=True``, ``cv2.fisheye``'s ``D``, 4 values), see
        ``distortion``. :meth:`to_opencv` gives ``K, R, t`` back."""
        from .projection import opencv_kwargs

        fisheye = as_bool(fisheye, "fisheye")
        lens = {} if dist is None else {"distortion": dist, "distortion_model": "fisheye" if fisheye else "opencv"}
        return cls(width=width, height=height, **opencv_kwargs(K, R, t, projection), **lens)

    @classmethod
    def from_opengl(cls, view, projection, width, height) -> "Camera":
        """A camera from OpenGL (4, 4) view and projection matrices, as made
        by :meth:`view_matrix` and :meth:`projection_matrix`."""
        from .projection import opengl_kwargs

        # The size first: the matrices are read in pixels of it (a bad one would be blamed on K).
        width, height = as_int(width, "width", minimum=1), as_int(height, "height", minimum=1)
        return cls(width=width, height=height, **opengl_kwargs(view, projection, width, height))

    @property
    def K(self) -> np.ndarray:
        """(3, 3) float64 OpenCV intrinsics matrix (derived from ``fov`` when not given)."""
        from .projection import intrinsics_matrix

        return intrinsics_matrix(self)

    def to_opencv(self):
        """``(K, R, t)``: (3, 3), (3, 3), (3,) float64, OpenCV's convention."""
        from .projection import extrinsics, intrinsics_matrix

        R, t = extrinsics(self)
        return intrinsics_matrix(self), R, t

    def view_matrix(self) -> np.ndarray:
        """(4, 4) float64 OpenGL world-to-view matrix (looking down ``-z``, ``y`` up)."""
        from .projection import view_matrix

        return view_matrix(self)

    def projection_matrix(self, near, far) -> np.ndarray:
        """(4, 4) float64 OpenGL projection matrix; see
        :func:`raycast_shade.scene.projection.projection_matrix`."""
        from .projection import projection_matrix

        return projection_matrix(self, near, far)

    def principal_offset(self):
        """``(ox, oy)``: the principal point's shift of the central ray along
        ``right`` and ``up`` (zero without intrinsics); see
        :func:`raycast_shade.scene.projection.principal_offset`."""
        from .projection import principal_offset

        return principal_offset(self)

    # -- framing (issue 22: "a file in, a picture out") -----------------------------------------
    @classmethod
    def fit(cls, scene_or_bounds, direction=(-0.4, -0.35, -1.0), *, margin: float = 0.05, width: int = 640,
            height: int = 480, fov: float = 45.0, up=(0.0, 1.0, 0.0), projection: str = "perspective") -> "Camera":
        """A camera that frames a scene (or points, or a bounding box) from a direction.

        The camera looks along ``direction``; among all such cameras it is the
        closest one that keeps every point inside the frame with ``margin``
        (a fraction of the frame's half-width and half-height kept free on
        each side). In closed form: with the camera's axes ``r, u, f`` and
        ``a = (1 - margin) tan(fov_x / 2)``, a point ``p`` stays inside across
        while ``|p.r - e_r| <= a (p.f - e_f)``, so the eye's depth is at most
        ``(min(p.f - p.r / a) + min(p.f + p.r / a)) / 2``, reached at
        ``e_r = a (min(p.f + p.r / a) - min(p.f - p.r / a)) / 2``; the same
        along ``u`` with ``b = (1 - margin) tan(fov / 2)``, and the eye takes
        the smaller depth, and no closer than 1% of the points' extent to the
        nearest one (at wide fields of view the closest camera would sit on
        it). The extreme point(s) of the tighter axis touch the margin on both
        sides; the other axis is centred. Orthographic: the
        view is centred on the points' extent and ``ortho_height`` fits it.

        Parameters
        ----------
        scene_or_bounds : Scene, Model, Mesh, sequence of those, (N, 3) points or (2, 3) bounds
            What to frame: the vertices of every model (placed as rendered),
            or the corners of a bounding box ``[[xmin, ymin, zmin], [xmax, ...]]``.
        direction : (3,) float
            The view direction (camera to scene); not parallel to ``up``.
        margin : float
            In [0, 1): the fraction of the half-size left free on each side.
        width, height : int
        fov : float
            Vertical field of view in degrees (perspective).
        up : (3,) float
        projection : {"perspective", "orthographic"}

        Returns
        -------
        Camera
            Its ``target`` is the point on the view axis at the depth of the
            points' bounding-box centre.
        """
        from ..common.validate import as_array

        pts = _points_of(scene_or_bounds)
        d = as_vec3(direction, "camera.fit.direction", nonzero=True)
        up_v = as_vec3(up, "camera.fit.up", nonzero=True)
        margin = as_scalar(margin, "camera.fit.margin", minimum=0.0, maximum=1.0)
        if not margin < 1.0:
            raise ValueError(f"camera.fit.margin: must be < 1 (the fraction of the half-size left free), got {margin}")
        width = as_int(width, "camera.fit.width", minimum=1)
        height = as_int(height, "camera.fit.height", minimum=1)
        projection = as_choice(projection, "camera.fit.projection", PROJECTIONS)
        fov = as_scalar(fov, "camera.fit.fov", minimum=0.0, exclusive=True)
        if not fov < 180.0:
            raise ValueError(f"camera.fit.fov: must be < 180 degrees, got {fov}")
        f = d / np.linalg.norm(d)
        r = np.cross(f, up_v / np.linalg.norm(up_v))
        if not np.linalg.norm(r) > 1e-9:
            raise ValueError("camera.fit.direction: parallel to up")
        r /= np.linalg.norm(r)
        u = np.cross(r, f)
        pts = as_array(pts, "camera.fit points", dtype=np.float64, shape=(None, 3))
        centre = 0.5 * (pts.min(axis=0) + pts.max(axis=0))
        q = pts - centre  # coordinates about the centre: no cancellation for models far from the origin
        x, y, z = q @ r, q @ u, q @ f
        extent = float(np.abs(q).max())
        if not extent > 0.0:
            raise ValueError("camera.fit: the points coincide; there is nothing to frame (give a bounding box)")
        aspect = width / height
        keep = 1.0 - margin
        if projection == "orthographic":
            er, eu = 0.5 * (x.max() + x.min()), 0.5 * (y.max() + y.min())
            h = max(float(np.ptp(y)), float(np.ptp(x)) / aspect) / keep
            ef = float(z.min()) - max(extent, h)
            eye = centre + er * r + eu * u + ef * f
            return cls(eye=eye, target=eye + (float(-ef)) * f, up=up_v, width=width, height=height,
                       projection="orthographic", ortho_height=max(h, 1e-12 * max(extent, 1.0)))
        b = keep * float(np.tan(np.radians(fov) / 2.0))
        a = b * aspect
        ax, bx = float(np.min(z - x / a)), float(np.min(z + x / a))
        ay, by = float(np.min(z - y / b)), float(np.min(z + y / b))
        # Wide fields of view could put the eye on the nearest point: keep 1% of the size in front.
        ef = min(0.5 * (ax + bx), 0.5 * (ay + by), float(z.min()) - _NEAR * extent)
        er, eu = 0.5 * a * (bx - ax), 0.5 * b * (by - ay)
        eye = centre + er * r + eu * u + ef * f
        return cls(eye=eye, target=eye + (-ef if ef < 0 else extent) * f, up=up_v, fov=fov, width=width,
                   height=height)


_NEAR = 0.01  # Camera.fit's least distance to the nearest point, in the points' extent


def _points_of(thing) -> np.ndarray:
    """The world-space points that :meth:`Camera.fit` frames (see there)."""
    from .mesh import Mesh

    if hasattr(thing, "models") and not isinstance(thing, (list, tuple)):
        thing = thing.models
    if isinstance(thing, Mesh):
        return thing.vertices
    if hasattr(thing, "mesh") and isinstance(getattr(thing, "mesh"), Mesh):
        pose = getattr(thing, "pose", None)  # a Model: its mesh moved by its pose
        return thing.mesh.vertices if pose is None else thing.mesh.vertices @ pose[:3, :3].T + pose[:3, 3]
    if isinstance(thing, (list, tuple)) and thing and all(isinstance(t, Mesh) or hasattr(t, "mesh") for t in thing):
        return np.concatenate([_points_of(t) for t in thing])
    a = np.asarray(thing, np.float64) if not isinstance(thing, (str, bytes)) else None
    if a is None or a.ndim != 2 or a.shape[1] != 3 or not len(a):
        raise TypeError("camera.fit.scene_or_bounds: expected a Scene, Model, Mesh, a list of them, (N, 3) points or (2, 3) "
                        f"bounds, got {type(thing).__name__}")
    if not np.all(np.isfinite(a)):
        raise ValueError("camera.fit.scene_or_bounds: the points must be finite")
    if len(a) == 2:  # a bounding box: its eight corners
        lo, hi = a.min(axis=0), a.max(axis=0)
        a = np.array([[(lo, hi)[i][0], (lo, hi)[j][1], (lo, hi)[k][2]] for i in (0, 1) for j in (0, 1)
                      for k in (0, 1)])
    return a
