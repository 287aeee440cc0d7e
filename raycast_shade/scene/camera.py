"""Cameras: perspective and orthographic look-at, with the image size."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..common.choices import PROJECTIONS
from ..common.validate import as_choice, as_int, as_scalar, as_vec3, check_memory, pow2_scaled
from .framememory import FRAME_BYTES_PER_PIXEL, frame_bytes_per_pixel

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
        the distorted image, with no warp. None (or all zero): a pinhole.
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
        """Orthonormal ``(right, up, forward)``, each (3,) float64."""
        # Powers of two first (exact, so the bits are those of the plain formula):
        # an up of 1e-200 or a view of 1e300 would under/overflow in the norms.
        fwd = pow2_scaled(self.target - self.eye)
        fwd = fwd / np.linalg.norm(fwd)
        right = np.cross(fwd, pow2_scaled(self.up))
        right /= np.linalg.norm(right)
        up = np.cross(right, fwd)
        return right, up, fwd

    def check_frame_memory(self, buffers=(), samples: int = 1, terms=None, lights: int = 0) -> None:
        """Refuse (ValueError, with the figure) a frame larger than
        :func:`~raycast_shade.common.validate.memory_limit`.

        Parameters
        ----------
        buffers, samples, terms, lights
            What the frame is asked for, as
            :func:`~raycast_shade.scene.framememory.frame_bytes_per_pixel`
            counts it (the default: the plain frame, ``FRAME_BYTES_PER_PIXEL``).
        """
        per_pixel = frame_bytes_per_pixel(buffers, samples, terms, lights)
        check_memory(float(self.width) * float(self.height) * per_pixel,
                     f"camera.width x camera.height: {self.width} x {self.height} pixels", "a frame")

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

        if not isinstance(fisheye, (bool, np.bool_)):
            raise TypeError(f"fisheye: expected True or False, got {type(fisheye).__name__}")
        lens = {} if dist is None else {"distortion": dist, "distortion_model": "fisheye" if fisheye else "opencv"}
        return cls(width=width, height=height, **opencv_kwargs(K, R, t, projection), **lens)

    @classmethod
    def from_opengl(cls, view, projection, width, height) -> "Camera":
        """A camera from OpenGL (4, 4) view and projection matrices, as made
        by :meth:`view_matrix` and :meth:`projection_matrix`."""
        from .projection import opengl_kwargs

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
