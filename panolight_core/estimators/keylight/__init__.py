"""The key light: each compact source a panorama clipped (a sun, a lamp), made one explicit light that casts its
shadow, and what a user is told of it. One package, one file per stage:

- ``find``: which clipped regions hold a key light, where each stands, and a sun the photo does not show;
- ``weighing``: what every kind of sun and lamp weighs (``weigh``: energy, 68 % range, cap) and how it looks;
- ``pointer``: the artist's sun (``--sun``, *Pick sun*) or the photo's metadata sun, in place of a found one;
- ``notes``: the run's one line about the key light (CLI, batch and Blender);
- ``params``: every constant (``KeyLightParams``; ``PARAMS`` ships), ``light``: the ``KeyLight`` record.

To change how a sun's energy is decided, change ``weighing.weigh`` (or ``weighing.key_energy``, which it calls).
"""
from .find import (
    at_cores,
    find_key_lights,
    hidden_refusals,
    hidden_sun,
    region_candidates,
    sun_search_report,
    with_hidden_sun,
    with_key_lights,
)
from .light import KeyLight
from .notes import key_light_note, key_light_range, restoration_note
from .params import PARAMS, SUN_DIAMETER_DEG, KeyLightParams
from .pointer import METADATA_DEFERS_DEG, SkyCannotWeigh, photo_places_sun, with_pointed_sun
from .weighing import Weight, camera_colour, clear_sky_energy, key_energy, physics_trusted, ring_colour, weigh

__all__ = ["KeyLight", "KeyLightParams", "METADATA_DEFERS_DEG", "PARAMS", "SUN_DIAMETER_DEG", "SkyCannotWeigh",
           "Weight", "at_cores", "camera_colour", "clear_sky_energy", "find_key_lights", "hidden_refusals",
           "hidden_sun", "key_energy", "key_light_note", "key_light_range", "photo_places_sun", "physics_trusted",
           "region_candidates", "restoration_note", "ring_colour", "sun_search_report", "weigh", "with_hidden_sun",
           "with_key_lights", "with_pointed_sun"]
