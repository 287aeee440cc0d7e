"""Cameras as matrices: OpenCV intrinsics and extrinsics, OpenGL view and projection.

The functions take a :class:`~raycast_shade.scene.camera.Camera` (duck-typed:
this module does not import it, so the camera can import this one) and the
constructors return the camera's keyword arguments.

Conventions (``docs/vision.md`` compares them with pyrender, PyTorch3D and Open3D)
---------------------------------------------------------------------------------
OpenCV camera axes
    ``x`` right, ``y`` down, ``z`` forward; ``x_cam = R x_world + t``.
OpenCV pixels
    ``u = fx x / z + cx``, ``v = fy y / z + cy``; the centre of pixel
    ``(i, j)`` (column, row) is at ``(u, v) = (i, j)``: a point projects into
    pixel ``(round(u), round(v))``. The renderer's own continuous pixel
    coordinates put that centre at ``(i + 0.5, j + 0.5)``, so a camera made
    with no intrinsics has ``cx = W / 2 - 0.5``, ``cy = H / 2 - 0.5``.
Orthographic
    ``u = fx x + cx``, ``v = fy y + cy``: ``fx, fy`` in pixels per world
    unit, ``x, y`` measured from the eye.
OpenGL
    View space ``x`` right, ``y`` up, ``z`` backward (the camera looks down
    ``-z``); clip space by :func:`projection_matrix`, normalised device
    coordinates in ``[-1, 1]`` with ``y`` up, window ``y`` from the bottom:
    image row ``v_gl = H (1 - y_ndc) / 2`` with pixel centres at ``+0.5``.
"""

from __future__ import annotations

import numpy as np

from ..common.validate import as_array, as_scalar

__all__ = ["intrinsics", "principal_offset", "intrinsics_matrix", "extrinsics", "opencv_kwargs",
           "view_matrix", "projection_matrix", "opengl_kwargs", "GL_FROM_CV", "distort_normalised",
           "project_points"]

# OpenCV camera axes to OpenGL view axes (and back): y and z flip.
GL_FROM_CV = np.diag([1.0, -1.0, -1.0])


def intrinsics(camera):
    """``(fx, fy, cx, cy)`` in pixels, OpenCV's convention (pixel centres at integers).

    Stored values for a camera made with them; otherwise derived from the
    field of view (orthographic: ``ortho_height``) with the principal point
    at the image centre.
    """
    if camera.fx is not None:
        return camera.fx, camera.fy, camera.cx, camera.cy
    hw, hh = camera.half_extents()
    w, h = camera.width, camera.height
    return w / (2.0 * hw), h / (2.0 * hh), 0.5 * w - 0.5, 0.5 * h - 0.5


def principal_offset(camera):
    """How far the principal point moves the image centre's ray.

    Returns
    -------
    ox, oy : float
        Along ``right`` and ``up``: in units of the focal distance
        (perspective; the centre pixel's direction is
        ``forward + ox right + oy up`` before normalising) or world units
        (orthographic: the ray origin moves by as much). Zero for a camera
        without intrinsics.
    """
    if camera.fx is None:
        return 0.0, 0.0
    w, h = camera.width, camera.height
    return (0.5 * w - 0.5 - camera.cx) / camera.fx, (camera.cy - 0.5 * h + 0.5) / camera.fy


def intrinsics_matrix(camera) -> np.ndarray:
    """(3, 3) float64 ``K = [[fx, 0, cx], [0, fy, cy], [0, 0, 1]]`` (zero skew)."""
    fx, fy, cx, cy = intrinsics(camera)
    return np.array([[fx, 0.0, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]])


def extrinsics(camera):
    """OpenCV's world-to-camera transform.

    Returns
    -------
    R : (3, 3) float64
        Rows ``right``, ``-up``, ``forward`` (a rotation, ``det R = 1``).
    t : (3,) float64
        ``-R eye``.
    """
    right, up, fwd = camera.basis
    R = np.stack([right, -up, fwd])
    return R, -(R @ camera.eye)


def _matrix(value, shape, field):
    """``value`` as a finite float64 array of ``shape``: numbers only (strings and booleans refused)."""
    from ..common.validate import as_array

    a = as_array(value, field, dtype=np.float64, finite=False)
    if shape == (3,) and a.shape in ((3, 1), (1, 3)):  # a column, as cv2.solvePnP and cv2.Rodrigues give it
        a = a.reshape(3)
    if a.shape != shape:
        raise ValueError(f"{field}: expected shape {shape}, got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{field}: must be finite")
    return a


def opencv_kwargs(K, R, t, projection="perspective") -> dict:
    """Camera keyword arguments from OpenCV's ``K``, ``R``, ``t``.

    Parameters
    ----------
    K : (3, 3) float
        ``[[fx, 0, cx], [0, fy, cy], [0, 0, 1]]``, ``fx, fy > 0``; skew must be 0.
    R : (3, 3) float
        Rotation (orthonormal to 1e-6, ``det R > 0``), world to camera.
    t : (3,), (3, 1) or (1, 3) float
        Translation, world to camera (a column as ``cv2.solvePnP`` returns it).
    projection : {"perspective", "orthographic"}

    Returns
    -------
    dict
        ``eye``, ``target``, ``up``, ``fx``, ``fy``, ``cx``, ``cy``, ``projection``.

    Raises
    ------
    TypeError, ValueError
        Naming ``K``, ``R`` or ``t``.
    """
    K = _matrix(K, (3, 3), "K")
    R = _matrix(R, (3, 3), "R")
    if isinstance(t, np.ndarray) and t.shape in ((3, 1), (1, 3)):  # cv2.solvePnP's column, or a row
        t = t.reshape(3)
    t = _matrix(t, (3,), "t")
    if K[0, 1] != 0.0:
        raise ValueError(f"K: skew K[0, 1] must be 0, got {K[0, 1]}")
    if K[1, 0] != 0.0 or K[2, 0] != 0.0 or K[2, 1] != 0.0 or K[2, 2] != 1.0:
        raise ValueError(f"K: expected [[fx, 0, cx], [0, fy, cy], [0, 0, 1]], got {K.tolist()}")
    if not (K[0, 0] > 0.0 and K[1, 1] > 0.0):
        raise ValueError(f"K: fx and fy must be > 0, got {K[0, 0]} and {K[1, 1]}")
    if not np.allclose(R @ R.T, np.eye(3), rtol=0.0, atol=1e-6):
        raise ValueError("R: not orthonormal (R R^T != I to 1e-6)")
    if not np.linalg.det(R) > 0.0:
        raise ValueError("R: a reflection (det R < 0); expected a rotation")
    eye = -(R.T @ t)
    # A target one scene-size away keeps target - eye's relative rounding at 1e-16.
    reach = max(1.0, float(np.abs(eye).max()))
    return dict(eye=eye, target=eye + reach * R[2], up=-R[1], fx=float(K[0, 0]), fy=float(K[1, 1]),
                cx=float(K[0, 2]), cy=float(K[1, 2]), projection=projection)


def view_matrix(camera) -> np.ndarray:
    """(4, 4) float64 OpenGL world-to-view matrix (view space ``x`` right, ``y`` up, looking down ``-z``)."""
    R, t = extrinsics(camera)
    V = np.eye(4)
    V[:3, :3] = GL_FROM_CV @ R
    V[:3, 3] = GL_FROM_CV @ t
    return V


def projection_matrix(camera, near, far) -> np.ndarray:
    """(4, 4) float64 OpenGL projection matrix (clip space) of the camera's intrinsics.

    A view-space point ``p`` (:func:`view_matrix`) has clip coordinates
    ``P p``; after the divide by ``w``, ``x_ndc = 2 u / W - 1`` and
    ``y_ndc = 1 - 2 v / H`` with ``(u, v)`` the renderer's continuous pixel
    coordinates (OpenCV's plus 0.5), and ``z_ndc`` is -1 at ``near`` and 1
    at ``far``.

    Parameters
    ----------
    near, far : float
        Clip distances along the view axis, ``0 < near < far``
        (orthographic: ``near`` may be 0 or negative).
    """
    n, f = as_scalar(near, "near"), as_scalar(far, "far")  # NumPy scalars and 0-d arrays are numbers
    if getattr(camera, "distorted", False):
        raise ValueError("camera.distortion: an OpenGL projection matrix cannot hold lens distortion")
    if not f > n or (not camera.orthographic and not n > 0.0):
        raise ValueError(f"near, far: expected 0 < near < far (orthographic: near < far), got {n}, {f}")
    fx, fy, cx, cy = intrinsics(camera)
    w, h = camera.width, camera.height
    cxg, cyg = cx + 0.5, cy + 0.5
    P = np.zeros((4, 4))
    P[0, 0] = 2.0 * fx / w
    P[1, 1] = 2.0 * fy / h
    if camera.orthographic:
        P[0, 3] = 2.0 * cxg / w - 1.0
        P[1, 3] = 1.0 - 2.0 * cyg / h
        P[2, 2] = -2.0 / (f - n)
        P[2, 3] = -(f + n) / (f - n)
        P[3, 3] = 1.0
    else:
        P[0, 2] = 1.0 - 2.0 * cxg / w
        P[1, 2] = 2.0 * cyg / h - 1.0
        P[2, 2] = -(f + n) / (f - n)
        P[2, 3] = -2.0 * f * n / (f - n)
        P[3, 2] = -1.0
    return P


# The OpenCV field each error of opencv_kwargs names, as the OpenGL argument it was read from.
_GL_FIELDS = {"K": "projection", "R": "view", "t": "view"}


def opengl_kwargs(view, projection, width, height) -> dict:
    """Camera keyword arguments from OpenGL view and projection matrices
    (the inverse of :func:`view_matrix` and :func:`projection_matrix`).

    Raises
    ------
    TypeError, ValueError
        Naming ``view`` or ``projection``: not 4x4, not rigid, skewed, or
        neither a perspective nor an orthographic projection.
    """
    V = _matrix(view, (4, 4), "view")
    P = _matrix(projection, (4, 4), "projection")
    if not np.array_equal(V[3], [0.0, 0.0, 0.0, 1.0]):
        raise ValueError(f"view: last row must be [0, 0, 0, 1], got {V[3].tolist()}")
    w, h = float(width), float(height)
    if P[0, 1] != 0.0 or P[1, 0] != 0.0:
        raise ValueError("projection: skew must be 0")
    if np.array_equal(P[3], [0.0, 0.0, -1.0, 0.0]):
        kind = "perspective"
        cxg, cyg = (1.0 - P[0, 2]) * w / 2.0, (P[1, 2] + 1.0) * h / 2.0
    elif np.array_equal(P[3], [0.0, 0.0, 0.0, 1.0]):
        kind = "orthographic"
        cxg, cyg = (P[0, 3] + 1.0) * w / 2.0, (1.0 - P[1, 3]) * h / 2.0
    else:
        raise ValueError(f"projection: last row must be [0, 0, -1, 0] (perspective) or [0, 0, 0, 1] "
                         f"(orthographic), got {P[3].tolist()}")
    if not (P[0, 0] > 0.0 and P[1, 1] > 0.0):
        raise ValueError(f"projection: P[0, 0] and P[1, 1] (the focal terms) must be > 0, got {P[0, 0]} and {P[1, 1]}")
    rotation = V[:3, :3]  # R up to the axis flip GL_FROM_CV (det +1): the same tests, named as the caller knows it
    if not np.allclose(rotation @ rotation.T, np.eye(3), rtol=0.0, atol=1e-6):
        raise ValueError("view: the rotation view[:3, :3] is not orthonormal (to 1e-6)")
    if not np.linalg.det(rotation) > 0.0:
        raise ValueError("view: view[:3, :3] is a reflection (det < 0); expected a rotation")
    with np.errstate(over="ignore"):  # an overflow to inf is refused below, naming projection
        K = [[P[0, 0] * w / 2.0, 0.0, cxg - 0.5], [0.0, P[1, 1] * h / 2.0, cyg - 0.5], [0.0, 0.0, 1.0]]
    try:
        return opencv_kwargs(K, GL_FROM_CV @ rotation, GL_FROM_CV @ V[:3, 3], kind)
    except ValueError as exc:  # what remains (K overflowing to inf, say): K is read from projection, R, t from view
        field, _, rest = str(exc).partition(": ")
        raise ValueError(f"{_GL_FIELDS.get(field, field)}: {rest}") from None


def distort_normalised(camera, x, y):
    """A camera's lens model on normalised coordinates (identity without distortion).

    Parameters
    ----------
    camera : Camera
    x, y : (N,) float
        ``X / Z``, ``Y / Z`` in OpenCV's camera axes.

    Returns
    -------
    x_d, y_d : (N,) float64
        As ``cv2.projectPoints`` (``distortion_model="opencv"``) or
        ``cv2.fisheye.projectPoints`` (``"fisheye"``) distort them; the
        formulas are in :mod:`raycast_shade.visibility.distortion`.
    """
    x, y = np.asarray(x, np.float64), np.asarray(y, np.float64)
    if not getattr(camera, "distorted", False):
        return x, y
    k = np.zeros(5)
    k[:len(camera.distortion)] = camera.distortion
    if camera.distortion_model == "fisheye":
        r = np.hypot(x, y)
        theta = np.arctan(r)
        t2 = theta * theta
        td = theta * (1.0 + t2 * (k[0] + t2 * (k[1] + t2 * (k[2] + t2 * k[3]))))
        scale = np.where(r > 0, td / np.where(r > 0, r, 1.0), 1.0)
        return x * scale, y * scale
    k1, k2, p1, p2, k3 = k
    r2 = x * x + y * y
    s = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
    return x * s + 2 * p1 * x * y + p2 * (r2 + 2 * x * x), y * s + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y


def project_points(camera, points):
    """OpenCV pixel coordinates of world points (lens distortion included).

    Parameters
    ----------
    camera : Camera
    points : (N, 3) float
        World coordinates.

    Returns
    -------
    uv : (N, 2) float64
        Pixel coordinates, OpenCV's convention (the centre of pixel ``(i, j)``
        at ``(i, j)``); NaN for points not in front of a perspective camera.
    z : (N,) float64
        Camera-space depth (``z`` forward).
    """
    p = np.asarray(points, np.float64).reshape(-1, 3)
    fx, fy, cx, cy = intrinsics(camera)
    R, t = extrinsics(camera)
    q = p @ R.T + t
    z = q[:, 2]
    if camera.orthographic:
        x, y = q[:, 0], q[:, 1]
    else:
        with np.errstate(divide="ignore", invalid="ignore"):
            front = z > 0
            x = np.where(front, q[:, 0] / np.where(front, z, 1.0), np.nan)
            y = np.where(front, q[:, 1] / np.where(front, z, 1.0), np.nan)
        x, y = distort_normalised(camera, x, y)
    return np.stack([fx * x + cx, fy * y + cy], axis=-1), z
