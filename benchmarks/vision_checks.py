"""The figures of docs/vision.md's checks: exporters, lens distortion, optical flow, against references.

Run ``python -m benchmarks.vision_checks [--quick]``. Writes
``benchmarks/results/vision_checks.csv`` (``--quick``: smaller images, into
the git-ignored ``out/quick/results/``), one row per figure: ``check``,
``case``, ``value``, ``unit``, ``reference``. Accuracy only, no timings.

* ``export``: COLMAP text read back by pycolmap (``Image.project_point``) and
  nerfstudio's documented ray formula, against our OpenCV projection of
  random points and against points on our pixel rays;
* ``distortion``: each pixel's ray projected by ``cv2.projectPoints`` /
  ``cv2.fisheye.projectPoints``; ``cv2.undistortPoints`` to convergence and
  with its default criteria; vertices landing on their own triangles;
* ``flow``: a plane's closed-form homography (two cameras; a moved model),
  forward and backward.
"""

from __future__ import annotations

import argparse
import csv
import os
import tempfile

import numpy as np

from benchmarks.outputs import results_file

K = np.array([[60.0, 0.0, 31.2], [0.0, 62.0, 24.3], [0.0, 0.0, 1.0]])
LENSES = {"barrel": ([-0.28, 0.09, 0.0012, -0.0009, -0.012], False),
          "pincushion": ([0.22, 0.05, -0.002, 0.001], False),
          "fisheye": ([0.08, -0.03, 0.006, -0.001], True)}


def outputs(quick: bool) -> list:
    return [results_file("vision_checks.csv", quick)]


def _look(eye, target=(0.0, 0.0, 0.0)):
    eye = np.asarray(eye, float)
    z = np.asarray(target, float) - eye
    z /= np.linalg.norm(z)
    x = np.cross(z, [0.0, -1.0, 0.0])
    x /= np.linalg.norm(x)
    R = np.stack([x, np.cross(z, x), z])
    return R, -R @ eye


def _centres(w, h):
    jj, ii = np.mgrid[0:h, 0:w]
    return np.stack([ii.ravel(), jj.ravel()], axis=-1).astype(float)


def _opencv(cam, pts):
    from raycast_shade.scene.projection import project_points

    return project_points(cam, pts)[0]


def export_rows(w, h):
    import pycolmap

    import raycast_shade as rs
    from raycast_shade.output.export import nerfstudio_transforms, write_colmap
    from raycast_shade.visibility.rays import generate_rays

    rng = np.random.default_rng(0)
    cams = []
    for k in range(4):
        R, t = _look(4.0 * rng.normal(size=3) / 1.7)
        Kk = K * [[1 + 0.1 * k, 1, 1], [1, 1 + 0.05 * k, 1], [1, 1, 1]]
        cams.append(rs.Camera.from_opencv(Kk, R, t, w, h))
    folder = tempfile.mkdtemp()
    write_colmap(folder, cams, [f"{i}.png" for i in range(len(cams))])
    rec = pycolmap.Reconstruction(folder)
    ns = nerfstudio_transforms(cams, [f"{i}.png" for i in range(len(cams))])
    worst = {("colmap", "points"): 0.0, ("colmap", "rays"): 0.0, ("nerfstudio", "points"): 0.0,
             ("nerfstudio", "rays"): 0.0}
    for i, cam in enumerate(cams):
        o, d = generate_rays(cam, dtype=np.float64)
        sets = {"points": (rng.uniform(-1, 1, (300, 3)), None), "rays": (o + 3.0 * d, _centres(w, h))}
        frame = ns["frames"][i]
        c2w = np.array(frame["transform_matrix"])
        for kind, (pts, expect) in sets.items():
            ours = _opencv(cam, pts) if expect is None else expect
            col = np.array([rec.images[i + 1].project_point(p) for p in pts]) - 0.5
            q = (pts - c2w[:3, 3]) @ c2w[:3, :3]  # OpenGL camera axes
            nerf = np.stack([frame["fl_x"] * q[:, 0] / -q[:, 2] + frame["cx"],
                             -frame["fl_y"] * q[:, 1] / -q[:, 2] + frame["cy"]], -1) - 0.5
            worst["colmap", kind] = max(worst["colmap", kind], np.abs(col - ours).max())
            worst["nerfstudio", kind] = max(worst["nerfstudio", kind], np.abs(nerf - ours).max())
    ref = {"colmap": "pycolmap Image.project_point", "nerfstudio": "nerfstudio Cameras.generate_rays formula"}
    rows = [dict(check="export", case=f"{fmt} {kind}", value=v, unit="px", reference=ref[fmt])
            for (fmt, kind), v in worst.items()]
    return rows + _distorted_export_rows(cams, w, h)


def _distorted_export_rows(cams, w, h):
    """COLMAP's distorted models (pycolmap's projection) against ours, points and pixel rays."""
    import pycolmap

    import raycast_shade as rs
    from raycast_shade.output.export import write_colmap
    from raycast_shade.scene.projection import project_points
    from raycast_shade.visibility.distortion import ray_directions

    rng = np.random.default_rng(1)
    rows = []
    for model, dist, fisheye in (("FULL_OPENCV", LENSES["barrel"][0], False),
                                 ("OPENCV_FISHEYE", LENSES["fisheye"][0], True)):
        lensed = [rs.Camera.from_opencv(c.K, *c.to_opencv()[1:], w, h, dist=dist, fisheye=fisheye) for c in cams]
        folder = tempfile.mkdtemp()
        write_colmap(folder, lensed, [f"{i}.png" for i in range(len(lensed))])
        rec = pycolmap.Reconstruction(folder)
        worst = {"points": 0.0, "rays": 0.0}
        for i, cam in enumerate(lensed):
            d, ok = ray_directions(cam)
            pts = rng.uniform(-1, 1, (300, 3))
            uv = project_points(cam, pts)[0]
            front = np.isfinite(uv).all(axis=1)
            for kind, p, ours in (("points", pts[front], uv[front]), ("rays", cam.eye + 3.0 * d[ok], _centres(w, h)[ok])):
                col = np.array([rec.images[i + 1].project_point(q) for q in p]) - 0.5
                worst[kind] = max(worst[kind], np.abs(col - ours).max())
        rows += [dict(check="export", case=f"colmap {model} {kind}", value=v, unit="px",
                      reference="pycolmap Image.project_point") for kind, v in worst.items()]
    return rows


def distortion_rows(w, h):
    import cv2

    import raycast_shade as rs
    from raycast_shade.visibility.distortion import ray_directions

    crit = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 500, 1e-15)
    mesh = rs.shapes.icosphere(3)
    scene = rs.Scene([rs.Model(mesh)], lights=[rs.PointLight((2, 3, 4))], camera=rs.Camera(eye=(0, 0, 4)))
    faces_of = [set(np.flatnonzero((mesh.faces == i).any(axis=1))) for i in range(len(mesh.vertices))]
    rows = []
    for lens, (dist, fisheye) in LENSES.items():
        R, t = _look((0.7, 1.1, 1.8))
        cam = rs.Camera.from_opencv(K * [[w / 64, 1, w / 64], [1, h / 48, h / 48], [1, 1, 1]], R, t, w, h,
                                    dist=dist, fisheye=fisheye)
        Kc = cam.K
        d, ok = ray_directions(cam)
        rvec = cv2.Rodrigues(R)[0]

        def project(p):
            if fisheye:
                return cv2.fisheye.projectPoints(p.reshape(-1, 1, 3), rvec, t, Kc, np.array(dist))[0].reshape(-1, 2)
            return cv2.projectPoints(p, rvec, t, Kc, np.array(dist))[0].reshape(-1, 2)

        reproj = np.abs(project(cam.eye + 2.5 * d) - _centres(w, h)).max()
        dc = d @ R.T
        ours = dc[:, :2] / dc[:, 2:]
        pix = _centres(w, h).reshape(-1, 1, 2)
        und = cv2.fisheye.undistortPoints if fisheye else cv2.undistortPoints
        conv = np.abs(und(pix, Kc, np.array(dist), criteria=crit).reshape(-1, 2) - ours).max()
        default = np.abs(und(pix, Kc, np.array(dist)).reshape(-1, 2) - ours).max() * Kc[0, 0]
        tri = rs.render(scene, camera=cam, buffers=("triangle_id",)).buffers["triangle_id"]
        uv = project(mesh.vertices)
        to_eye = cam.eye - mesh.vertices
        facing = np.einsum("ij,ij->i", mesh.vertices, to_eye) / np.linalg.norm(to_eye, axis=1) > 0.3
        px = np.rint(uv).astype(int)
        inside = (px[:, 0] >= 0) & (px[:, 0] < w) & (px[:, 1] >= 0) & (px[:, 1] < h)
        checked = np.flatnonzero(facing & inside)
        wrong = sum(tri[px[i, 1], px[i, 0]] not in faces_of[i] for i in checked)
        rows += [dict(check="distortion", case=f"{lens} ray onto its pixel", value=reproj, unit="px",
                      reference="cv2.projectPoints"),
                 dict(check="distortion", case=f"{lens} undistortPoints converged", value=conv, unit="normalised",
                      reference="cv2.undistortPoints criteria 500, 1e-15"),
                 dict(check="distortion", case=f"{lens} undistortPoints default criteria", value=default, unit="px",
                      reference="cv2.undistortPoints defaults"),
                 dict(check="distortion", case=f"{lens} vertices in a wrong triangle", value=f"{wrong}/{len(checked)}",
                      unit="vertices", reference="cv2.projectPoints of the mesh vertices")]
    return rows


def flow_rows(w, h):
    import cv2

    import raycast_shade as rs
    from raycast_shade.output.flow import move_model, optical_flow

    scene = rs.Scene([rs.Model(rs.shapes.plane(size=30.0, subdivisions=3))], lights=[rs.PointLight((0, 0, 5))])
    Kc = K * [[w / 64, 1, w / 64], [1, h / 48, h / 48], [1, 1, 1]]

    def homography(Ra, ta, Rb, tb):
        n_a = Ra @ [0.0, 0.0, 1.0]
        R_rel = Rb @ Ra.T
        return Kc @ (R_rel + np.outer(tb - R_rel @ ta, n_a) / (n_a @ ta)) @ np.linalg.inv(Kc)

    def error(out, Hm):
        m = out["mask"].ravel()
        pix = _centres(w, h)[m]
        q = np.c_[pix, np.ones(len(pix))] @ Hm.T
        return np.abs(out["flow"].reshape(-1, 2)[m] - (q[:, :2] / q[:, 2:] - pix)).max()

    Ra, ta = _look((0.5, -1.0, 6.0), (0.2, 0.1, 0.0))
    Rb, tb = _look((-1.5, 0.5, 5.0), (0.0, -0.3, 0.0))
    a, b = (rs.Camera.from_opencv(Kc, R, t, w, h) for R, t in ((Ra, ta), (Rb, tb)))
    M = np.eye(4)
    M[:3, :3] = cv2.Rodrigues(np.array([0.3, 1.0, 0.2]) / np.linalg.norm([0.3, 1.0, 0.2]) * np.radians(12))[0]
    M[:3, 3] = (0.4, -0.2, 0.3)
    moved = move_model(scene, 0, M)
    Hm = homography(Ra, ta, Ra @ M[:3, :3], Ra @ M[:3, 3] + ta)
    cases = {"two cameras, forward": error(optical_flow(scene, a, camera_b=b), homography(Ra, ta, Rb, tb)),
             "two cameras, backward": error(optical_flow(scene, b, camera_b=a), homography(Rb, tb, Ra, ta)),
             "moved model, forward": error(optical_flow(scene, a, moved), Hm),
             "moved model, backward": error(optical_flow(moved, a, scene), np.linalg.inv(Hm))}
    return [dict(check="flow", case=c, value=v, unit="px", reference="plane homography (closed form)")
            for c, v in cases.items()]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="small images; write nothing tracked")
    args = ap.parse_args(argv)
    w, h = (32, 24) if args.quick else (160, 120)
    rows = export_rows(w, h) + distortion_rows(w, h) + flow_rows(w, h)
    path = outputs(args.quick)[0]
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "w", newline="") as fh:
        wr = csv.DictWriter(fh, fieldnames=["check", "case", "value", "unit", "reference"])
        wr.writeheader()
        for r in rows:
            wr.writerow({**r, "value": r["value"] if isinstance(r["value"], str) else f"{r['value']:.2g}"})
    for r in rows:
        print(f"{r['check']:11s} {r['case']:42s} {r['value'] if isinstance(r['value'], str) else format(r['value'], '.2g')} {r['unit']}")
    print("wrote", path)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
