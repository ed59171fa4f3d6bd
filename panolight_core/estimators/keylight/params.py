"""The key light's constants, in one place (``KeyLightParams``; ``PARAMS`` is what ships). Each was measured over
the real HDRs: the evidence for every value is in docs/studies/keylight_params.md."""
from __future__ import annotations

from dataclasses import dataclass

SUN_DIAMETER_DEG = 0.53  # the sun's angular diameter seen from the earth


@dataclass(frozen=True)
class KeyLightParams:
    """The key light's constants (``PARAMS`` ships; a study varies one with ``dataclasses.replace``). Energies are
    luminance x sr in camera units, angles degrees; the evidence for each value: docs/studies/keylight_params.md.

    key_share, sun_share: the share of the scene's predicted energy a region needs to hold a key light (sun_share:
        with a clear sky's sun in it).
    max_keys: the most key lights one panorama gets.
    sky_correction: true / clear-sky model sun energy, the real suns' median (``weighing.clear_sky_energy``).
    camera_white, white_ramp_deg: the camera's white point (linear sRGB, luminance 1) a sun's colour is divided by,
        from none of it at [0] degrees up to all of it at [1] (``weighing.camera_colour``).
    sky_spread: the clear-sky energy's 68 % range, a factor.
    lamp_min_diameter_deg: the smallest angular diameter of a lamp.
    shoulder: linear level (clip 1) above which a channel is on the camera's highlight shoulder (no glare colour).
    plateau_extent_deg: a region wider than this (angular radius) without a clear-sky sun makes no light.
    hidden_clearance_deg: a sun found from the sky alone lies at least this far beyond every clipped region.
    direction_68_per_extent: a light's 68 % direction error as a share of its region's angular radius.
    floor_max_extent_deg, floor_min_elevation_deg: a clear-sky sun on a region no wider, standing at least this
        high, is trusted: kept within its fit's 68 % range (``weighing.physics_trusted``).
    belief: a key light carries its evidence's belief, not the decided fill's caution (an HDR file's plateau).
    sky_alone_sun: a sun the photo does not show is put back where its clear sky alone places it (the bolder rule,
        ``--sky-sun``); by default only the note says where, and ``--sun`` (Blender: Pick sun) places it.
    """

    key_share: float = 0.1
    sun_share: float = 0.02
    max_keys: int = 3
    sky_correction: float = 2.25
    camera_white: tuple = (1.1542, 0.9772, 0.7713)
    white_ramp_deg: tuple = (10.0, 20.0)
    sky_spread: float = 2.0
    lamp_min_diameter_deg: float = 1.0
    shoulder: float = 0.75
    plateau_extent_deg: float = 30.0
    hidden_clearance_deg: float = 20.0
    direction_68_per_extent: float = 0.25
    floor_max_extent_deg: float = 30.0
    floor_min_elevation_deg: float = 15.0
    belief: bool = False
    sky_alone_sun: bool = False


PARAMS = KeyLightParams()  # what ships
