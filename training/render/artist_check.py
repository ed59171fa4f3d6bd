"""The artist's check on real 360 photos (issue 22): a white sphere on a white ground, composited into
the photo under the estimated lighting, beside the photo, with the numbers an artist looks at.

For each photo (default: every JPEG in ../shared/data/ldr; never trained or tuned on) and estimator:
- the product's estimate (``pipeline.estimate_lighting``, the CLI's path) of the photo;
- a Mitsuba render (``training.render.mitsuba.composite_view``: differential rendering) of a diffuse white sphere
  (albedo 0.8) standing on the photo's ground, seen from the panorama's centre with the key light to the
  side, so its shadow falls across the view;
- the lit/shadow ratio a white plane gets: the model's irradiance on an upward plane over the same with
  its explicit lights blocked (the sphere's umbra), and the same ratio read off the render (the darkest
  1 % of the ground's A/B ratio), against the photo's own sunlit/shadowed ground where it shows one
  (``PHOTO_GROUND``: two patches picked by eye, one sunlit and one in a cast shadow, on the same material,
  linearised at full resolution through sRGB as the estimate linearises the photo; only building.jpg shows a
  clean one: its far sidewalk in the sun and in the wide shadow band beside it);
- EVALUATION.md's shadow contrast C of a surface facing the key light (``metrics.model_shadow_contrast``);
- the key light's direction against the visible sun (``SUNS``, ../shared/data/ldr/README.md), and its
  colour (the tunnel's sodium lamps must come out orange);
- what the product tells the artist of the key light (``keylight.key_light_note``) and, for a key light
  kept below its own evidence, the same render estimated again with ``--sun-strength`` at the low end of its 68 %
  range, as the note advises (Blender: Sun lamp strength); for a sun only the sky suggests (not placed by
  default), the render with the ``--sun AZ,EL`` the note gives.
Writes OUT/<photo>.png (photo | composite per estimator) and OUT/artist_check.md (the table).

    python -m training.render.artist_check [--photos a.jpg ...] [--estimators sources auto] [--spp 64] --out docs/artist_check
"""
from __future__ import annotations

import argparse
import math
import re
import sys
import time
from pathlib import Path

import numpy as np

from panolight_core import metrics
from panolight_core.camera.color import LUMINANCE_WEIGHTS
from panolight_core.estimators.keylight import key_light_note, key_light_range
from panolight_core.estimators.keylight.notes import KEPT_BELOW

ROOT = Path(__file__).resolve().parents[2]
LDR = ROOT.parent / "shared" / "data" / "ldr"
SUNS = {"field_lowsun.jpg": (0.732, 0.678, 0.072)}  # the README's visible (veiled) sun, CONVENTIONS.md frame
# (row0, row1, col0, col1) as fractions of the photo: a sunlit and a shadowed patch of one ground material.
# building.jpg: the far sidewalk (paving) in the sun and in the wide shadow band beside it (each patch's luminance
# varies 4-11 % about its mean); the camera itself stands in the shade, so this is the sun where it reaches, not
# what an object at the camera gets. The other photos show no cast shadow on one flat material: grass and rock facing
# every way, leaves against a sandy path, water.
PHOTO_GROUND: dict[str, tuple[tuple[float, float, float, float], tuple[float, float, float, float]]] = {
    "building.jpg": ((0.628, 0.636, 0.338, 0.348), (0.641, 0.652, 0.321, 0.329)),
}
SPHERE_RADIUS = 0.45
SPHERE_ALBEDO = 0.8


def key_direction(model) -> tuple[np.ndarray, str]:
    """The brightest explicit light's direction, else the SH's dominant direction (band 1 luminance)."""
    lights = [light for light in model.lights if light["type"] in ("sun", "area")]
    if lights:
        best = max(lights, key=lambda light: light["intensity"])
        return np.asarray(best["direction"], dtype=np.float64), best["type"]
    band1 = np.asarray(model.coeffs[1:4], dtype=np.float64) @ LUMINANCE_WEIGHTS  # (y, z, x) order
    d = np.array([band1[2], band1[0], band1[1]])
    return d / max(np.linalg.norm(d), 1e-12), "SH"


def plane_ratio(model) -> tuple[float, float, float]:
    """(lit, shadowed, lit / shadowed) irradiance of an upward plane: the model's whole irradiance, and
    the same with every explicit light above the horizon blocked (the umbra of an object)."""
    from panolight_core.lighting.lights import light_irradiance

    up = np.array([[0.0, 0.0, 1.0]])
    lit = float(np.mean(model.irradiance(up)))
    direct = float(np.mean(light_irradiance([light for light in model.lights if light["direction"][2] > 0], up)))
    shadow = max(lit - direct, 1e-12)
    return lit, shadow, lit / shadow


def photo_ratio(name: str, px: np.ndarray) -> float | None:
    """The photo's own lit/shadow ratio: mean linear luminance of its sunlit ground patch over its shadowed one
    (``PHOTO_GROUND[name]``), read from the full-resolution 8-bit photo ``px`` (H, W, 3) through
    ``camera.ldr_to_linear``; None for a photo without picked patches."""
    from panolight_core.camera import ldr_to_linear

    boxes = PHOTO_GROUND.get(name)
    if boxes is None:
        return None
    h, w = px.shape[:2]

    def mean(box):
        r0, r1, c0, c1 = box
        patch = px[int(r0 * h):max(int(r1 * h), int(r0 * h) + 1), int(c0 * w):max(int(c1 * w), int(c0 * w) + 1)]
        return float(np.mean(ldr_to_linear(patch) @ LUMINANCE_WEIGHTS))

    return mean(boxes[0]) / max(mean(boxes[1]), 1e-12)


def sphere_shape(yaw_deg: float) -> dict:
    from training.render.mitsuba import DISTANCE, EYE_HEIGHT, view_basis

    fwd, _, _ = view_basis(yaw_deg, 0.0)
    centre = DISTANCE * fwd + np.array([0.0, 0.0, -EYE_HEIGHT + SPHERE_RADIUS])
    return {"sphere": {"type": "sphere", "center": centre.tolist(), "radius": SPHERE_RADIUS,
                       "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": [SPHERE_ALBEDO] * 3}}}}


def check(photo: Path, estimators, spp: int, size=(320, 240), fov: float = 70.0, log=print) -> dict:
    """The renders and numbers of one photo, per estimator (see the module's docstring)."""
    from panolight_core.camera import ldr_to_linear
    from panolight_core.camera.resample import area_downsample, sample_equirect
    from panolight_core.io import read_image
    from panolight_core.pipeline.estimate import estimate_lighting
    from panolight_core.pipeline.settings import Settings, direction_from_az_el
    from training.render.mitsuba import composite_view, perspective_rays, scene_emitters

    px = read_image(photo, ldr_as_uint8=True)
    linear = ldr_to_linear(area_downsample(px, min(512, px.shape[0])).round().astype(np.uint8))
    rows = {"photo": photo.name, "photo_ratio": photo_ratio(photo.name, px), "estimates": []}
    runs = []
    for name in estimators:
        res = estimate_lighting(px, Settings(estimator=name))
        runs.append((name, res.model, key_light_note(res.document)))
        key = key_light_range(res.document)
        if key is not None and key["low"] >= KEPT_BELOW:
            # what the artist gets by raising --sun-strength (Blender: Sun lamp strength) to the low end of the
            # key light's 68 % range, as the note advises
            strength = round(key["low"], 1)
            raised = estimate_lighting(px, Settings(estimator=name, sun_strength=strength))
            runs.append((f"{name}, --sun-strength {strength:g}", raised.model, ""))
        said = re.search(r"(--sun (-?\d+),(-?\d+)) places", key_light_note(res.document))
        if said:  # a sun only the sky suggests: what the artist gets by placing it as the note says
            pointed = direction_from_az_el(float(said.group(2)), float(said.group(3)))
            placed = estimate_lighting(px, Settings(estimator=name, sun_direction=pointed))
            runs.append((f"{name}, {said.group(1)}", placed.model, ""))
    for name, model, note in runs:
        t = time.perf_counter()
        d, kind = key_direction(model)
        yaw = math.degrees(math.atan2(d[1], d[0])) + 90.0  # the key light from the right: the shadow crosses the view
        pitch = -25.0
        bg = sample_equirect(linear, perspective_rays(*size, fov, yaw, pitch))
        comp = composite_view(scene_emitters(model.coeffs, model.lights), sphere_shape(yaw), bg,
                              (*size, fov, yaw, pitch), spp)
        ground = (comp["ground_mask"] > 0.99) & (comp["mask"] < 0.01)
        lum = comp["ratio"] @ LUMINANCE_WEIGHTS
        rendered = 1.0 / max(float(np.percentile(lum[ground], 1)), 1e-6) if ground.any() else float("nan")
        lit, shadow, ratio = plane_ratio(model)
        keys = [light for light in model.lights if light["type"] in ("sun", "area")]
        colour = np.asarray(max(keys, key=lambda light: light["intensity"])["color"]) if keys else None
        sun = SUNS.get(photo.name)
        err = math.degrees(math.acos(np.clip(d @ (np.asarray(sun) / np.linalg.norm(sun)), -1, 1))) if sun else None
        rows["estimates"].append({"estimator": name, "note": note, "key": kind, "direction": d.round(3).tolist(),
                                  "sun_error_deg": err,
                                  "lights": len(model.lights), "colour": None if colour is None else colour.round(3).tolist(),
                                  "plane_ratio": ratio, "rendered_ratio": rendered, "composite": comp["composite"],
                                  "facing_contrast": metrics.model_shadow_contrast(model, d),
                                  "background": bg, "seconds": time.perf_counter() - t})
        log(f"{photo.name} {name}: key {kind} {d.round(3)}, lit/shadow {ratio:.2f} (render {rendered:.2f}), "
            f"facing the key {rows['estimates'][-1]['facing_contrast']:.2f}, "
            f"{time.perf_counter() - t:.0f} s")
    rows["thumbnail"] = linear
    return rows


def write(results, out: Path) -> Path:
    """OUT/<photo>.png per photo and OUT/artist_check.md (the table, then the pictures)."""
    from PIL import Image, ImageDraw

    from panolight_core.io import write_srgb8
    from panolight_core.pipeline.preview import tonemap

    out.mkdir(parents=True, exist_ok=True)
    lines = ["# The artist's check: a white sphere composited into real 360 photos", "",
             "Made by `python -m training.render.artist_check --out docs/artist_check` (../shared/data/ldr: real photos, "
             "no HDR truth, never trained or tuned on). Each picture: the photo, then per estimator a diffuse white "
             "sphere (albedo 0.8) rendered by Mitsuba under the estimate and composited into the photo's ground "
             "(differential rendering), the key light to the right. *lit/shadow*: an upward white plane's "
             "irradiance over the same in the sphere's umbra, from the model (and read off the render); an object "
             "casts a visible shadow when it is well above 1. *the photo's own ground*: the same ratio read off the photo, "
             "a sunlit patch of its ground over a patch of the same material in a cast shadow (through sRGB), where "
             "the photo shows one: what the sun gives where it reaches, which an object at the camera matches only "
             "when the camera stands in the sun. *facing the key*: EVALUATION.md's shadow contrast C, lit over shadow of "
             "a surface facing the key light (1: no shadow).", "",
             "| photo | estimator | key light | lights | colour of the key | lit/shadow (model) | lit/shadow (render) "
             "| facing the key | sun error |", "|---|---|---|---|---|---|---|---|---|"]
    pictures = []
    for r in results:
        # the photo's own exposure (its linear values as they are), so the composite looks as the photo does
        tiles = [("photo", tonemap(r["estimates"][0]["background"], 1.0))]
        for e in r["estimates"]:
            tiles.append((e["estimator"], tonemap(e["composite"], 1.0)))
            err = "" if e["sun_error_deg"] is None else f"{e['sun_error_deg']:.1f}°"
            lines.append(f"| {r['photo']} | `{e['estimator']}` | {e['key']} {tuple(e['direction'])} | {e['lights']} | "
                         f"{'' if e['colour'] is None else tuple(e['colour'])} | {e['plane_ratio']:.2f} | "
                         f"{e['rendered_ratio']:.2f} | {e['facing_contrast']:.2f} | {err} |")
        if r["photo_ratio"] is not None:
            lines.append(f"| {r['photo']} | the photo's own ground | | | | {r['photo_ratio']:.2f} | | | |")
        panels = []
        for label, img in tiles:
            tile = Image.fromarray(img)
            draw = ImageDraw.Draw(tile)
            draw.rectangle((0, 0, 8 + 6 * len(label), 14), fill=(0, 0, 0))
            draw.text((3, 1), label, fill=(255, 255, 255))
            panels += [np.asarray(tile), np.full((img.shape[0], 4, 3), 255, np.uint8)]
        picture = out / f"{Path(r['photo']).stem}.png"
        write_srgb8(picture, np.concatenate(panels[:-1], axis=1))
        pictures += ["", f"**{r['photo']}**", "", f"![{r['photo']}]({picture.name})"]
    notes = [f"- **{r['photo']}**, `{e['estimator']}`: {e['note']}"
             for r in results for e in r["estimates"] if e["note"]]
    if notes:
        lines += ["", "What `panolight estimate` and the Blender status bar tell the artist "
                  "(`keylight.key_light_note`; a key light kept below its evidence is also rendered at the low "
                  "end of its 68 % range with `--sun-strength`, and a sun only the sky suggests with the `--sun` "
                  "that places it, as the note advises):", ""] + notes
    lines += pictures
    report = out / "artist_check.md"
    report.write_text("\n".join(lines).rstrip() + "\n", encoding="utf-8")
    return report


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--photos", nargs="*", default=None, help="JPEGs (default: every one in ../shared/data/ldr)")
    ap.add_argument("--estimators", nargs="+", default=["sources", "auto"])
    ap.add_argument("--spp", type=int, default=64, help="samples per pixel of each Mitsuba pass (default 64)")
    ap.add_argument("--out", required=True, help="folder for the pictures and artist_check.md")
    args = ap.parse_args(argv)
    photos = [Path(p) for p in args.photos] if args.photos else sorted(LDR.glob("*.jpg"))
    if not photos:
        print(f"artist_check: no photos (looked in {LDR})", file=sys.stderr)
        return 1
    results = [check(p, args.estimators, args.spp) for p in photos]
    print(write(results, Path(args.out)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
