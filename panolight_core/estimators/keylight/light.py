"""A key light: a compact source (a sun, a lamp) as one explicit light, with what weighed it."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import sky as clear_sky


@dataclass
class KeyLight:
    """A key light: unit direction (3,), luminance energy (clip units x sr), colour (luminance 1), angular
    diameter (radians), the 68 % range of the source's true energy (the belief; ``energy`` is what
    ``key_energy`` decides, which may lie below it), the region it came from and how it was weighed, the
    direction's 68 % error radius (radians: ``direction_68_per_extent`` of the region's radius, at least a cell),
    the cap on its regions' energy, and the candidates ``key_energy`` decided from."""

    direction: np.ndarray
    energy: float
    color: np.ndarray
    angle: float
    energy_68: tuple
    region: int  # -1: a hidden sun, which no clipped region holds (its energy is added, none taken from a fill)
    method: str
    physical: float | None = None  # the clear-sky fit's energy x sky_correction
    sky: clear_sky.SkyFit | None = None  # the clear-sky fit tried at its direction (clear or not); None below the horizon
    direction_68: float = 0.0
    parts: tuple = ()  # other regions of the same source (a sun's patch split in two): its energy comes from them too
    cap: float | None = None  # the most its regions may hold beyond their clip level, light and fill together: a
    # trusted sun's fit x sky_spread (the high end of its 68 % range; ``cap_log_ratios``); None: no cap
    weak: bool = False  # a clear-sky sun admitted under key_share only because its fit passes (from sun_share)
    learned: float = 0.0  # the per-source model's mean energy for its regions (``key_energy``'s candidates) ...
    decided: float = 0.0  # ... the decided fill's ...
    trusted: bool = False  # ... and whether its clear-sky fit bounds it (``physics_trusted``)

    def as_light(self) -> dict:
        """A lighting-file light dict (energy as intensity)."""
        return {"type": "sun" if math.degrees(self.angle) <= 5.0 else "area",
                "direction": [float(v) for v in self.direction], "peak_direction": [float(v) for v in self.direction],
                "color": [float(v) for v in self.color], "intensity": float(self.energy), "angle": float(self.angle),
                "energy_68": [float(v) for v in self.energy_68],
                "direction_68_deg": round(math.degrees(self.direction_68), 3), "source": self.method}
