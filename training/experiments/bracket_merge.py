"""Two rules of the bracket merge and the evidence for them (docs/studies/captures.md), each measured against the rule
it replaced over the real HDRs of ../shared/data/hdri:

- ``ring``: a JPEG's ringing round a clipped edge counts as clipped (``camera.blend.clipped_or_ringing``). Each
  scene's camera JPEGs (q90) at -2, 0, +2 are merged with the rule and without it (only codes from CLIPPED_CODE up
  clipped); a dark-ring pixel is one whose truth is over the set's ceiling but that merged under half of it.
- ``curve``: the camera's own curve wherever it leaves ``camera.response.RESPONSE_GAIN`` of sRGB's disagreement.
  The share over every scene's sRGB sets ({-2, 0, +2} and {-4 .. +4}: it must stay above the gain, or an sRGB set
  would leave sRGB), and, on every ``--step``-th scene, cameras a little off sRGB merged under the old gain (0.35)
  and the shipped one: which curve each took and its mid-tone error (the median |log| of merged over true
  luminance where the truth is 0.01-0.9 of the reference frame's white, after one scale).

- ``gain``: two gains side by side (``--gains A B``) over every scene's sRGB sets ({-2, 0, +2} and {-4 .. +4}) and
  its mild cameras at {-2, 0, +2}: which curve each set takes under each, and its mid-tone error; the sets made
  worse (error over 1.1x + 0.002) counted first.

    python -m training.experiments.bracket_merge ring [--out runs/bracket_ring.json]
    python -m training.experiments.bracket_merge curve [--step 10] [--out runs/bracket_curve.json]
    python -m training.experiments.bracket_merge gain --gains 0.7 1.0 [--step 1] [--out runs/bracket_gain.json]
"""
from __future__ import annotations

import argparse
import contextlib
import json
import sys
from pathlib import Path

import numpy as np

from panolight_core.camera import auto_exposure, blend, brackets, hdr_to_ldr, response
from panolight_core.camera.color import LUMINANCE_WEIGHTS
from panolight_core.camera.weights import CLIPPED_CODE
from training.common.real_hdri import DEFAULT_HDRI, load_hdr, scene_files

RING_EVS = (-2, 0, 2)
CURVE_SETS = ((-2, 0, 2), (-4, -2, 0, 2, 4))
OLD_GAIN = 0.35  # the gain before session 51
MILD_CAMERAS = (("contrast", 1.03), ("contrast", 1.04), ("gamma", 2.25))  # a little off sRGB


@contextlib.contextmanager
def ring_rule(on: bool):
    """Within it, the merge takes a JPEG's ringing as clipped (``on``, as shipped) or only codes from CLIPPED_CODE."""
    shipped = blend.clipped_or_ringing
    if not on:
        blend.clipped_or_ringing = lambda top: top >= CLIPPED_CODE
    try:
        yield
    finally:
        blend.clipped_or_ringing = shipped


@contextlib.contextmanager
def response_gain(gain: float):
    """Within it, the recovered curve is taken at ``gain`` (``camera.response.RESPONSE_GAIN``)."""
    shipped = response.RESPONSE_GAIN
    response.RESPONSE_GAIN = gain
    try:
        yield
    finally:
        response.RESPONSE_GAIN = shipped


def dark_ring_pixels(hdr: np.ndarray, merged: np.ndarray, ceiling: float) -> int:
    """Pixels whose truth (``hdr`` at the ev-0 exposure) is over ``ceiling`` but merged under half of it."""
    truth = hdr * auto_exposure(hdr, 0.0)
    return int(((truth.max(axis=-1) > ceiling) & (merged.max(axis=-1) < 0.5 * ceiling)).sum())


def ring_row(hdr: np.ndarray) -> dict:
    """{"without", "with"}: one scene's dark-ring pixels merged without and with the ringing rule."""
    frames = [hdr_to_ldr(hdr, ev, 90) for ev in RING_EVS]
    out = {}
    for name, on in (("without", False), ("with", True)):
        with ring_rule(on):
            merged, info = brackets.merge_brackets(frames, [2.0 ** ev for ev in RING_EVS])
        out[name] = dark_ring_pixels(hdr, merged, info["ceiling"])
    return out


def midtone_error(hdr: np.ndarray, merged: np.ndarray) -> float:
    """The median |log| of merged over true luminance where the truth is 0.01-0.9 of the reference's white, after
    the one scale that best matches them (their median ratio)."""
    truth = (hdr * auto_exposure(hdr, 0.0)) @ LUMINANCE_WEIGHTS
    seen = merged @ LUMINANCE_WEIGHTS
    ok = (truth > 0.01) & (truth < 0.9) & (seen > 0)
    ratio = seen[ok] / truth[ok]
    return float(np.median(np.abs(np.log(ratio / np.median(ratio)))))


def srgb_share(hdr: np.ndarray, evs) -> float:
    """The disagreement under the recovered curve over sRGB's, for the scene's sRGB camera JPEGs at ``evs``."""
    frames = [hdr_to_ldr(hdr, ev, 90) for ev in evs]
    found = response.recover_response(frames, [2.0 ** ev for ev in evs], len(evs) // 2).disagreement
    return found["recovered"] / found["sRGB"]


def curve_rows(hdr: np.ndarray) -> list[dict]:
    """For each mild camera, the curve taken and the mid-tone error under the old gain and the shipped one."""
    rows = []
    for curve, param in MILD_CAMERAS:
        frames = [hdr_to_ldr(hdr, ev, 90, curve=curve, curve_param=param) for ev in RING_EVS]
        row = {"camera": f"{curve} {param:g}"}
        for name, gain in (("old", OLD_GAIN), ("shipped", response.RESPONSE_GAIN)):
            with response_gain(gain):
                merged, info = brackets.merge_brackets(frames, [2.0 ** ev for ev in RING_EVS])
            row[name] = {"curve": info["response"]["curve"], "error": midtone_error(hdr, merged)}
        rows.append(row)
    return rows


WORSE = (1.1, 0.002)  # a set is made worse where its mid-tone error passes WORSE[0] x before + WORSE[1]


def gain_rows(hdr: np.ndarray, gains) -> list[dict]:
    """One scene's sets (sRGB at CURVE_SETS, the mild cameras at RING_EVS), each merged under both ``gains``."""
    sets = [(f"sRGB {evs[0]:+d}..{evs[-1]:+d}", [hdr_to_ldr(hdr, ev, 90) for ev in evs], evs) for evs in CURVE_SETS]
    sets += [(f"{curve} {param:g}", [hdr_to_ldr(hdr, ev, 90, curve=curve, curve_param=param) for ev in RING_EVS],
              RING_EVS) for curve, param in MILD_CAMERAS]
    rows = []
    for name, frames, evs in sets:
        row = {"camera": name}
        for gain in gains:
            with response_gain(gain):
                merged, info = brackets.merge_brackets(frames, [2.0 ** ev for ev in evs])
            row[f"{gain:g}"] = {"curve": info["response"]["curve"], "error": midtone_error(hdr, merged)}
        rows.append(row)
    return rows


def gain_summary(rows: dict, gains) -> dict:
    a, b = (f"{g:g}" for g in gains)
    flat = [r for rs in rows.values() for r in rs]
    moved = [r for r in flat if r[a]["curve"] != r[b]["curve"]]
    worse = [r for r in flat if r[b]["error"] > WORSE[0] * r[a]["error"] + WORSE[1]]
    better = [r for r in flat if r[a]["error"] > WORSE[0] * r[b]["error"] + WORSE[1]]
    by_camera = {}
    for r in flat:
        c = by_camera.setdefault(r["camera"], {"sets": 0, "moved": 0, a: [], b: []})
        c["sets"] += 1
        c["moved"] += r[a]["curve"] != r[b]["curve"]
        c[a].append(r[a]["error"])
        c[b].append(r[b]["error"])
    for c in by_camera.values():
        c[a], c[b] = (round(float(np.median(c[k])), 5) for k in (a, b))
    return {"gains": [a, b], "sets": len(flat), "worse": len(worse), "better": len(better), "moved": len(moved),
            "worse_sets": [f"{scene}: {r['camera']}" for scene, rs in rows.items() for r in rs if r in worse],
            "median_error_by_camera": by_camera}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m training.experiments.bracket_merge", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("study", choices=("ring", "curve", "gain"))
    ap.add_argument("--gains", type=float, nargs=2, default=(response.RESPONSE_GAIN, 1.0), metavar=("A", "B"),
                    help="gain: the two RESPONSE_GAINs compared (default: the shipped one and 1.0)")
    ap.add_argument("--hdri", type=Path, default=DEFAULT_HDRI, help="folder of real HDR panoramas")
    ap.add_argument("--step", type=int, default=None,
                    help="curve: the mild cameras on every N-th scene (default 10); gain: every N-th scene (default 1)")
    ap.add_argument("--out", type=Path, default=None, help="write the rows and summary here (JSON)")
    args = ap.parse_args(argv)
    files = scene_files(args.hdri)
    if args.study == "gain":
        rows = {p.stem: gain_rows(load_hdr(p), args.gains) for p in files[::args.step or 1]}
        summary = gain_summary(rows, args.gains)
    elif args.study == "ring":
        rows = {p.stem: ring_row(load_hdr(p)) for p in files}
        summary = {name: {"pixels": sum(r[name] for r in rows.values()),
                          "scenes": sum(r[name] > 0 for r in rows.values())} for name in ("without", "with")}
    else:
        shares = {f"{p.stem}@{len(evs)}": srgb_share(load_hdr(p), evs) for p in files for evs in CURVE_SETS}
        rows = {p.stem: curve_rows(load_hdr(p)) for p in files[::args.step or 10]}
        moved = [r for rs in rows.values() for r in rs if r["old"]["curve"] != r["shipped"]["curve"]]
        summary = {"srgb_sets": len(shares), "lowest_srgb_share": min(shares.values()),
                   "gain": response.RESPONSE_GAIN, "moved": len(moved),
                   "moved_worse": sum(r["shipped"]["error"] > r["old"]["error"] for r in moved),
                   "moved_error_ratio": [round(r["old"]["error"] / r["shipped"]["error"], 3) for r in moved]}
    print(json.dumps(summary, indent=1))
    if args.out:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps({"summary": summary, "rows": rows}, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
