"""Does a photo keep its key light when it is turned, re-encoded or downsized? The same 360 photo turned about its
vertical (its columns rolled, as another camera's "north" would), saved again as a JPEG, or made smaller (what a web
page, a chat or a CMS does to a photo before a user gets it) is the same scene, so it should get the same key light.
Work cells are whole groups of pixels, so a turn that is no whole number of cells regroups the clipped pixels; a
threshold on what a region holds (``keylight.PARAMS.key_share``) can then let a sun come and go. A JPEG saved again pulls
some channel of a barely clipped sun below 254, and a region is made of pixels white in every channel.

For each photo (default: every JPEG in ../shared/data/ldr) and each turn (pixels; default a spread of 0-1500, most
of them no whole number of work cells), the default estimate's brightest key light (a light that names its
``source``), its direction turned back, and whether it is the unturned photo's: within ``--degrees`` and a factor
``--factor`` in intensity, or no key light in both. Then the same for copies of each photo: saved again at JPEG
quality 90 at its own size, and downsized (Lanczos) to ``--widths`` and saved at quality 90.

    python -m training.keylight.turns [--photos a.jpg ...] [--turns 0 37 111 ...] [--widths 2048 1024]
                                      [--out docs/keylight_turns.md]
"""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

from panolight_core import metrics

ROOT = Path(__file__).resolve().parents[2]
LDR = ROOT.parent / "shared" / "data" / "ldr"
TURNS = (0, 37, 111, 333, 517, 701, 913, 1229, 1500)
WIDTHS = (2048, 1024)
QUALITY = 90


def turned_back(direction, shift: int, width: int) -> np.ndarray:
    """A direction found in a panorama whose columns were rolled by ``shift`` pixels (``np.roll`` along the width),
    in the unrolled panorama's frame: rolling moves every azimuth by -2 pi shift / width (CONVENTIONS.md's u)."""
    phi = 2.0 * math.pi * shift / width
    d = np.asarray(direction, dtype=np.float64)
    return np.array([math.cos(phi) * d[0] - math.sin(phi) * d[1], math.sin(phi) * d[0] + math.cos(phi) * d[1], d[2]])


def key_light(pixels: np.ndarray, estimator: str = "auto") -> dict | None:
    """The brightest key light (``keylight.key_light_range``) of the default estimate of ``pixels`` (uint8
    (H, W, 3)), or None."""
    from panolight_core.estimators.keylight import key_light_range
    from panolight_core.pipeline.estimate import estimate_lighting
    from panolight_core.pipeline.settings import Settings

    doc = estimate_lighting(pixels, Settings(estimator=estimator)).document
    key = key_light_range(doc)
    return None if key is None else doc["lights"][key["index"]]


def turns_of(pixels: np.ndarray, turns=TURNS, degrees: float = 3.0, factor: float = 1.5) -> list[dict]:
    """Per turn (pixels): the key light found (direction turned back into the unturned frame, intensity, source)
    and whether it is the unturned photo's (the first turn's): within ``degrees`` and ``factor``, or none in both."""
    width = pixels.shape[1]
    rows = []
    for shift in turns:
        light = key_light(np.roll(pixels, int(shift) % width, axis=1))
        rows.append({"turn": int(shift), "key": key_row(light, int(shift) % width, width)})
    return mark_same(rows, degrees, factor)


def copies_of(pixels: np.ndarray, widths=WIDTHS, quality: int = QUALITY, degrees: float = 3.0, factor: float = 1.5
              ) -> list[dict]:
    """The photo as it is, then saved again as a JPEG of ``quality`` at its own size and downsized (Lanczos) to each
    of ``widths`` narrower than it: per copy the key light found and whether it is the photo's (``turns_of``'s
    test). The directions need no turning back: a copy keeps the photo's frame."""
    rows = [{"copy": label, "key": key_row(key_light(px), 0, px.shape[1])}
            for label, px in copies(pixels, widths, quality)]
    return mark_same(rows, degrees, factor)


def copies(pixels: np.ndarray, widths=WIDTHS, quality: int = QUALITY) -> list[tuple[str, np.ndarray]]:
    """(label, uint8 (h, 2h, 3)) of a photo as it is, saved again as a JPEG of ``quality`` at its own size, and
    downsized (Lanczos) to each of ``widths`` narrower than it, then saved at ``quality``."""
    from panolight_core.camera import jpeg_roundtrip, lanczos_resize

    out = [("as it is", pixels), (f"JPEG q{quality}", jpeg_roundtrip(pixels, quality))]
    for w in widths:
        if w < pixels.shape[1]:
            out.append((f"{w} wide, q{quality}", jpeg_roundtrip(lanczos_resize(pixels, w, w // 2), quality)))
    return out


def key_row(light: dict | None, shift: int, width: int) -> dict | None:
    """A study's record of a lighting-file key light found in a panorama rolled by ``shift`` of ``width`` pixels:
    its direction turned back into the unrolled frame, intensity and source; None for no light."""
    if light is None:
        return None
    return {"direction": turned_back(light["direction"], shift, width).round(4).tolist(),
            "intensity": float(light["intensity"]), "source": light["source"]}


def mark_same(rows: list[dict], degrees: float, factor: float) -> list[dict]:
    """Each row's "same": its key light within ``degrees`` and ``factor`` of the first row's, or none in both."""
    first = rows[0]["key"]
    for row in rows:
        k = row["key"]
        if first is None or k is None:
            row["same"] = first is None and k is None
        else:
            row["same"] = (metrics.angle_deg(first["direction"], k["direction"]) <= degrees
                           and abs(math.log(k["intensity"] / first["intensity"])) <= math.log(factor))
    return rows


def table(results: dict) -> list[str]:
    lines = ["| photo | key light, unturned | the same light at | a key light at |", "|---|---|---:|---:|"]
    for name, rows in results.items():
        lines.append(f"| {name} | {_what(rows[0]['key'])} | {sum(r['same'] for r in rows[1:])} of {len(rows) - 1} turns | "
                     f"{sum(r['key'] is not None for r in rows)} of {len(rows)} |")
    return lines


def copies_table(results: dict) -> list[str]:
    labels = [r["copy"] for r in max(results.values(), key=len)]
    lines = ["| photo | " + " | ".join(labels) + " |", "|---|" + "---|" * len(labels)]
    for name, rows in results.items():
        got = {r["copy"]: _what(r["key"]) + ("" if r["same"] or r is rows[0] else " (another)") for r in rows}
        lines.append(f"| {name} | " + " | ".join(got.get(label, "(not smaller than the photo)") for label in labels) + " |")
    return lines


def _what(k: dict | None) -> str:
    return "none" if k is None else f"{k['source'].split(' (')[0]}, {k['intensity']:.3g}"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m training.keylight.turns", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--photos", nargs="*", default=None, help="JPEGs (default: every one in ../shared/data/ldr)")
    ap.add_argument("--turns", nargs="+", type=int, default=list(TURNS),
                    help="column shifts in pixels, the first the reference (default: %(default)s)")
    ap.add_argument("--degrees", type=float, default=3.0, help="the same light: this close (default 3)")
    ap.add_argument("--factor", type=float, default=1.5, help="... and within this factor (default 1.5)")
    ap.add_argument("--widths", nargs="*", type=int, default=list(WIDTHS),
                    help="copies of each photo: saved again at JPEG quality 90, and downsized to these widths "
                         "(default: %(default)s; give none for the re-encoded copy alone)")
    ap.add_argument("--out", type=Path, default=None, help="write the table (markdown) here")
    args = ap.parse_args(argv)
    from panolight_core.io import read_image

    photos = [Path(p) for p in args.photos] if args.photos else sorted(LDR.glob("*.jpg"))
    if not photos:
        print(f"turns: no photos (looked in {LDR})", file=sys.stderr)
        return 1
    results, copies = {}, {}
    for p in photos:
        pixels = read_image(p, ldr_as_uint8=True)
        results[p.name] = turns_of(pixels, args.turns, args.degrees, args.factor)
        print(table({p.name: results[p.name]})[-1], flush=True)
        if args.widths is not None:
            copies[p.name] = copies_of(pixels, args.widths, QUALITY, args.degrees, args.factor)
            print(copies_table({p.name: copies[p.name]})[-1], flush=True)
    lines = table(results)
    if copies:
        lines += ["", f"The same photo saved again (JPEG quality {QUALITY}, at its own size) and downsized (Lanczos, then "
                  f"quality {QUALITY}): its brightest key light, \"(another)\" where it is not the photo's (more than "
                  f"{args.degrees:g} degrees or {args.factor:g}x apart, or a light where the photo has none).", ""]
        lines += copies_table(copies)
    print("\n".join(lines))
    if args.out:
        head = ["# The key light of a turned, re-encoded or downsized photo", "",
                f"`python -m training.keylight.turns --out {args.out}`: each photo turned about its vertical by "
                f"{', '.join(str(t) for t in args.turns[1:])} pixels; the same light: within {args.degrees:g} degrees "
                f"and {args.factor:g}x of the unturned photo's brightest key light (or none in both).", ""]
        args.out.write_text("\n".join(head + lines) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
