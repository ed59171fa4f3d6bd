"""Exceptions and warnings of PanoLight: every message names the file (if any) and the problem."""
from __future__ import annotations


class PanoLightError(Exception):
    """Base class of PanoLight's own errors (caught by the CLI and reported without a traceback)."""


class ImageError(PanoLightError, ValueError):
    """An image file could not be used: ``path`` and ``problem`` say which and why."""

    def __init__(self, path, problem: str):
        self.path = str(path)
        self.problem = problem
        super().__init__(f"{self.path}: {problem}")


class LightingFileError(PanoLightError, ValueError):
    """A lighting.json file is missing, malformed or violates the schema."""

    def __init__(self, path, problem: str):
        self.path = str(path)
        self.problem = problem
        super().__init__(f"{self.path}: {problem}")


class PanoLightWarning(UserWarning):
    """Input was repaired (clamped negatives, replaced NaN/Inf, ...): the message says what."""
