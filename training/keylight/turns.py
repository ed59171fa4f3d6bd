"""Does a photo keep its key light when it is turned? The same 360 photo turned about its vertical (its columns
rolled, as another camera's "north" would) is the same scene, so it should get the same key light, turned with it.
Work cells are whole groups of pixels, so a turn that is no whole number of cells regroups the clipped pixels; a
threshold on what a region holds (``keylight.KEY_SHARE``) can then let a sun come and go.

For each photo (default: every JPEG in ../shared/data/ldr) and each turn (pixels; default a spread of 0-1500, most
of them no whole number of work cells), the default estimate's brightest key light (a light that names its
``source``), its direction turned back, and whether it is the unturned photo's: within ``--degrees`` and a factor
``--factor`` in intensity, or no key light in both.

    python -m training.keylight.turns [--photos a.jpg ...] [--turns 0 37 111 ...] [--out docs/keylight_turns.md]
"""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
LDR = ROOT.parent / "shared" / "data" / "ldr"
TURNS = (0, 37, 111, 333, 517, 701, 913, 1229, 1500)


def turned_back(direction, shift: int, width: int) -> np.ndarray:
    """A direction found in a panorama whose columns were rolled by ``shift`` pixels (``np.roll`` along the width),
    in the unrolled panorama's frame: rolling moves every azimuth by -2 pi shift / width (CONVENTIONS.md's u)."""
    phi = 2.0 * math.pi * shift / width
    d = np.asarray(direction, dtype=np.float64)
    return np.array([math.cos(phi) * d[0] - math.sin(phi) * d[1], math.sin(phi) * d[0] + math.cos(phi) * d[1], d[2]])


def key_light(pixels: np.ndarray, estimator: str = "auto") -> dict | None:
    """The brightest key light (``lighting.lights.key_light_range``) of the default estimate of ``pixels`` (uint8
    (H, W, 3)), or None."""
    from panolight_core.lighting.lights import key_light_range
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
        row = {"turn": int(shift), "key": None}
        if light is not None:
            row["key"] = {"direction": turned_back(light["direction"], int(shift) % width, width).round(4).tolist(),
                          "intensity": float(light["intensity"]), "source": light["source"]}
        rows.append(row)
    first = rows[0]["key"]
    for row in rows:
        k = row["key"]
        if first is None or k is None:
            row["same"] = first is None and k is None
        else:
            apart = math.degrees(math.acos(float(np.clip(np.dot(first["direction"], k["direction"]), -1.0, 1.0))))
            row["same"] = apart <= degrees and abs(math.log(k["intensity"] / first["intensity"])) <= math.log(factor)
    return rows


def table(results: dict) -> list[str]:
    lines = ["| photo | key light, unturned | the same light at | a key light at |", "|---|---|---:|---:|"]
    for name, rows in results.items():
        k = rows[0]["key"]
        what = "none" if k is None else f"{k['source'].split(' (')[0]}, {k['intensity']:.3g}"
        lines.append(f"| {name} | {what} | {sum(r['same'] for r in rows[1:])} of {len(rows) - 1} turns | "
                     f"{sum(r['key'] is not None for r in rows)} of {len(rows)} |")
    return lines


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m training.keylight.turns", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--photos", nargs="*", default=None, help="JPEGs (default: every one in ../shared/data/ldr)")
    ap.add_argument("--turns", nargs="+", type=int, default=list(TURNS),
                    help="column shifts in pixels, the first the reference (default: %(default)s)")
    ap.add_argument("--degrees", type=float, default=3.0, help="the same light: this close (default 3)")
    ap.add_argument("--factor", type=float, default=1.5, help="... and within this factor (default 1.5)")
    ap.add_argument("--out", type=Path, default=None, help="write the table (markdown) here")
    args = ap.parse_args(argv)
    from panolight_core.io import read_image

    photos = [Path(p) for p in args.photos] if args.photos else sorted(LDR.glob("*.jpg"))
    if not photos:
        print(f"turns: no photos (looked in {LDR})", file=sys.stderr)
        return 1
    results = {}
    for p in photos:
        results[p.name] = turns_of(read_image(p, ldr_as_uint8=True), args.turns, args.degrees, args.factor)
        print(table({p.name: results[p.name]})[-1], flush=True)
    lines = table(results)
    print("\n".join(lines))
    if args.out:
        head = ["# The key light of a turned photo", "",
                f"`python -m training.keylight.turns --out {args.out}`: each photo turned about its vertical by "
                f"{', '.join(str(t) for t in args.turns[1:])} pixels; the same light: within {args.degrees:g} degrees "
                f"and {args.factor:g}x of the unturned photo's brightest key light (or none in both).", ""]
        args.out.write_text("\n".join(head + lines) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
