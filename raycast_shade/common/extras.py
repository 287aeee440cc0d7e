"""Optional dependencies: import on demand, or say which extra to install."""

from __future__ import annotations

import importlib

__all__ = ["MissingExtraError", "require"]


class MissingExtraError(ImportError):
    """An optional dependency is not installed; the message says how to get it."""


def require(module: str, package: str, what: str, extra: str):
    """Import ``module``, or raise :class:`MissingExtraError` naming ``pip install 'raycast_shade[extra]'``.

    Parameters
    ----------
    module : str
        Dotted module name, e.g. ``"matplotlib.figure"``.
    package : str
        The distribution that provides it, e.g. ``"matplotlib"``.
    what : str
        The feature that needs it, for the message.
    extra : str
        The optional-dependency group of ``pyproject.toml`` that installs it.
    """
    try:
        return importlib.import_module(module)
    except ImportError:
        raise MissingExtraError(
            f"{what} needs the optional package {package!r}, which is not installed: "
            f"pip install 'raycast_shade[{extra}]' (or pip install {package})"
        ) from None
