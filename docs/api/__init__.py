"""The API reference (``docs/api/*.md``), generated from the docstrings: ``python -m docs.api``."""
