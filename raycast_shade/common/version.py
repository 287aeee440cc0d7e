"""The package version (one place, so that the apps need not import the package root)."""

__version__ = "0.1.0"
