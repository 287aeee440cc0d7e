"""OpenCV lenses with tangential terms (p1, p2): the fold warning's share, estimated as the ray casting
undistorts, against every pixel of the kernel's own answer."""

from __future__ import annotations

import re
import warnings

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.scene.lens import TANGENTIAL_GRID, tangential_fraction
from raycast_shade.scene.projection import intrinsics
from raycast_shade.visibility.distortion import undistort


def _forward(x, y, k):
    """OpenCV's model as its documentation writes it (cv2.projectPoints), plain NumPy."""
    k1, k2, p1, p2, k3 = k
    r2 = x * x + y * y
    s = 1 + k1 * r2 + k2 * r2 ** 2 + k3 * r2 ** 3
    return x * s + 2 * p1 * x * y + p2 * (r2 + 2 * x * x), y * s + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y


def _jacobian_det(x, y, k, h=1e-6):
    """By central differences of :func:`_forward` (independent of the library's closed form)."""
    xa, ya = _forward(x + h, y, k)
    xb, yb = _forward(x - h, y, k)
    xc, yc = _forward(x, y + h, k)
    xe, ye = _forward(x, y - h, k)
    return ((xa - xb) * (yc - ye) - (xc - xe) * (ya - yb)) / (4 * h * h)


def _kernel_inside(cam, samples=400):
    """Every pixel: the kernel gives a ray, and the Jacobian stays positive from the axis to it."""
    k = np.zeros(5)
    k[:len(cam.distortion)] = cam.distortion
    fx, fy, cx, cy = intrinsics(cam)
    jj, ii = np.mgrid[0:cam.height, 0:cam.width]
    d, ok = undistort(cam, (ii.ravel() - cx) / fx, (jj.ravel() - cy) / fy)
    x, y = d[ok, 0] / d[ok, 2], d[ok, 1] / d[ok, 2]
    s = np.linspace(0.0, 1.0, samples)[1:, None]
    with np.errstate(all="ignore"):
        det = _jacobian_det(s * x, s * y, k)
    return np.count_nonzero(np.all(det > 0, axis=0)) / ok.size


def _camera(k, **kw):
    kw = dict(eye=(0, 0, 3), fov=70, width=80, height=60) | kw
    return rs.Camera(distortion=k, **kw)


@pytest.mark.parametrize("k", [(-0.5, 0.0, 0.05, 0.0), (-0.5, 0.0, 0.2, 0.1), (-1.0, 0.2, 0.3, -0.2, 0.05),
                               (2.0, -3.0, 0.4, 0.0), (-50.0, 0.0, 0.1, 0.0)])
def test_a_folding_tangential_lens_warns_with_the_kernels_share(k):
    with pytest.warns(rs.LensFoldWarning) as record:
        cam = _camera(k)
    text = str(record[0].message)
    share = re.search(r"about ([0-9.]+)% of the frame's pixel centres have a ray inside the fold \(estimated on "
                      rf"{min(80, TANGENTIAL_GRID) * min(60, TANGENTIAL_GRID)} of them", text)
    assert share, text
    assert "tangential terms p1, p2" in text
    truth = 100.0 * _kernel_inside(cam)
    assert abs(float(share.group(1)) - truth) < 2.5, (share.group(1), truth)
    assert float(share.group(1)) < 100.0


@pytest.mark.parametrize("k", [(0.3, -0.05, 1e-3, 0.0), (-0.3, 0.05, 0.01, -0.01), (-0.1, 0.01, -2e-3, 1e-3, 0.001)])
def test_a_real_lens_with_tangential_terms_is_silent(k):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        cam = _camera(k)
    assert tangential_fraction(cam) == 1.0
    assert _kernel_inside(cam) == 1.0


def test_the_folded_share_is_not_the_rays_share():
    """k1 = -50 with p1 = 0.1: the kernel finds a ray for about 13% of the pixels, nearly all of them
    from past the fold; the warning counts only those inside it."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", rs.LensFoldWarning)
        cam = _camera((-50.0, 0.0, 0.1, 0.0))
    fx, fy, cx, cy = intrinsics(cam)
    jj, ii = np.mgrid[0:cam.height, 0:cam.width]
    _, ok = undistort(cam, (ii.ravel() - cx) / fx, (jj.ravel() - cy) / fy)
    assert ok.mean() > 0.05
    assert tangential_fraction(cam) < 0.02
