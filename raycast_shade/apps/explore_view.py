"""What the explorer draws around its picture for the back row of a lecture hall.

The explained pixel is marked in every panel by a ring drawn *over* the image (HTML
positioned on the picture, so the PNG stays exactly ``rs.render``'s and a click passes
through the ring to the image), the explained panel's title names it, and the printout
is set at 14 px, wrapped only at spaces (never inside a token such as ``s_i``), in a
box with no scroll bar of its own: all its numbers are on the page. Its result (``total I = ...`` and
``frame.image[y, x]``) comes first, in bold, right under its head: side by side, where the printout stands
under the three panels, the answer is on screen at 1366x625 even when the derivation below it is not.
"""

from __future__ import annotations

import html

__all__ = ["CSS", "CONTROL_PX", "FONT_PX", "LINE_HEIGHT", "SIDE_PANEL_PX", "EXPLANATION_PX", "marks_html", "title_html",
           "explanation_html"]

FONT_PX = 14  # the printout's font size: legible from the back row on a projector
CONTROL_PX = 216  # each of the two columns of controls under the picture: together within its 440 px
SIDE_PANEL_PX = 320  # side by side, each panel at least this wide (three fit 1366 px with the file browser closed)
# The printout's least width beside the picture (78 characters of 14-px monospace); it grows to fill the row,
# 85 characters on a 1366-px screen, so that a one-light Phong printout (26 lines) fits a 625-px-high view.
EXPLANATION_PX = 660
LINE_HEIGHT = 1.2  # times FONT_PX: 16.8-px lines (about "normal" for this font), tight enough to fit

CSS = ("<style>img.rs-explorer-image {image-rendering: pixelated; image-rendering: crisp-edges; margin: 0;}"
       ".rs-explorer-stage {position: relative; overflow: visible;}"
       ".rs-explorer-marks {position: absolute; left: 0; top: 0; margin: 0; padding: 0; pointer-events: none;}"
       ".rs-explorer-marks * {pointer-events: none;}"
       # narrower slider readouts ("0.800" still fits): the 216-px columns keep a usable track
       ".rs-explorer .widget-readout, .rs-explorer .jupyter-widget-readout "
       " {flex: 0 0 44px; min-width: 44px; max-width: 44px; padding: 0;}"
       f".rs-explorer-text pre {{font-size: {FONT_PX}px; line-height: {LINE_HEIGHT}; margin: 4px;"
       " white-space: pre-wrap; word-break: normal; overflow-wrap: normal;}"
       ".rs-explorer-total {font-weight: bold;}</style>")


def marks_html(n: int, panel_px: int, width: int, height: int, x: int, y: int, explained: int) -> str:
    """Rings over pixel (x, y) of each of ``n`` panels, ``panel_px`` display pixels wide for a frame of
    ``width`` x ``height``; the explained panel's ring is the bold one.

    Returns
    -------
    str
        An HTML fragment, absolutely positioned over the picture (``.rs-explorer-marks``).
    """
    s = panel_px / width  # display pixels per image pixel, each way
    rings = []
    for p in range(n):
        r = max(6.0, 1.5 * s)  # at least a 12-px ring: visible from the back
        cx, cy = p * panel_px + (x + 0.5) * s, (y + 0.5) * s
        bold = p == explained
        rings.append(
            f"<div class='rs-mark{' rs-mark-explained' if bold else ''}' style='position:absolute;"
            f"left:{cx - r:.1f}px;top:{cy - r:.1f}px;width:{2 * r:.1f}px;height:{2 * r:.1f}px;"
            f"box-sizing:border-box;border-radius:50%;border:{3 if bold else 2}px solid "
            f"{'#ffe000' if bold else '#00e5ff'};box-shadow:0 0 0 1px #000, inset 0 0 0 1px #000'></div>")
    return (f"<div style='position:relative;width:{n * panel_px}px;height:{height * s:.0f}px'>"
            + "".join(rings) + "</div>")


def title_html(label: str, panel_px: int, explained: bool, x: int, y: int) -> str:
    """A panel's title; the explained panel's says so, with its pixel."""
    text = html.escape(label) + (f": pixel ({x}, {y}) explained" if explained else "")
    colour = "background:#ffe000;" if explained else ""
    return (f"<div style='text-align:center;font-weight:bold;font-size:{FONT_PX}px;{colour}"
            f"width:{panel_px}px'>{text}</div>")


def explanation_html(label: str, x: int, y: int, text: str, note: str = "") -> str:
    """The printout of one pixel, headed by its panel's name (and a note when the panel changed).

    ``text`` is :func:`raycast_shade.explain`'s, every line kept; its result (the ``total I = ...`` line and
    the lines after it, which say what shows clipped) moves up under the head, in bold
    (``.rs-explorer-total``). A text without that line (a background pixel's: two lines, all result) is
    set in bold whole.
    """
    head = f"{html.escape(label)} panel, pixel ({x}, {y})" + (f"  [{html.escape(note)}]" if note else "")
    lines = text.split("\n")
    at = next((i for i, line in enumerate(lines) if line.startswith("total I = ")), 0)
    total, rest = lines[at:], lines[:at]
    result = f"<span class='rs-explorer-total'>{html.escape(chr(10).join(total))}</span>"
    return f"<pre>{head}\n{result}" + (f"\n{html.escape(chr(10).join(rest))}" if rest else "") + "</pre>"
