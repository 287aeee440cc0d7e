"""The ``stacklevel`` that attributes a warning to the user's own line.

A warning raised deep inside the package (a ``cached_property`` such as
``Mesh.prepared``, reached through ``render``) with a fixed ``stacklevel``
names one of our files, or ``functools.py`` (the property's ``__get__``): a
notebook then shows a warning box pointing at neither the cell nor the call.
"""

from __future__ import annotations

import sys

__all__ = ["user_stacklevel"]

# Frames passed over: this package's, and functools' (cached_property.__get__ lies between a
# property's body and the attribute access that ran it).
_SKIPPED = ("raycast_shade", "functools")


def user_stacklevel() -> int:
    """``stacklevel`` for a ``warnings.warn`` made by the function calling this one: the first frame
    outside this package (and outside ``functools``), i.e. the user's line.

    Returns
    -------
    int
        At least 2 (the warning's own function's caller) when called from the package.
    """
    frame, level = sys._getframe(1), 1
    while frame is not None:
        name = frame.f_globals.get("__name__", "") or ""
        if name.split(".", 1)[0] not in _SKIPPED:
            break
        frame, level = frame.f_back, level + 1
    return level
