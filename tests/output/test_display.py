"""Pictures in a notebook without magic: figures, frames, overlays and terms display as PNGs
through IPython's own display formatter (no %matplotlib inline); explain()'s printout
recomputes at its printed precision."""

from __future__ import annotations

import io
import re

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.output.display import ImageArray, Picture, display_scale
from raycast_shade.output.frame import NoTerms, TermsMissingError

pytest.importorskip("matplotlib")
pytest.importorskip("IPython")


def _scene(w=64, h=48, shininess=40.0, **material):
    return rs.Scene([rs.Model(rs.shapes.icosphere(2), rs.Material(kd=(0.8, 0.3, 0.2), ks=0.5, shininess=shininess,
                                                                  **material)),
                     rs.Model(rs.shapes.plane(5.0, center=(0.0, -1.0, 0.0), normal="+y"),
                              rs.Material(kd=0.5, reflectivity=0.3))],
                    lights=[rs.PointLight((2.0, 3.0, 2.0), intensity=20.0, attenuation="inverse_square",
                                          shadows=True)],
                    camera=rs.Camera(eye=(0.0, 1.0, 4.0), target=(0.0, -0.3, 0.0), width=w, height=h), ambient=0.1)


@pytest.fixture(scope="module")
def frame():
    return rs.render(_scene(), "phong", terms=True)


def _formats(obj):
    from IPython.core.formatters import DisplayFormatter

    data, _ = DisplayFormatter().format(obj)  # a fresh formatter: no backend has registered anything
    return data


def _png(data):
    import imageio.v3 as iio

    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    return iio.imread(io.BytesIO(data))


# -- figures ---------------------------------------------------------------------------------------------

def test_a_plain_matplotlib_figure_is_text_in_a_plain_kernel():
    """The failure the figures' class fixes: without a backend's formatter, a Figure is its repr."""
    from matplotlib.figure import Figure

    fig = Figure()
    fig.add_subplot().plot([0, 1])
    assert "image/png" not in _formats(fig)


def test_every_figure_displays_as_a_png_in_a_plain_kernel(frame):
    figures = [rs.figures.montage([frame, frame.image]), rs.figures.difference(frame, frame.image * 0.5),
               rs.figures.profile(frame, 20), rs.figures.montage(frame.terms)]
    for fig in figures:
        data = _formats(fig)
        assert "image/png" in data, type(fig)
        img = _png(data["image/png"])
        assert img.shape[0] > 100 and img.shape[1] > 200
        assert img.std() > 0  # something is drawn


def test_a_figure_is_still_a_matplotlib_figure(frame, tmp_path):
    from matplotlib.figure import Figure

    fig = rs.figures.montage([frame])
    assert isinstance(fig, Figure)
    fig.savefig(tmp_path / "m.png")
    assert _png((tmp_path / "m.png").read_bytes()).ndim == 3


# -- frames and overlays -----------------------------------------------------------------------------------

@pytest.mark.parametrize("w, expected", [(16, 30), (64, 8), (160, 3), (240, 2), (320, 2), (480, 1), (2000, 1)])
def test_default_display_scale_is_legible_and_bounded(w, expected):
    s = display_scale((10, w))
    assert s == expected
    assert w * s >= min(480, w * (1024 // w) if w <= 1024 else w)
    assert s == 1 or w * s <= 1024


def test_frame_displays_upscaled_nearest_neighbour(frame):
    data = _formats(frame)
    assert "image/png" in data and data["text/plain"].startswith("Frame(64x48")
    shown = _png(data["image/png"])
    assert shown.shape == (48 * 8, 64 * 8, 3)
    expected = frame.to_uint8()
    np.testing.assert_array_equal(shown, np.repeat(np.repeat(expected, 8, axis=0), 8, axis=1))


def test_show_takes_a_scale_or_a_width_and_tone(frame):
    assert _png(frame.show(scale=3)._repr_png_()).shape == (144, 192, 3)
    assert frame.show(width=200).scale == 3  # the largest integer scale within 200 pixels
    assert frame.show(width=10).scale == 1
    dark = frame.show(scale=1, exposure=0.25)
    np.testing.assert_array_equal(dark.rgb, frame.to_uint8(exposure=0.25))
    with pytest.raises(ValueError, match="scale, width"):
        frame.show(scale=2, width=100)
    with pytest.raises(ValueError, match="scale"):
        frame.show(scale=0)
    with pytest.raises(TypeError, match="scale"):
        frame.show(scale=1.5)
    with pytest.raises(TypeError, match="exposur"):
        frame.show(exposur=2)
    assert repr(frame.show(scale=2)) == "Picture(64x48, shown at 2x: 128x96)"


def test_picture_refuses_what_is_not_an_8_bit_rgb_image():
    with pytest.raises(ValueError, match="rgb"):
        Picture(np.zeros((4, 4, 3), np.float32))
    with pytest.raises(ValueError, match="rgb"):
        Picture(np.zeros((4, 4), np.uint8))


def test_overlay_is_an_array_that_displays_as_a_picture(frame):
    ov = frame.overlay(wireframe=True)
    assert isinstance(ov, ImageArray) and isinstance(ov, np.ndarray) and ov.dtype == np.float32
    shown = _png(_formats(ov)["image/png"])
    np.testing.assert_array_equal(shown[::8, ::8], rs.to_uint8(np.asarray(ov)))
    # arithmetic gives plain arrays (which show as numbers), reductions plain scalars
    assert type(ov * 2) is np.ndarray and type(ov.max()) is np.float32
    assert "image/png" not in _formats(ov[..., 0])  # a slice that is no RGB image stays text
    assert ov.show(scale=2).rgb.shape == (48, 64, 3)


def test_overlay_keeps_the_frames_tone():
    scene = _scene()
    frame = rs.render(scene, "gouraud").with_tone({"exposure": 0.5})
    ov = frame.overlay()
    np.testing.assert_array_equal(ov.show(scale=1).rgb, rs.to_uint8(np.asarray(ov), exposure=0.5))


# -- terms --------------------------------------------------------------------------------------------------

def test_terms_of_a_frame_without_them_say_how_to_get_them():
    plain = rs.render(_scene(), "phong")
    t = plain.terms
    assert isinstance(t, NoTerms) and t == {} and not t and not plain.has_terms
    with pytest.raises(TermsMissingError, match=r"terms=True") as info:
        t["diffuse"]
    assert isinstance(info.value, KeyError) and str(info.value).startswith("frame.terms['diffuse']")
    assert "terms=True" in repr(t)
    with pytest.raises(ValueError, match="terms=True"):
        rs.figures.montage(plain.terms)


def test_montage_of_terms_shares_one_linear_scale_with_a_colour_bar(frame):
    fig = rs.figures.montage(frame.terms)
    t = frame.terms
    colour = [k for k, v in t.items() if v.ndim == 3 and v.shape[2] == 3]
    titles = [ax.get_title() for ax in fig.axes if ax.get_title()]
    assert titles == colour + ["keep", "shadow[0]"]
    vmax = max(float(t[k].max()) for k in colour)
    for ax in fig.axes[:len(colour)]:
        np.testing.assert_array_equal(ax.images[0].get_array(), rs.to_uint8(t[ax.get_title()], exposure=1 / vmax))
    bars = [ax for ax in fig.axes if ax.get_label() == "<colorbar>"]
    assert len(bars) == 2
    lo, hi = sorted(bars[0].get_ylim()) if bars[0].get_ylim()[1] > 1.01 else sorted(bars[1].get_ylim())
    assert lo == 0.0 and hi == pytest.approx(vmax)


def test_the_shadow_mask_is_not_white_on_white(frame):
    fig = rs.figures.montage({"shadow": frame.terms["shadow"]})
    ax = fig.axes[0]
    assert ax.get_title() == "shadow[0]"
    rgba = ax.images[0].cmap(1.0)
    assert min(rgba[:3]) < 0.5  # lit (1) is a colour, not white
    assert ax.images[0].get_clim() == (0.0, 1.0)
    np.testing.assert_array_equal(ax.images[0].get_array(), frame.terms["shadow"][0])


def test_terms_refuse_what_is_not_a_term():
    img = np.zeros((4, 5, 3))
    with pytest.raises(ValueError, match=r"terms\['x'\].*\[0, 1\]"):
        rs.figures.terms({"x": np.full((4, 5), 2.0)})
    with pytest.raises(ValueError, match=r"terms\['x'\].*finite"):
        rs.figures.terms({"x": np.full((4, 5, 3), np.nan)})
    with pytest.raises(TypeError, match="keys"):
        rs.figures.terms({1: img})
    with pytest.raises(TypeError, match="items"):
        rs.figures.terms([img])
    with pytest.raises(ValueError, match="labels"):
        rs.figures.montage({"a": img}, ["b"])


# -- explain's printout ---------------------------------------------------------------------------------

_NUM = r"-?[0-9.]+(?:e[-+]?[0-9]+)?"
_VAL = rf"(?:\({_NUM}(?:, {_NUM})*\)|{_NUM})"


def _value(text):
    return np.array([float(x) for x in re.findall(_NUM, text)])


def _same_at_4(a, b):
    from raycast_shade.insight.explain_text import fmt

    return fmt(a) == fmt(b) if np.size(b) > 1 or np.size(a) == 1 else fmt(a[0]) == fmt(b)


def _check_printout(text):
    """Every product, power and sum line recomputes, from its printed operands, to its printed result."""
    checked = 0
    t = float(re.search(rf"shininess t = ({_NUM})", text).group(1)) if "shininess t" in text else None
    for m in re.finditer(rf"(?:r\.v|n\.h) = ({_NUM}), \((?:r\.v|n\.h)\)\^t = ({_NUM})", text):
        shin = float(re.findall(rf"shininess t = ({_NUM})", text[:m.start()])[-1])
        c, p = float(m.group(1)), float(m.group(2))
        assert f"{min(max(c, 0.0), 1.0) ** shin:.4g}" == f"{p:.4g}", m.group(0)
        checked += 1
    for m in re.finditer(rf"= ({_VAL}(?: x {_VAL})+) = ({_VAL})", text):
        ops = [_value(o) for o in re.findall(_VAL, m.group(1))]
        prod = np.ones(1)
        for o in ops:
            prod = prod * o
        assert _same_at_4(prod, _value(m.group(2))), m.group(0)
        checked += 1
    for m in re.finditer(rf"specular = ({_VAL}) \+ ({_VAL}) \+ ({_VAL})\n\s+= ({_VAL})", text):
        total = _value(m.group(1)) + _value(m.group(2)) + _value(m.group(3))
        assert _same_at_4(total, _value(m.group(4))), m.group(0)
        checked += 1
    assert t is None or checked >= 2  # at least the ambient product and the sum
    return checked


@pytest.mark.parametrize("method", ["flat", "gouraud", "phong"])
@pytest.mark.parametrize("shininess", [40.0, 400.0])
def test_explain_recomputes_at_its_printed_precision(method, shininess):
    frame = rs.render(_scene(48, 36, shininess=shininess), method)
    ys, xs = np.nonzero(frame.mask)
    total = 0
    for i in range(0, len(xs), 41):
        total += _check_printout(str(frame.explain(int(xs[i]), int(ys[i]))))
    assert total > 20


def test_explain_near_the_highlight_prints_enough_digits():
    """The issue's case: r.v close to 1 printed as 0.9998 or 1 while (r.v)^t is not its 4-digit power."""
    frame = rs.render(_scene(96, 72, shininess=40.0), "phong")
    lines = []
    for y, x in zip(*np.nonzero(frame.mask)):
        text = str(frame.explain(int(x), int(y)))
        m = re.search(rf"r\.v = ({_NUM}), \(r\.v\)\^t = ({_NUM})", text)
        if m and float(m.group(1)) > 0.999:
            lines.append(m.group(0))
            _check_printout(text)
    assert lines, "no pixel near the highlight"
    assert any(len(line.split(",")[0].split("= ")[1]) > 6 for line in lines)  # more than 4 digits were needed


def test_explain_uses_the_fields_names_and_says_when_a_pixel_is_clipped():
    frame = rs.render(_scene(48, 36), "phong")
    i = np.unravel_index(np.argmax(frame.image.max(axis=2)), frame.mask.shape)
    assert frame.image[i].max() > 1.0
    text = str(frame.explain(int(i[1]), int(i[0])))
    assert "ks = 0.5, shininess t = 40" in text and "t = material.shininess" in text and "Ks = material.ks" in text
    assert "shown clipped to 1" in text and "above 1" in text
    dim = np.unravel_index(np.argmin(np.where(frame.mask, frame.image.max(axis=2), 9)), frame.mask.shape)
    assert "clipped" not in str(frame.explain(int(dim[1]), int(dim[0])))
    assert max(len(line) for line in text.splitlines()) <= 110
