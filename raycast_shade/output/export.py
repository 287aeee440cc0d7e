"""Cameras in the formats reconstruction tools read: nerfstudio / instant-ngp, COLMAP text.

Both formats put the centre of pixel ``(i, j)`` at ``(i + 0.5, j + 0.5)``;
OpenCV's convention (this package's ``K``) puts it at ``(i, j)``. The
exporters shift the principal point by +0.5 so that a point projects to the
same pixel in every convention (``docs/vision.md``).

``transforms.json`` (nerfstudio, instant-ngp)
    ``camera_model`` ``"OPENCV"`` (``fl_x, fl_y, cx, cy, w, h`` and the
    distortion coefficients ``k1, k2, p1, p2, k3``, zero for a pinhole
    camera) or ``"OPENCV_FISHEYE"`` (``k1 .. k4``), at the top when every
    view shares them, else in each frame; per frame
    ``file_path`` and ``transform_matrix``, the (4, 4) camera-to-world matrix
    in OpenGL's camera axes (``x`` right, ``y`` up, ``z`` backward); and, when
    given, ``depth_file_path`` (a 16-bit PNG that nerfstudio's dataparser reads
    as ``value * depth_unit_scale_factor``, its option, default 0.001: the
    top-level ``depth_unit_scale_factor`` written here says the value to pass,
    ``1 / depth_scale``) and ``mask_path`` (an 8-bit grey PNG; nerfstudio
    trains only on its non-zero pixels). nerfstudio's depth loss reads a
    depth image as z-depth for ``OPENCV`` (its rays' direction norms scale
    it to the ray) and as the distance along the ray for ``OPENCV_FISHEYE``
    (unit directions): the caller links the matching kind.
COLMAP text (``cameras.txt``, ``images.txt``, ``points3D.txt``)
    One camera per distinct intrinsics, lens and size: ``PINHOLE``
    (``fx fy cx cy``), ``OPENCV`` (``... k1 k2 p1 p2``), ``FULL_OPENCV``
    (``... k1 k2 p1 p2 k3 k4 k5 k6``, when ``k3`` is not 0) or
    ``OPENCV_FISHEYE`` (``... k1 k2 k3 k4``); lens coefficients are
    unchanged by the pixel shift (they act on normalised coordinates); per image the world-to-camera rotation as a unit quaternion
    (Hamilton, ``QW QX QY QZ``, ``QW >= 0``), the translation ``TX TY TZ``
    (OpenCV's ``R``, ``t``: COLMAP uses OpenCV's camera axes), the camera
    id and the file name, then its 2D points ``X Y POINT3D_ID`` (the
    observations of :class:`~raycast_shade.output.surfacepoints.SurfacePoints`,
    +0.5 as the principal point), empty without points; ``points3D.txt``: per
    point ``X Y Z R G B ERROR`` (ERROR 0: the observations are its exact
    projections) and its track ``IMAGE_ID POINT2D_IDX`` pairs, empty without
    points. Numbers are written with 17 significant digits.
"""

from __future__ import annotations

import json
import os

import numpy as np

from ..common.validate import as_path, as_scalar, as_sequence

__all__ = ["PIXEL_CENTRE_SHIFT", "camera_to_world_gl", "nerfstudio_transforms", "write_transforms", "rotation_to_quaternion",
           "write_colmap", "check_colmap", "check_transforms", "COLMAP_FILES", "place_file"]

COLMAP_FILES = ("cameras.txt", "images.txt", "points3D.txt")  # the text model, in a folder of its own

# Their pixel coordinates minus OpenCV's: both tools put the first pixel's centre at (0.5, 0.5).
PIXEL_CENTRE_SHIFT = 0.5


def _check(cameras, names, field: str, *, one_lens_model: bool):
    """The cameras (perspective) and one file name per camera, checked; ``one_lens_model``: all fisheye
    or none (nerfstudio's ``camera_model`` is one per file; COLMAP's is per camera)."""
    from ..scene.camera import Camera

    if isinstance(cameras, Camera):
        cameras = [cameras]
    cameras = as_sequence(cameras, "cameras")
    names = as_sequence(names, field)
    if not cameras:
        raise ValueError("cameras: expected at least one camera")
    for i, cam in enumerate(cameras):
        if not isinstance(cam, Camera):
            raise TypeError(f"cameras[{i}]: expected a Camera, got {type(cam).__name__}")
        if cam.orthographic:
            raise ValueError(f"cameras[{i}]: orthographic; these formats take perspective cameras")
    fisheye = [c.distorted and c.distortion_model == "fisheye" for c in cameras]
    if one_lens_model and any(fisheye) and not all(fisheye):
        raise ValueError(f"cameras: fisheye (cameras[{fisheye.index(True)}]) and pinhole/OpenCV lenses "
                         f"(cameras[{fisheye.index(False)}]) mixed; transforms.json takes one camera_model per file")
    if len(names) != len(cameras):
        raise ValueError(f"{field}: expected one per camera ({len(cameras)}), got {len(names)}")
    for i, n in enumerate(names):
        if not isinstance(n, str) or not n or any(c in n for c in "\n\r"):
            raise ValueError(f"{field}[{i}]: expected a file name, got {n!r}")
    return cameras, names


def check_transforms(cameras, file_paths) -> tuple:
    """The cameras and file paths of a ``transforms.json``, checked before anything is rendered or written.

    Parameters
    ----------
    cameras : sequence of Camera
        Perspective, and all fisheye or none: nerfstudio reads one ``camera_model``
        for the file (its dataparser takes it from the top level only).
    file_paths : sequence of str
        One per camera, each a name on one line, no two alike (one pose per picture).

    Returns
    -------
    tuple
        ``(cameras, file_paths)`` as lists.

    Raises
    ------
    TypeError, ValueError
        Naming ``cameras[i]`` or ``file_paths[i]``.
    """
    cameras, file_paths = _check(cameras, file_paths, "file_paths", one_lens_model=True)
    seen = {}
    for i, p in enumerate(file_paths):
        if p in seen:  # two poses for one picture: nerfstudio would train on a contradiction
            raise ValueError(f"file_paths[{i}]: {p!r} repeats file_paths[{seen[p]}]; each frame is its own image")
        seen[p] = i
    return cameras, file_paths


def check_colmap(cameras, names) -> tuple:
    """The cameras and image names of a COLMAP text model, checked before anything is rendered or written.

    Parameters
    ----------
    cameras : sequence of Camera
        Perspective (COLMAP has no orthographic model); each camera's lens is its own
        (``cameras.txt`` gives a model per line).
    names : sequence of str
        One per camera: no whitespace (COLMAP's reader splits ``images.txt``'s lines on
        spaces, keeping the first word of a name, and other readers on any whitespace)
        and no repeats (an image is found by its name).

    Returns
    -------
    tuple
        ``(cameras, names)`` as lists.

    Raises
    ------
    TypeError, ValueError
        Naming ``cameras[i]`` or ``names[i]``.
    """
    cameras, names = _check(cameras, names, "names", one_lens_model=False)
    seen = {}
    for i, n in enumerate(names):
        if any(c.isspace() for c in n):
            raise ValueError(f"names[{i}]: {n!r} holds whitespace; COLMAP's images.txt splits its lines on it "
                             "(a name is one word)")
        if n in seen:
            raise ValueError(f"names[{i}]: {n!r} repeats names[{seen[n]}]; COLMAP finds an image by its name")
        seen[n] = i
    return cameras, names


def _lens(cam):
    """``(model, coefficients)``: ``"fisheye"`` with (k1, k2, k3, k4), else ``"opencv"`` with
    (k1, k2, p1, p2, k3) (zero for a pinhole)."""
    k = np.zeros(5)
    if cam.distorted:
        k[:len(cam.distortion)] = cam.distortion
    if cam.distorted and cam.distortion_model == "fisheye":
        return "fisheye", k[:4]
    return "opencv", k


def _intrinsics(cam) -> dict:
    fx, fy, cx, cy = (float(v) for v in (cam.K[0, 0], cam.K[1, 1], cam.K[0, 2], cam.K[1, 2]))
    out = {"fl_x": fx, "fl_y": fy, "cx": cx + PIXEL_CENTRE_SHIFT, "cy": cy + PIXEL_CENTRE_SHIFT,
           "w": int(cam.width), "h": int(cam.height)}
    model, k = _lens(cam)
    names = ("k1", "k2", "k3", "k4") if model == "fisheye" else ("k1", "k2", "p1", "p2", "k3")
    out.update({n: float(v) for n, v in zip(names, k)})
    return out


def camera_to_world_gl(cam) -> np.ndarray:
    """(4, 4) float64 camera-to-world matrix, OpenGL camera axes (``x`` right, ``y`` up, ``z`` back)."""
    _, R, _ = cam.to_opencv()
    c2w = np.eye(4)
    c2w[:3, :3] = R.T * np.array([1.0, -1.0, -1.0])  # columns right, up, backward
    c2w[:3, 3] = cam.eye
    return c2w


def nerfstudio_transforms(cameras, file_paths, *, depth_paths=None, mask_paths=None, depth_scale: float = 1000.0) -> dict:
    """The ``transforms.json`` dictionary of perspective cameras (see the module docstring).

    Parameters
    ----------
    cameras : sequence of Camera
        Perspective; lenses all fisheye or none.
    file_paths : sequence of str
        Each view's image, relative to the ``transforms.json`` folder.
    depth_paths, mask_paths : sequence of str, optional
        Each view's depth PNG (z-depth for pinhole/OpenCV lenses, distance along the ray for
        fisheye ones: what nerfstudio reads) and mask PNG; one per camera.
    depth_scale : float
        The depth PNGs' units per world unit: ``depth_unit_scale_factor`` is its inverse.
    """
    cameras, file_paths = check_transforms(cameras, file_paths)
    extra = {}
    for key, paths in (("depth_file_path", depth_paths), ("mask_path", mask_paths)):
        if paths is not None:
            extra[key] = _check(cameras, paths, key, one_lens_model=True)[1]
    intr = [_intrinsics(c) for c in cameras]
    shared = all(i == intr[0] for i in intr)
    model = "OPENCV_FISHEYE" if _lens(cameras[0])[0] == "fisheye" else "OPENCV"
    out = {"camera_model": model, **(intr[0] if shared else {})}
    if depth_paths is not None:
        out["depth_unit_scale_factor"] = 1.0 / float(as_scalar(depth_scale, "depth_scale", minimum=0.0, exclusive=True))
    out["frames"] = [{"file_path": p, **({} if shared else i), "transform_matrix": camera_to_world_gl(c).tolist(),
                      **{key: paths[k] for key, paths in extra.items()}}
                     for k, (c, p, i) in enumerate(zip(cameras, file_paths, intr))]
    return out


def write_transforms(path, cameras, file_paths, **links) -> str:
    """Write :func:`nerfstudio_transforms` to ``path`` (``.json``), atomically; returns the path.
    ``links``: its ``depth_paths``, ``mask_paths`` and ``depth_scale``.

    Raises
    ------
    TypeError, ValueError
        Naming the argument, before the file is opened: ``path`` not a ``.json``
        file that can be written (:func:`~raycast_shade.output.imagefile.check_output_file`),
        or as :func:`check_transforms`.
    """
    from .imagefile import atomic_target, check_output_file

    path = as_path(path, "path")
    if not path.lower().endswith(".json"):
        raise ValueError(f"path: {path!r}: expected a .json file")
    check_output_file(path, "path")
    data = nerfstudio_transforms(cameras, file_paths, **links)
    with atomic_target(path) as tmp, open(tmp, "w") as fh:
        json.dump(data, fh, indent=1)
    return path


def rotation_to_quaternion(R) -> np.ndarray:
    """(4,) float64 unit quaternion ``(w, x, y, z)`` (Hamilton, ``w >= 0``) of a rotation matrix."""
    R = np.asarray(R, np.float64)
    # The largest of the four squared components first: no division by a small number.
    squares = np.array([1.0 + R[0, 0] + R[1, 1] + R[2, 2], 1.0 + R[0, 0] - R[1, 1] - R[2, 2],
                        1.0 - R[0, 0] + R[1, 1] - R[2, 2], 1.0 - R[0, 0] - R[1, 1] + R[2, 2]])
    k = int(np.argmax(squares))
    s = 2.0 * np.sqrt(squares[k])
    if k == 0:
        q = [s / 4, (R[2, 1] - R[1, 2]) / s, (R[0, 2] - R[2, 0]) / s, (R[1, 0] - R[0, 1]) / s]
    elif k == 1:
        q = [(R[2, 1] - R[1, 2]) / s, s / 4, (R[0, 1] + R[1, 0]) / s, (R[0, 2] + R[2, 0]) / s]
    elif k == 2:
        q = [(R[0, 2] - R[2, 0]) / s, (R[0, 1] + R[1, 0]) / s, s / 4, (R[1, 2] + R[2, 1]) / s]
    else:
        q = [(R[1, 0] - R[0, 1]) / s, (R[0, 2] + R[2, 0]) / s, (R[1, 2] + R[2, 1]) / s, s / 4]
    q = np.array(q)
    q /= np.linalg.norm(q)
    return -q if q[0] < 0 else q


def _num(x) -> str:
    return format(float(x), ".17g")


def write_colmap(folder, cameras, names, points=None) -> list:
    """Write COLMAP's text model (``cameras.txt``, ``images.txt``, ``points3D.txt``) of perspective cameras.

    Parameters
    ----------
    folder : str or path-like
        Created if need be.
    cameras : sequence of Camera
        Perspective; lenses may differ (one COLMAP camera per distinct one).
    names : sequence of str
        Each view's image file name (COLMAP's ``NAME``): one word, no repeats
        (:func:`check_colmap`).
    points : SurfacePoints, optional
        Points with their observations per camera
        (:func:`~raycast_shade.output.surfacepoints.surface_points`); default: none.

    Returns
    -------
    list of str
        The three paths.

    Raises
    ------
    TypeError, ValueError
        Naming the argument, before anything is written: ``folder`` a file or
        not writable (:func:`~raycast_shade.output.imagefile.check_output_folder`),
        or one of the three files a folder; or as :func:`check_colmap`.
    """
    from .imagefile import atomic_target, check_output_folder

    folder = check_output_folder(folder, "folder")
    cameras, names = check_colmap(cameras, names)
    if points is not None and len(points.observations) != len(cameras):
        raise ValueError(f"points: observations for {len(points.observations)} views, {len(cameras)} cameras")
    for fname in COLMAP_FILES:
        if os.path.isdir(os.path.join(folder, fname)):
            raise ValueError(f"folder: {os.path.join(folder, fname)!r} is a folder; COLMAP's {fname} goes there")
    os.makedirs(folder, exist_ok=True)
    ids, cam_lines, img_lines = {}, [], []
    for i, (cam, name) in enumerate(zip(cameras, names)):
        intr = _intrinsics(cam)
        model, k = _lens(cam)
        if model == "fisheye":
            kind, extra = "OPENCV_FISHEYE", tuple(k)
        elif not cam.distorted:
            kind, extra = "PINHOLE", ()
        elif k[4] == 0.0:
            kind, extra = "OPENCV", tuple(k[:4])
        else:  # k3 needs the full model: k1 k2 p1 p2 k3 k4 k5 k6
            kind, extra = "FULL_OPENCV", (*k, 0.0, 0.0, 0.0)
        params = (kind, intr["w"], intr["h"], intr["fl_x"], intr["fl_y"], intr["cx"], intr["cy"], *extra)
        if params not in ids:
            ids[params] = len(ids) + 1
            cam_lines.append(f"{ids[params]} {kind} {params[1]} {params[2]} " + " ".join(_num(v) for v in params[3:]))
        _, R, t = cam.to_opencv()
        q = rotation_to_quaternion(R)
        img_lines.append(f"{i + 1} " + " ".join(_num(v) for v in (*q, *t)) + f" {ids[params]} {name}")
        img_lines.append("" if points is None else _points2d_line(*points.observations[i]))
    point_lines, n_obs = _points3d_lines(points)
    texts = {
        "cameras.txt": "# Camera list with one line of data per camera:\n#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n"
                       f"# Number of cameras: {len(cam_lines)}\n" + "\n".join(cam_lines) + "\n",
        "images.txt": "# Image list with two lines of data per image:\n"
                      "#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n#   POINTS2D[] as (X, Y, POINT3D_ID)\n"
                      f"# Number of images: {len(cameras)}, mean observations per image: {n_obs / len(cameras):g}\n"
                      + "\n".join(img_lines) + "\n",
        "points3D.txt": "# 3D point list with one line of data per point:\n"
                        "#   POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[] as (IMAGE_ID, POINT2D_IDX)\n"
                        f"# Number of points: {len(point_lines)}, mean track length: "
                        f"{n_obs / max(1, len(point_lines)):g}\n" + "".join(line + "\n" for line in point_lines),
    }
    paths = []
    for fname, text in texts.items():
        p = os.path.join(folder, fname)
        with atomic_target(p) as tmp, open(tmp, "w") as fh:
            fh.write(text)
        paths.append(p)
    return paths


def _points2d_line(ids, uv) -> str:
    """One image's ``X Y POINT3D_ID`` triples (COLMAP's pixel coordinates; point ids from 1)."""
    xy = np.asarray(uv, np.float64) + PIXEL_CENTRE_SHIFT
    return " ".join(f"{_num(x)} {_num(y)} {int(p) + 1}" for (x, y), p in zip(xy, ids))


def _points3d_lines(points) -> tuple:
    """``(lines, observations)``: ``points3D.txt``'s lines and the total track length."""
    if points is None or not len(points.xyz):
        return [], 0
    tracks = [[] for _ in range(len(points.xyz))]
    for i, (ids, _) in enumerate(points.observations):
        for idx, p in enumerate(ids.tolist()):
            tracks[p].append(f"{i + 1} {idx}")
    lines = [f"{p + 1} " + " ".join(_num(v) for v in xyz) + " " + " ".join(str(int(c)) for c in rgb) + " 0 "
             + " ".join(track) for p, (xyz, rgb, track) in enumerate(zip(points.xyz, points.rgb, tracks))]
    return lines, sum(len(t) for t in tracks)


def place_file(src, dst) -> None:
    """``dst`` a hard link to ``src`` where the file system allows, else a copy (atomically either way;
    BOP's ``rgb/`` files are placed so)."""
    from .bop import _place

    _place(src, dst)
