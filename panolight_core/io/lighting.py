"""The lighting file (lighting.json): SH radiance coefficients plus optional explicit lights.

Schema: panolight_core/schemas/lighting.schema.json. ``validate`` checks everything the schema says
plus what JSON Schema cannot (row count = (lmax+1)^2, finite numbers, unit light directions), in plain
Python so it also runs inside Blender where jsonschema is absent.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from ..errors import LightingFileError
from .atomic import atomic_path
from .metadata import MAX_JSON_DEPTH, too_deep

FRAME = "blender-world-z-up"
BASIS = "real-orthonormal-no-condon-shortley"
LIGHT_TYPES = ("sun", "area", "spot", "point")
FORMAT_VERSION = 1


def schema() -> dict:
    """The JSON Schema of the lighting file, as a dict."""
    return json.loads((Path(__file__).resolve().parents[1] / "schemas" / "lighting.schema.json").read_text())


def make_lighting(coeffs, *, units: str = "relative", lights=(), **extra) -> dict:
    """Build a lighting document from (K, 3) coefficients; ``extra`` keys (source, estimator, timings,
    window) are copied in. The result passes ``validate``."""
    c = np.asarray(coeffs, dtype=np.float64)
    k = c.shape[0] if c.ndim == 2 else 0
    lmax = math.isqrt(k) - 1
    doc = {
        "format_version": FORMAT_VERSION,
        "lmax": lmax,
        "coefficients": c.tolist(),
        "frame": FRAME,
        "basis": BASIS,
        "units": units,
        "color_space": "linear-rec709",
        "lights": [dict(light) for light in lights],
        **extra,
    }
    validate(doc)
    return doc


def _number(x) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


def validate(doc, source="lighting") -> dict:
    """Raise LightingFileError (naming ``source`` and the first problem) unless ``doc`` is valid."""
    def bad(msg):
        raise LightingFileError(source, msg)

    if not isinstance(doc, dict):
        bad(f"top level must be a JSON object, got {type(doc).__name__}")
    _check_header(doc, bad)
    lights = doc.get("lights", [])
    if not isinstance(lights, list):
        bad("'lights' must be a list")
    for i, light in enumerate(lights):
        _check_light(f"light {i}", light, bad)
    src = doc.get("source")
    if src is not None:
        if not isinstance(src, dict):
            bad(f"'source' must be an object with 'path' and 'sha256', got {type(src).__name__}")
        for key in ("path", "sha256"):
            if key in src and not isinstance(src[key], str):
                bad(f"'source.{key}' must be a string")
    return doc


def _check_header(doc: dict, bad) -> None:
    """The required keys, the order, frame, basis, version and units, and (lmax + 1)^2 rows of 3 finite numbers."""
    for key in ("lmax", "coefficients", "frame", "basis"):
        if key not in doc:
            bad(f"missing required key {key!r}")
    lmax = doc["lmax"]
    if not isinstance(lmax, int) or isinstance(lmax, bool) or not 0 <= lmax <= 100:
        bad(f"'lmax' must be an integer in 0..100, got {lmax!r}")
    if doc["frame"] != FRAME:
        bad(f"'frame' must be {FRAME!r} (convert other frames before writing), got {doc['frame']!r}")
    if doc["basis"] != BASIS:
        bad(f"'basis' must be {BASIS!r}, got {doc['basis']!r}")
    coeffs = doc["coefficients"]
    if not isinstance(coeffs, list) or len(coeffs) != (lmax + 1) ** 2:
        n = len(coeffs) if isinstance(coeffs, list) else type(coeffs).__name__
        bad(f"'coefficients' must have (lmax+1)^2 = {(lmax + 1) ** 2} rows for lmax {lmax}, got {n}")
    for i, row in enumerate(coeffs):
        if not isinstance(row, list) or len(row) != 3 or not all(_number(v) for v in row):
            bad(f"coefficient row {i} must be 3 finite numbers [r, g, b], got {row!r}")
    if "format_version" in doc and doc["format_version"] != FORMAT_VERSION:
        bad(f"unsupported format_version {doc['format_version']!r} (this PanoLight reads {FORMAT_VERSION})")
    if "units" in doc and not isinstance(doc["units"], str):
        bad("'units' must be a string")


def _check_light(where: str, light, bad) -> None:
    """One light: its type, unit direction, non-negative colour and intensity, and angle (an area light's)."""
    if not isinstance(light, dict):
        bad(f"{where} must be an object")
    for key in ("type", "direction", "color", "intensity"):
        if key not in light:
            bad(f"{where} is missing {key!r}")
    if light["type"] not in LIGHT_TYPES:
        bad(f"{where}: type must be one of {LIGHT_TYPES}, got {light['type']!r}")
    d = light["direction"]
    if not isinstance(d, list) or len(d) != 3 or not all(_number(v) for v in d):
        bad(f"{where}: direction must be 3 finite numbers")
    if abs(math.sqrt(sum(v * v for v in d)) - 1.0) > 1e-3:
        bad(f"{where}: direction must be a unit vector, got {d}")
    col = light["color"]
    if not isinstance(col, list) or len(col) != 3 or not all(_number(v) and v >= 0 for v in col):
        bad(f"{where}: color must be 3 finite non-negative numbers")
    if not _number(light["intensity"]) or light["intensity"] < 0:
        bad(f"{where}: intensity must be a finite non-negative number")
    if "angle" in light and (not _number(light["angle"]) or not 0 <= light["angle"] <= math.pi):
        bad(f"{where}: angle must be in [0, pi] radians")
    if light["type"] == "area" and "angle" not in light:
        bad(f"{where}: an area light needs its angular diameter 'angle' (radians)")


def read_lighting(path) -> tuple[np.ndarray, dict]:
    """Read and validate a lighting file. Returns ((K, 3) float64 coefficients, the whole document)."""
    p = Path(path)
    if not p.is_file():
        raise LightingFileError(p, "file not found")
    try:
        text = p.read_text(encoding="utf-8")
        if too_deep(text):
            raise LightingFileError(p, f"nested deeper than {MAX_JSON_DEPTH} levels: not a lighting file")
        doc = json.loads(text)
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise LightingFileError(p, f"not valid JSON: {exc}") from None
    validate(doc, p)
    return np.asarray(doc["coefficients"], dtype=np.float64).reshape(-1, 3), doc


def write_lighting(path, doc: dict) -> Path:
    """Validate and write a lighting document atomically (temporary file + rename)."""
    p = Path(path)
    validate(doc, p)
    with atomic_path(p) as tmp:
        tmp.write_text(json.dumps(doc, indent=2) + "\n", encoding="utf-8")
    return p
