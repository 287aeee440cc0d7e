"""A matplotlib Figure that a notebook shows as a picture without ``%matplotlib inline``.

IPython draws a plain :class:`matplotlib.figure.Figure` as an image only when
a matplotlib backend has registered its formatter (``%matplotlib inline``, or
pyplot imported in an IPython kernel); otherwise the cell shows the text
``<Figure size 1600x340 with 4 Axes>``. :class:`LectureFigure` carries its own
``_repr_png_``, which IPython's display formatter calls in any kernel. Where a
backend's formatter is registered, that one runs instead (it is looked up by
type first), so the picture shows once either way.

Imports matplotlib: :mod:`raycast_shade.output.figures` loads it on first use.
"""

from __future__ import annotations

import io

from matplotlib.figure import Figure

__all__ = ["LectureFigure"]


class LectureFigure(Figure):
    """:class:`matplotlib.figure.Figure` with ``_repr_png_`` (tight bounding box, the figure's dpi)."""

    def _repr_png_(self) -> bytes:
        buf = io.BytesIO()
        self.savefig(buf, format="png", bbox_inches="tight")
        return buf.getvalue()
