"""What the explorer draws around its picture for the back row of a lecture hall.

The explained pixel is marked in every panel by a ring drawn *over* the image (HTML
positioned on the picture, so the PNG stays exactly ``rs.render``'s and a click passes
through the ring to the image), the explained panel's title names it, and the printout
is set at 14 px, wrapped only at spaces (never inside a token such as ``s_i``), in a
box with no scroll bar of its own: all its numbers are on the page.
"""

from __future__ import annotations

import html

__all__ = ["CSS", "FONT_PX", "SIDE_PANEL_PX", "EXPLANATION_PX", "marks_html", "title_html", "explanation_html"]

FONT_PX = 14  # the printout's font size: legible from the back row on a projector
SIDE_PANEL_PX = 320  # side by side, each panel at least this wide (three fit 1366 px with the file browser closed)
EXPLANATION_PX = 660  # the printout's box: 78 characters of 14-px monospace a line, beside 480 px of controls

CSS = ("<style>img.rs-explorer-image {image-rendering: pixelated; image-rendering: crisp-edges; margin: 0;}"
       ".rs-explorer-stage {position: relative; overflow: visible;}"
       ".rs-explorer-marks {position: absolute; left: 0; top: 0; margin: 0; padding: 0; pointer-events: none;}"
       ".rs-explorer-marks * {pointer-events: none;}"
       f".rs-explorer-text pre {{font-size: {FONT_PX}px; line-height: 1.3; margin: 4px; white-space: pre-wrap;"
       " word-break: normal; overflow-wrap: normal;}</style>")


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
    """The printout of one pixel, headed by its panel's name (and a note when the panel changed)."""
    head = f"{html.escape(label)} panel, pixel ({x}, {y})" + (f"  [{html.escape(note)}]" if note else "")
    return f"<pre>{head}\n{html.escape(text)}</pre>"
