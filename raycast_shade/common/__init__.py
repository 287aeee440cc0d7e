"""Foundations every stage may use: argument validation, the one list of every
choice, the packed kernel layouts, and the balanced parallel schedule. Imports
nothing else of the package."""
