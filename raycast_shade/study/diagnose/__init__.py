"""Diagnosing a student's image: a variant shader, the catalogue of mistakes, and scoring.

The user-facing function is :func:`raycast_shade.diagnose` (``apps/diagnose.py``).
"""

from .catalogue import Candidate, catalogue
from .variant import Mistake, check_scene, encode, shade_variant

__all__ = ["Candidate", "catalogue", "Mistake", "check_scene", "encode", "shade_variant"]
