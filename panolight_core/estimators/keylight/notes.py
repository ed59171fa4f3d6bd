"""What an artist should know about the key light, in one line (``key_light_note``): read from a lighting document,
so the CLI, batch and Blender say the same. ``key_light_range`` is the key light's 68 % range over the strength it
was given (Blender's panel draws it)."""
from __future__ import annotations

import math

import numpy as np

from ... import sh
from ..sun_search import AT_THE_HORIZON
from .find import SKY_ALONE


def key_light_range(doc: dict) -> dict | None:
    """The brightest key light of a lighting document (a light that names its ``source`` and carries its source's
    68 % energy range, ``energy_68``) and how that range stands to the energy it was given: {"index" (in
    doc["lights"]), "source", "elevation_deg", "low", "high"}, low and high the range's ends over its
    ``intensity`` (a clear-sky sun kept below its sky fit, so that a hazy sky does not get a blinding one, has
    low > 1). None where no light carries a range."""
    lights = doc.get("lights", [])
    keys = [i for i, light in enumerate(lights) if light.get("source") and len(light.get("energy_68") or ()) == 2
            and float(light.get("intensity", 0.0)) > 0]
    if not keys:
        return None
    best = max(keys, key=lambda i: float(lights[i]["intensity"]))
    light = lights[best]
    energy = float(light["intensity"])
    d = np.asarray(light["direction"], dtype=np.float64)
    elevation = sh.elevation_deg(d)
    return {"index": best, "source": str(light["source"]), "elevation_deg": elevation,
            "low": float(light["energy_68"][0]) / energy, "high": float(light["energy_68"][1]) / energy}


KEPT_BELOW = 1.25  # a key light whose 68 % range starts this far above its strength was kept below its evidence
CHECKED_SUN_ELEVATION_DEG = 10.0  # under this the clear-sky energy is unreliable: from 10 degrees up the real suns'
# fits land within 1.2-2x (training.keylight.sun_elevation, docs/keylight.md); the one real sun lower, 3 degrees up,
# came out LOW_SUN_OVERSHOOT too strong, and the public set's hazy sunset 50x
LOW_SUN_OVERSHOOT = 12  # that 3-degree sun's fit over its truth (pmndrs_sunset_piazza at ev -2, the gate passed)


def _factor(x: float) -> str:
    """A 68 % range's end as a factor, to one decimal from 1 up and to two significant digits under it: a range
    that starts at 0.04x is never printed as 0.0x."""
    return f"{x:.1f}" if x >= 1.0 else f"{x:.2g}"


def key_light_note(doc: dict, light: str = "light",
                   raise_with: str = "--sun-strength (Blender: Sun lamp strength; or its intensity in lighting.json)",
                   as_is: str = "--restore none", place_with: str = "--sun {az},{el}") -> str:
    """What an artist should know about the key light from lighting.json, in one line: a sun placed from the photo's
    capture metadata (GPS, time, heading); a sun the photo does not show that was placed from its clear sky (where,
    and how sure); a sun only the sky's gradient suggests, not placed by default (where, how sure, and
    ``place_with``: what places it, "{az}" and "{el}" its degrees); where no key light (sun or lamp) was weighed at
    all, why the sky search placed no sun either (``sun_search.refused``), and whether any explicit light is left
    to cast a shadow; a key light given less than its own evidence says (a clear-sky sun capped so that a hazy sky
    does not get a blinding one: its 68 % range over the strength it was given, from KEPT_BELOW up, and what raises
    it: ``raise_with``); an HDR file's clipped source restored (``restoration_note``; ``as_is`` takes the file as it
    is); "" otherwise. ``light``: what the reader's tool calls a light (Blender: "lamp")."""
    pointed = (doc.get("estimator") or {}).get("pointed_sun") or {}
    if pointed.get("from", "the artist") != "the artist":
        return (f"the sun was placed from {pointed['from']}: check its {light} against the photo's shadows (a camera's "
                f"compass heading is seldom better than 5-10 deg; --sun AZ,EL sets it by hand)")
    search = (doc.get("estimator") or {}).get("sun_search") or {}
    if search.get("hidden_sun"):
        return (f"the photo shows no sun, so one was placed where its clear sky puts it ({search['elevation_deg']:.0f} "
                f"deg up, within {search['direction_68_deg']:.0f} deg for 68 %): check its {light} against the photo's "
                f"shadows")
    lights = doc.get("lights", [])
    keys = [one for one in lights if one.get("source")]  # key lights name their source
    if search.get("direction") and SKY_ALONE in (search.get("refused") or ()):
        return _sky_suggests(search, light, place_with)
    if search.get("searched") and not keys and search.get("refused"):
        why = "; ".join(search["refused"])
        cast = (f"the {len(lights)} explicit light(s) are the brightest spots of the recovered map" if lights else
                "nothing will cast a hard shadow")
        where = ""
        if search.get("direction") and all(r.startswith(AT_THE_HORIZON) for r in search["refused"]):
            # the sky passed every other test: its sun's position holds, only a sun that low is not weighed
            x, y, z = search["direction"]
            where = (f" toward ({x:.2f}, {y:.2f}, {z:.2f}), where the sky puts it ({search['elevation_deg']:.0f} deg "
                     f"up, within {search['direction_68_deg']:.0f} deg for 68 %)")
        return (f"no sun or lamp was weighed as a key light, and no sun was placed from the sky ({why}): {cast}. If "
                f"the photo shows a sun, add a sun {light} by hand{where}")
    key = key_light_range(doc)
    if key is not None and key["low"] >= KEPT_BELOW:
        scaled = float(doc.get("sun_strength", 1.0))  # an artist's --sun-strength, already applied
        strength = "the strength" if scaled == 1.0 else f"{scaled:g}x the strength"
        low_sun = key["source"].startswith("clear-sky") and key["elevation_deg"] < CHECKED_SUN_ELEVATION_DEG
        caveat = (f"; under {CHECKED_SUN_ELEVATION_DEG:g} deg the sky fit is unreliable: haze near the horizon made "
                  f"the one real sun that low it was checked on (3 deg up) {LOW_SUN_OVERSHOOT}x too strong" if low_sun
                  else "")
        return (f"the key light ({key['elevation_deg']:.0f} deg up) has {strength} the estimate is sure of; its "
                f"own evidence ({key['source']}) puts it at {_factor(key['low'])}-{_factor(key['high'])}x that (68 %"
                f"{caveat}). If the photo's shadows are harder than a render's, raise {raise_with} toward that (a "
                f"sun strength of {scaled * key['low']:.1f} reaches its low end)")
    return restoration_note(doc, key, light, raise_with, as_is)


def _sky_suggests(search: dict, light: str, place_with: str) -> str:
    """The note of a sun the sky's gradient alone suggests (``keylight.find.SKY_ALONE``): where, how sure, why it was
    not placed, and the command that places it."""
    d = np.asarray(search["direction"], dtype=np.float64)
    az, el = math.degrees(math.atan2(-d[1], d[0])), sh.elevation_deg(d)
    command = place_with.format(az=f"{az:.0f}", el=f"{el:.0f}")
    return (f"the photo shows no sun; its sky's gradient suggests one {el:.0f} deg up, {az:.0f} deg from the "
            f"panorama's centre (within {search['direction_68_deg']:.0f} deg for 68 %), but a hazy sky suggests suns "
            f"that are not there, so none was added. If the photo's shadows show a sun, {command} places a sun {light} "
            f"there")


def restoration_note(doc: dict, key: dict | None, light: str, raise_with: str, as_is: str) -> str:
    """The note of an HDR file, bracket set or RAW whose clipped source was restored (``estimator.restoration``):
    its plateau, the light it became and how sure its strength is (``key``: ``key_light_range``'s), what sets it,
    and ``as_is``; "" where nothing was restored."""
    restoration = (doc.get("estimator") or {}).get("restoration") or {}
    if not restoration.get("restored"):
        return "" if restoration else _set_too_bright(doc)  # a ceiling found but not restored: --restore none
    clips = {"hdr-merged-brackets": "the bracket set clips its source in every frame",
             "raw-linear": "the sensor clips its source"}.get((doc.get("source") or {}).get("dynamic_range"),
                                                              "the file clips its own source")
    found = (f"{clips} ({restoration.get('plateau_pixels', 0)} pixel(s) at its ceiling, "
             f"{max(restoration.get('ceiling') or [0.0]):.3g})")
    if key is None:
        return (f"{found}: its energy was restored into the map, with no key light; a patch that is no compact sun "
                f"or lamp gains little from it and can come out too bright ({as_is} takes the file as it is)")
    kind = str(doc["lights"][key["index"]].get("type", "")).strip()
    became = f"{kind} {light}" if kind else light
    return (f"{found}: restored as a {became} {key['elevation_deg']:.0f} deg up, its "
            f"strength sure within {_factor(key['low'])}-{_factor(key['high'])}x (68 %). If the scene's own shadows are "
            f"harder or softer than a render's, set {raise_with}; {as_is} takes the file as it is"
            f"{_what_would_hold_it(doc, doc['lights'][key['index']], restoration)}")


SET_CLIPPED_SHARE = 0.001  # a set that clips a thousandth of its pixels in every frame lost a source's energy


def _set_too_bright(doc: dict) -> str:
    """The note of a bracket set that clips in every frame but whose darkest frame is too bright for its ceiling to
    be weighed as a clipped source (no restoration, no key light: its brightest frame is the ev-0 one, say): what it
    lost, and what places a light. Restoring such a set made six scenes of 46 far worse than one JPEG (0, +2 pair;
    docs/studies/captures.md): it is not done by default. "" for anything else."""
    brackets = (doc.get("source") or {}).get("brackets") or {}
    share, stops = brackets.get("clipped_in_every_frame"), brackets.get("stops")
    if not stops or not isinstance(share, (int, float)) or share < SET_CLIPPED_SHARE or doc.get("lights"):
        return ""
    return (f"the bracket set clips {100 * share:.2g} % of its pixels in every frame, its darkest ({min(stops):+g} "
            f"stops) too, and too little above the scene to weigh them as a clipped sun or lamp: no light was made "
            f"from them. A darker frame (-2 or -4 stops) holds the source; --sun AZ,EL (Blender: Sun is here) "
            f"places a sun by hand")


def _what_would_hold_it(doc: dict, light: dict, restoration: dict) -> str:
    """For a bracket set whose source clips even its darkest frame: how many more stops (or an ND filter) would
    hold it, from the restored light's radiance (its intensity x its colour's largest channel over its disk's solid
    angle) over the set's ceiling; "" for any other capture, or where the light's size is not known."""
    brackets = (doc.get("source") or {}).get("brackets") or {}
    ceiling, angle = max(restoration.get("ceiling") or [0.0]), float(light.get("angle") or 0.0)
    if not brackets.get("stops") or not ceiling > 0 or not 0 < angle < math.pi:
        return ""
    solid_angle = 2.0 * math.pi * (1.0 - math.cos(angle / 2.0))
    radiance = float(light.get("intensity", 0.0)) * max(light.get("color") or [1.0]) / solid_angle
    stops = math.log2(radiance / ceiling) if radiance > ceiling else 0.0
    if stops < 1.0:
        return ""
    return (f". The source clips even the darkest frame ({min(brackets['stops']):+g} stops): about {stops:.0f} more "
            f"stops, or an ND filter, would hold it")
