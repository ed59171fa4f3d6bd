"""The PanoLight datablocks' tags and the estimate stored on a world (ID properties), read and written.

Everything PanoLight makes carries TAG, so a user's datablock that merely shares a name is never taken for
PanoLight's (``ours``). The estimate is a lighting.json document stored as JSON on the world, with a token
(ESTIMATE_KEY) that the reconstructed HDRI image made from it carries too.
"""
from __future__ import annotations

import json

import bpy

from .core import errors, keylight, lighting_file, metadata, units

TAG = "panolight"
PANORAMA_KEY = "panolight_panorama"  # world ID property: the panorama image itself (an ID pointer: renames follow)
LIGHTING_KEY = "panolight_lighting"  # world ID property: the estimate, a lighting.json document as JSON
SOURCE_KEY = "panolight_source"  # image ID property: the file an upright copy was made from
BRACKETS_KEY = "panolight_brackets"  # image ID property: the bracket set (JSON: files, evs) a merged image was made from
ESTIMATE_KEY = "panolight_estimate"  # world and HDRI image ID property: which estimate the HDRI is of
LIGHTING_MAX_BYTES = 1 << 26  # a lighting document of SH order 100 is about 0.6 MB
SETTINGS_KEY = "panolight_settings"  # world ID property: the core Settings the estimate was made with (JSON)
SUN_STRENGTH_KEY = "panolight_sun_strength"  # HDRI image ID property: the Sun lamp strength its key lights carry
PEAK_BESIDE_KEY = "panolight_peak_beside"  # HDRI image ID property: its brightest luminance beside its brightest light


def ours(collection, name: str):
    """PanoLight's own datablock of a kind: the one carrying its tag (renamed or not), preferring ``name``.
    A user's datablock that merely has the name is never returned."""
    tagged = [d for d in collection if d.get(TAG)]
    return next((d for d in tagged if d.name == name), tagged[0] if tagged else None)


def stored_panorama(world):
    """The panorama image of a PanoLight world, or PanoLightError. Tracked by identity: renaming it keeps
    it, and another image that takes its old name is never taken for it."""
    image = world.get(PANORAMA_KEY) if world else None
    if not isinstance(image, bpy.types.Image):  # removed, or a name stored by an earlier version
        image = None
    if image is None:
        raise errors.PanoLightError("no panorama loaded: use Load panorama first")
    return image


def stored_lighting(world) -> dict:
    """The estimate stored on ``world``: a validated lighting document (io.lighting), or PanoLightError."""
    raw = world.get(LIGHTING_KEY) if world else None
    if not raw:
        raise errors.PanoLightError("no lighting estimated yet: use Estimate lighting first")
    doc = metadata.json_object(raw, LIGHTING_MAX_BYTES)  # validated: an edited one is refused
    if doc is None:
        raise errors.PanoLightError("the stored estimate is not a lighting document (edited?): use Estimate "
                                         "lighting again")
    return lighting_file.validate(doc, "the estimated lighting")


def store_lighting(world, doc: dict | None, settings=None) -> None:
    """Store an estimate on ``world`` (None forgets it: a new panorama needs a new estimate), with the core
    ``Settings`` it was made with and a new ESTIMATE_KEY token (the HDRI image made from it carries the same token)."""
    import uuid

    if doc is None:
        for key in (LIGHTING_KEY, ESTIMATE_KEY, SETTINGS_KEY):
            world.pop(key, None)
    else:
        world[LIGHTING_KEY] = json.dumps(doc)
        world[ESTIMATE_KEY] = uuid.uuid4().hex
        if settings is not None:
            world[SETTINGS_KEY] = json.dumps(_settings_record(settings))
        else:
            world.pop(SETTINGS_KEY, None)


def _settings_record(settings) -> dict:
    """The core Settings as JSON values (tuples as lists), as SETTINGS_KEY keeps them."""
    import dataclasses

    return json.loads(json.dumps(dataclasses.asdict(settings)))


def same_settings_but_strength(world, settings) -> bool:
    """Whether the stored estimate was made with ``settings`` but for their sun strength (validated: an edited or
    missing record is not): then a new strength is that estimate's key lights scaled, nothing else."""
    stored = metadata.json_object(world.get(SETTINGS_KEY)) if world is not None else None
    if stored is None:
        return False
    now = _settings_record(settings)
    return {k: v for k, v in stored.items() if k != "sun_strength"} == \
        {k: v for k, v in now.items() if k != "sun_strength"}


def has_lighting(world) -> bool:
    return bool(world is not None and world.get(LIGHTING_KEY))


def _panel_document(world) -> dict | None:
    """The stored estimate as a JSON object, unvalidated (the panel's lines read it on every redraw and never
    raise), or None without one."""
    raw = world.get(LIGHTING_KEY) if world is not None else None
    return metadata.json_object(raw, LIGHTING_MAX_BYTES) if raw else None


def units_line(world) -> str | None:
    """The stored estimate's units in one line (``camera.units.summary``: relative, or cd/m^2 and lux, and what one
    unit is), for the panel; None without an estimate. Never raises."""
    doc = _panel_document(world)
    return None if doc is None else units.summary(doc.get("physical"))


def key_light_range(world) -> dict | None:
    """The stored estimate's key light and its 68 % energy range over the strength it was given
    (``keylight.key_light_range``), for the panel; None without an estimate or a key light. Never raises:
    the panel draws it on every redraw."""
    doc = _panel_document(world)
    try:
        return keylight.key_light_range(doc) if doc is not None else None
    except (TypeError, ValueError, KeyError, IndexError, AttributeError):
        return None
