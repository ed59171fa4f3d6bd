"""The key light's constants, in one place (``KeyLightParams``; ``PARAMS`` is what ships). Each was measured over
the real HDRs: the evidence for every value is in docs/studies/keylight_params.md."""
from __future__ import annotations

from dataclasses import dataclass

SUN_DIAMETER_DEG = 0.53  # the sun's angular diameter seen from the earth


@dataclass(frozen=True)
class KeyLightParams:
    """The key light's constants, in one place: what decides which regions hold a key light, where it stands,
    what it weighs and how it looks. Each was measured over the real HDRs (docs/keylight.md; the studies in
    docs/studies/ and training/keylight/). The shipped values are ``PARAMS``; a study varies one with
    ``dataclasses.replace(PARAMS, name=value)``.

    key_share: a region whose predicted energy is at least this share of the scene's holds a key light.
    sun_share: ... or this share, if a clear sky's sun is in it: the sky's own evidence admits the sun, the share
        only keeps glints out. A low sun's share wavers with the pixel grid (dawn.jpg turned by 333 pixels: 0.086
        against 0.103; sunset_water.jpg's sun 3.5 degrees up, which the trees weigh at 3-6 %), and the sun should
        not come and go with it. No scene of the 68 real HDRs at ev -2/0/+2 changes between 0.05 and 0.02; with no
        floor, ten false weak "suns" appear (night skies, rooms).
    max_keys: the most key lights one panorama gets.
    sky_correction: true / physical sun energy: the real suns' median (training/keylight/cv.py: 2.20 over 28,
        folds 2.05-2.37).
    camera_white: the camera's white point in the model's linear sRGB (D65), luminance 1: a camera balances
        sunlit daylight to about neutral, so the model's sun colour over this is what it shows (the median over
        the 27 clear fits of 12 real suns 20 degrees up or more; by fold 1.13-1.17 / 0.97-0.98 / 0.75-0.81;
        training/keylight/sun_colour.py) ...
    white_ramp_deg: ... for a sun at least [1] degrees up (none of it below [0], a share linear in between): the
        real suns 20 degrees up or more came closer to their truth 11 times of 12, those lower (warm, and left
        warm by their photographers) as often farther as closer.
    sky_spread: the clear-sky energy's 68 % range, a factor (the cross-validated spread).
    lamp_min_diameter_deg: the smallest angular diameter of a lamp (a light that is not a clear-sky sun).
    shoulder: linear (clip level 1; sRGB 225): above it a channel sits on the camera's highlight shoulder, and a
        glare colour is not read there.
    plateau_extent_deg: a region this wide (angular radius) with no clear-sky sun in it is a plateau (an overcast
        sky, a window wall), not a compact source: its even fill stays and it makes no light.
    hidden_clearance_deg: a sun found from the sky alone (``sun_search.search_sun``) is a hidden one only this far
        beyond every clipped region (its angular radius plus this): nearer, the region is the sun the photo shows.
    direction_68_per_extent: a light's direction error: within this share of its region's angular radius (at
        least one work cell) for 68 % of the dominant sources of the real HDRs at ev -2/0/+2.
    floor_max_extent_deg, floor_min_elevation_deg: a clear-sky sun whose region is no wider (angular radius) and
        that stands at least this high keeps at least its fit's 68 % low end, its patch at most the high end
        (``physics_trusted``): there the centroid is on the sun and the fit was checked; a wider patch's centroid
        is degrees off, and a low sun's haze makes the model's sun too strong.
    belief: a key light carries what its evidence believes, not the decided fill's caution: the per-source model's
        mean energy for its regions, a clear-sky sun the geometric mean of that and its fit's (two estimates
        averaged in log), and never less than the decided fill's (so its region holds one account: the light).
        What an HDR file's clipped plateau gets (``with_key_lights``): the plateau is a few pixels around the
        source, its place sure, its surroundings un-clipped and linear (docs/studies/captures.md).
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


PARAMS = KeyLightParams()  # what ships
