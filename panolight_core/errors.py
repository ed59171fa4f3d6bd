"""Exceptions and warnings of PanoLight: every message names the file (if any) and the problem."""
from __future__ import annotations

import re

_CONTROL = re.compile(r"[\x00-\x1f\x7f-\x9f]")


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


def naming(path, exc: Exception) -> PanoLightError:
    """``exc`` as a PanoLightError whose message names ``path`` once: prefixed with it unless it names it already."""
    text = str(exc)
    return PanoLightError(text if text.startswith(f"{path}:") else f"{path}: {text}")


class Cancelled(PanoLightError):
    """Work stopped because its caller asked (``threads.cancellable``): Blender's Esc."""


class PanoLightWarning(UserWarning):
    """Input was repaired (clamped negatives, replaced NaN/Inf, ...): the message says what."""


def printable(text) -> str:
    """``text`` safe to print on a terminal, on one line: control characters (a file name's escape
    sequences, newlines) written as ``\\xNN``."""
    return _CONTROL.sub(lambda m: f"\\x{ord(m.group()):02x}", str(text))
