"""The bracket merge against OpenCV's calibrated Debevec merge (issue 59): time, agreement and fireflies.

Sets, each merged by PanoLight (``camera.brackets.merge_brackets``: its own camera curve where that fits better
than sRGB; no alignment, the sets are still) and by OpenCV (``CalibrateDebevec``, then ``MergeDebevec`` with that
curve) on the same frames and exposures:

- **simulated** (default): real HDRs of ../shared/data/hdri (``--scenes``; ``--public``: the eight the bpy package
  ships, real scenes the project never trained on), each taken as a camera takes a bracket:
  the EVALUATION.md ev-0 exposure times 2^s for each s of ``--stops``, photon and read noise
  (``camera.sensor_noise``: a small sensor's), the sRGB curve, JPEG q90;
- **real**: ``--frames DIR``, a folder of a real set's frames (8-bit, one scene) with their exposure times: from
  EXIF as ``panolight estimate`` reads them (``pipeline.brackets.bracket_exposures``: a phone's repeated exposures
  from its exposure bias), or from a ``shutter_times.txt`` beside them (one time per line, in seconds or as 1/N, frames in name order,
  as Debevec's memorial set carries them). Never copied into the repository.

Scores (``score``):
- agreement: the median |ln(ours / OpenCV's)| of luminance over the pixels the reference frame (the median
  exposure) sees well exposed (its brightest channel's code 20-235), after one scale (the two merges' units differ);
- fireflies: pixels whose luminance is over FIREFLY_RATIO x the median of their 5 x 5 neighbourhood (and above a
  thousandth of the reference white: no flicker in black counts); also those that are no bright point of the
  scene's own (spurious: a night scene's lamps are points a merge must keep): for a simulated set, none of the
  truth's; for a real set, none that two frames show themselves where they expose it well, nor a lamp only the
  darkest frame can hold (``shown_by_a_frame``);
- truth (simulated): the median |ln(merged / true)| of luminance where the truth is 0.01-0.9 of the reference
  frame's white, after one scale;
- held out (a real set of three or more frames, which has no truth): each frame between the darkest and the
  brightest left out, the others merged, and it taken again through the merge's own curve (``held_out``): the median
  and mean |code error|, for PanoLight's merge also weighed by Debevec's hat (which weighing predicts better);
- where the disagreement comes from (a real set, ``weighed_as_opencv``): PanoLight's merge run again with OpenCV's
  calibrated curve, then also with Debevec's hat for its noise weights and no ghost or outlier tests, each against
  OpenCV's merge (what is left is the two merges' weighing, not their curves);
- time: the median of ``--repeats`` runs, in this process;
- the camera curve (``curves``): PanoLight's recovered curve against OpenCV's CalibrateDebevec, and each against
  sRGB (the simulated cameras' own), in log over codes 30-230 after one scale; and which curve the merge used.

    python -m training.benchmarks.bench_merge [--scenes noon_grass ...] [--stops -4 -2 0 2 4] [--width 1024]
    python -m training.benchmarks.bench_merge --frames PATH/TO/memorial --out runs/bench_merge_memorial.json
"""
from __future__ import annotations

import argparse
import contextlib
import json
import math
import statistics
import time
from fractions import Fraction
from pathlib import Path

import numpy as np

from panolight_core.camera import auto_exposure, blend, brackets, hdr_to_ldr, response
from panolight_core.camera.color import LUMINANCE_WEIGHTS
from panolight_core.camera.resample import area_downsample
from panolight_core.errors import PanoLightError

FIREFLY_RATIO = 10.0
WELL_EXPOSED = (20, 235)
DEFAULT_SCENES = ("noon_grass", "kloppenheim_05", "brown_photostudio_02", "dresden_station_night")


def camera_set(hdr: np.ndarray, stops, seed: int = 0):
    """(frames, relative exposures) of ``hdr`` bracketed at ``stops`` about the EVALUATION.md ev-0 exposure: each a
    noisy sensor's (``camera.sensor_noise``) sRGB JPEG at q90."""
    rng = np.random.default_rng(seed)
    k = auto_exposure(hdr, 0.0, robust=True)
    frames = [hdr_to_ldr(hdr, scale=k * 2.0 ** s, jpeg_quality=90, noise=rng) for s in stops]
    return frames, np.array([2.0 ** s for s in stops])


def read_set(folder: Path):
    """(frames, exposure times in s, names) of a real set in ``folder``: its 8-bit frames in name order, timed by a
    shutter_times.txt beside them or by their EXIF as ``panolight estimate`` reads it. SystemExit naming what is
    missing."""
    from PIL import Image

    from panolight_core.pipeline.brackets import bracket_exposures

    names = sorted(p for p in folder.iterdir() if p.suffix.lower() in (".jpg", ".jpeg", ".png", ".tif", ".tiff"))
    if not names:
        raise SystemExit(f"--frames {folder}: no 8-bit frames (JPEG, PNG or TIFF) there")
    listed = folder / "shutter_times.txt"
    if listed.is_file():
        times = [float(Fraction(line.strip())) for line in listed.read_text().split() if line.strip()]
    else:  # as panolight estimate reads them (a phone's repeated exposures from its bias)
        try:
            times = bracket_exposures(names)[0]
        except PanoLightError as exc:
            raise SystemExit(f"--frames {folder}: {exc} (or give a shutter_times.txt)") from None
    if len(times) != len(names):
        raise SystemExit(f"--frames {folder}: {len(names)} frames but {len(times)} exposure times")
    frames = [np.asarray(Image.open(p).convert("RGB")) for p in names]  # any shape: a merge needs no panorama
    return frames, np.array(times, dtype=np.float64), [p.name for p in names]


def merge_panolight(frames, exposures, names=None):
    return brackets.merge_brackets(frames, exposures, align=False, names=names)[0]


def _opencv_calibration(frames, exposures):
    """(the frames as OpenCV takes them, BGR; their times, float32; OpenCV's CalibrateDebevec curve, (256, 1, 3) BGR)."""
    import cv2

    bgr = [np.ascontiguousarray(f[..., ::-1]) for f in frames]
    times = np.asarray(exposures, dtype=np.float32)
    return bgr, times, cv2.createCalibrateDebevec().process(bgr, times)


def opencv_merge(frames, exposures) -> tuple[np.ndarray, np.ndarray]:
    """OpenCV's calibrated Debevec merge of RGB ``frames``: (the HDR (H, W, 3) float64, RGB; its curve (256, 3), RGB):
    the curve from the frames (CalibrateDebevec), then MergeDebevec with it."""
    import cv2

    bgr, times, curve = _opencv_calibration(frames, exposures)
    return cv2.createMergeDebevec().process(bgr, times, curve)[..., ::-1].astype(np.float64), curve[:, 0, ::-1]


def merge_opencv(frames, exposures):
    """``opencv_merge``'s HDR."""
    return opencv_merge(frames, exposures)[0]


def opencv_curve(frames, exposures) -> np.ndarray:
    """(256,) float32: OpenCV's CalibrateDebevec curve of the set, its luminance made monotone, scaled to put code 250
    where sRGB does (as ``camera.response`` scales a recovered curve)."""
    theirs = _opencv_calibration(frames, exposures)[2][:, 0, ::-1]
    table = np.maximum.accumulate(theirs @ LUMINANCE_WEIGHTS).astype(np.float64)
    return (table / table[250] * float(response.SRGB.table[250])).astype(np.float32)


@contextlib.contextmanager
def weighed_as_opencv(frames, exposures, hat: bool, curve: bool = True):
    """Within it, ``merge_brackets`` decodes, with ``curve``, through OpenCV's curve of the set (``opencv_curve``; else
    through its own) and, with ``hat``, weighs each code by Debevec's hat instead of its noise weight: the parts of
    OpenCV's merge that PanoLight's can take, so that what disagreement is left is the rest of the weighing (per
    channel there, the worst channel here)."""
    from panolight_core.camera.weights import hat as hat_weights

    theirs = response.Response(opencv_curve(frames, exposures), "OpenCV's", "bench_merge", {}) if curve else None
    shipped = brackets.recover_response, blend.noise_weights
    if curve:
        brackets.recover_response = lambda *_: theirs
    if hat:
        blend.noise_weights = lambda table: hat_weights(np.arange(256, dtype=np.uint8))
    try:
        yield
    finally:
        brackets.recover_response, blend.noise_weights = shipped


def firefly_mask(img: np.ndarray, floor: float, ratio: float = FIREFLY_RATIO) -> np.ndarray:
    """Pixels whose luminance is over ``ratio`` x their 5 x 5 neighbourhood's median, and over ``floor``."""
    from scipy.ndimage import median_filter

    lum = np.asarray(img, dtype=np.float64) @ LUMINANCE_WEIGHTS
    return (lum > ratio * median_filter(lum, size=5, mode="nearest")) & (lum > floor)


CURVE_CODES = (30, 230)  # the codes the curves are compared on (both solves' reliable part)


def curves(frames, exposures) -> dict:
    """The set's camera curve as PanoLight recovers it (``camera.response.recover_response``, taken whatever its gain
    over sRGB) and as OpenCV's ``CalibrateDebevec`` does, compared in log luminance over CURVE_CODES after one scale:
    the median |ln| between the two, and each against sRGB (the simulated sets' true curve); and which curve the merge
    used (sRGB unless the recovered one explains the frames RESPONSE_GAIN better)."""

    e = np.asarray(exposures, dtype=np.float64)
    ref = int(np.argsort(e)[(e.size - 1) // 2])
    used = response.recover_response(frames, e / e[ref], ref)
    shipped, response.RESPONSE_GAIN = response.RESPONSE_GAIN, float("inf")
    try:
        ours = response.recover_response(frames, e / e[ref], ref)
    finally:
        response.RESPONSE_GAIN = shipped
    theirs = _opencv_calibration(frames, e)[2][:, 0, ::-1] @ LUMINANCE_WEIGHTS
    z = slice(CURVE_CODES[0], CURVE_CODES[1] + 1)
    logs = {"panolight": np.log(ours.table[z].astype(np.float64)), "opencv": np.log(theirs[z]),
            "srgb": np.log(response.SRGB.table[z].astype(np.float64))}

    def apart(a, b):
        d = logs[a] - logs[b]
        return float(np.median(np.abs(d - np.median(d))))

    return {"used": used.name, "recovered": ours.name, "panolight_vs_opencv": apart("panolight", "opencv"),
            "panolight_vs_srgb": apart("panolight", "srgb"), "opencv_vs_srgb": apart("opencv", "srgb")}


def fireflies(img: np.ndarray, floor: float, truth: np.ndarray | None = None) -> int:
    """``firefly_mask``'s count; with ``truth`` (the same units) only those that are no bright point of the truth's
    own (none within a pixel over FIREFLY_RATIO / 2 x its neighbourhood, as ``shown_by_a_frame`` asks of a real
    set's frames: a truth point at 9.5x that the merge puts at 10.2x is the truth's): a night scene's lamps are
    points a merge must keep."""
    from scipy.ndimage import binary_dilation

    found = firefly_mask(img, floor)
    if truth is not None:
        found &= ~binary_dilation(firefly_mask(truth, floor, 0.5 * FIREFLY_RATIO), iterations=1)
    return int(found.sum())


def shown_by_a_frame(frames, exposures, table: np.ndarray) -> np.ndarray:
    """(H, W) bool: pixels that two or more frames show as a bright point themselves: well exposed there (brightest
    channel's code within WELL_EXPOSED) and over FIREFLY_RATIO / 2 x the median of its 5 x 5 neighbourhood, decoded
    through the set's camera curve ``table`` (code -> linear); and lamps only the darkest frame can hold: pixels it
    holds over its well-exposed codes (which a merge can only put near its white or above), or shows as such a point
    where every other frame clips (brightest channel over WELL_EXPOSED: the brighter frames agree it is bright). A
    merge's firefly there is the scene's own (a lit speck of a window), not the merge's: the real sets' "spurious"
    count leaves them out. (One frame alone is no evidence elsewhere: a speck of dust on one scan is a bright point
    of that frame.)"""
    shown = np.zeros(frames[0].shape[:2], np.uint8)
    lut = np.asarray(table, dtype=np.float64)
    dark = int(np.argmin(exposures))
    others_clip = np.ones(frames[0].shape[:2], bool)
    for i, f in enumerate(frames):
        top = f.max(axis=-1)
        point = firefly_mask(lut[f], 0.0, 0.5 * FIREFLY_RATIO) & (top >= WELL_EXPOSED[0]) & (top <= WELL_EXPOSED[1])
        shown += point
        if i == dark:
            lamp = point | (top > WELL_EXPOSED[1])
        else:
            others_clip &= top > WELL_EXPOSED[1]
    return (shown >= 2) | (lamp & (others_clip | (frames[dark].max(axis=-1) > WELL_EXPOSED[1])))


def _codes_of(values: np.ndarray, curve: np.ndarray) -> np.ndarray:
    """The 8-bit codes a camera whose curve is ``curve`` ((256,) or (256, 3): code -> light, made monotone here)
    writes for ``values`` (..., 3) of light in the curve's units: the nearest code, per channel."""
    curve = np.asarray(curve, dtype=np.float64)
    curve = np.broadcast_to(curve.reshape(256, -1), (256, 3))
    out = np.empty(values.shape, np.int16)
    for c in range(3):
        table = np.maximum.accumulate(curve[:, c])
        edges = (table[1:] + table[:-1]) / 2.0
        out[..., c] = np.searchsorted(edges, values[..., c])
    return out


def held_out(frames, exposures, merges=("panolight", "opencv")) -> dict:
    """Each merge's accuracy where no truth exists: every frame between the darkest and the brightest left out in
    turn, the others merged (each merge with its own curve, recovered from them), and the left-out frame taken again
    from that HDR through that curve at its own exposure. The median |code error| over the channels the frame holds
    well exposed (WELL_EXPOSED), and its mean, pooled over the frames left out: what each merge's HDR and curve predict
    of a photo they never saw (a moving flag or a flickering lamp is in both merges' error alike). ``merges``: which of
    the two to score."""
    e = np.asarray(exposures, dtype=np.float64)
    order = np.argsort(e)
    errors = {n: [] for n in merges}
    for k in order[1:-1]:
        keep = [i for i in range(len(frames)) if i != k]
        rest, t = [frames[i] for i in keep], e[keep]
        ref = int(np.argsort(t)[(t.size - 1) // 2])
        actual = frames[k].astype(np.int16)
        well = (actual >= WELL_EXPOSED[0]) & (actual <= WELL_EXPOSED[1])
        if "panolight" in errors:  # the reference's units: a code z of frame i reads table[z] / (t_i / t_ref)
            ours = merge_panolight(rest, t)
            table = response.recover_response(rest, t / t[ref], ref).table
            errors["panolight"].append(np.abs(_codes_of(ours * (e[k] / t[ref]), table) - actual)[well])
        if "opencv" not in errors:
            continue
        theirs, curve = opencv_merge(rest, t)
        errors["opencv"].append(np.abs(_codes_of(theirs * e[k], curve) - actual)[well])
    pooled = {n: np.concatenate(v) for n, v in errors.items() if v}
    return {n: {"median": float(np.median(v)), "mean": float(np.mean(v))} for n, v in pooled.items()}


def _scaled_log_error(a: np.ndarray, b: np.ndarray) -> float:
    """Median |ln(a / b)| after one scale (the median ratio), over positive pairs."""
    ok = (a > 0) & (b > 0)
    r = np.log(a[ok] / b[ok])
    return float(np.median(np.abs(r - np.median(r))))


def score(frames, exposures, repeats: int = 3, truth: np.ndarray | None = None, names=None) -> dict:
    """Both merges of one set: time, agreement, fireflies and (with ``truth``, in the reference frame's units) the
    error against it. PanoLightError (naming frames by ``names``) where PanoLight's merge refuses the set."""
    e = np.asarray(exposures, dtype=np.float64)
    ref = int(np.argsort(e)[(e.size - 1) // 2])
    out, merged = {}, {}
    for name, merge in (("panolight", lambda f, x: merge_panolight(f, x, names)), ("opencv", merge_opencv)):
        times = []
        for _ in range(repeats):
            t0 = time.perf_counter()
            merged[name] = merge(frames, e)
            times.append(time.perf_counter() - t0)
        out[name] = {"seconds": statistics.median(times)}
    top = frames[ref].max(axis=-1)
    well = (top >= WELL_EXPOSED[0]) & (top <= WELL_EXPOSED[1])
    lum = {n: m @ LUMINANCE_WEIGHTS for n, m in merged.items()}
    out["agreement"] = _scaled_log_error(lum["panolight"][well], lum["opencv"][well])
    white = {n: float(np.median(lum[n][well])) / max(float(np.median(merged["panolight"][well] @ LUMINANCE_WEIGHTS)),
                                                      1e-30) for n in merged}  # each merge's reference white
    shown = None
    if truth is None:  # a real set: the points its frames show themselves are the scene's
        shown = shown_by_a_frame(frames, e, response.recover_response(frames, e / e[ref], ref).table)
    for n in merged:
        out[n]["fireflies"] = fireflies(merged[n], 1e-3 * white[n])
        if shown is not None:
            out[n]["spurious_fireflies"] = int((firefly_mask(merged[n], 1e-3 * white[n]) & ~shown).sum())
        if truth is not None:
            scale = float(np.median(lum[n][well])) / max(float(np.median((truth @ LUMINANCE_WEIGHTS)[well])), 1e-30)
            out[n]["spurious_fireflies"] = fireflies(merged[n], 1e-3 * white[n], truth * scale)
            lt = truth @ LUMINANCE_WEIGHTS
            mid = (lt > 0.01) & (lt < 0.9)
            out[n]["truth_error"] = _scaled_log_error(lum[n][mid], lt[mid])
    out["pixels"] = int(top.size)
    out["curve"] = curves(frames, e)
    if truth is None and len(frames) >= 3:  # a real set: how well each merge predicts a frame it never saw
        out["held_out"] = held_out(frames, e)
        with weighed_as_opencv(frames, e, hat=True, curve=False):  # PanoLight's merge weighed by the hat
            out["held_out"]["panolight_hat"] = held_out(frames, e, merges=("panolight",))["panolight"]
    if truth is None:  # where its disagreement with OpenCV comes from
        out["agreement_parts"] = {}
        for key, hat, ghosts in (("opencv_curve", False, True), ("opencv_curve_hat_no_ghosts", True, False)):
            with weighed_as_opencv(frames, e, hat):
                m = brackets.merge_brackets(frames, e, align=False, ghosts=ghosts)[0]
            out["agreement_parts"][key] = _scaled_log_error((m @ LUMINANCE_WEIGHTS)[well], lum["opencv"][well])
    return out


def table(rows: list[dict]) -> list[str]:
    lines = ["| set | frames | pixels | agreement (median abs ln) | fireflies (spurious): PanoLight / OpenCV | error vs "
             "truth: PanoLight / OpenCV | time s: PanoLight / OpenCV (ratio) |", "|---|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        if "refused" in r:
            lines.append(f"| {r['set']} | {r['frames']} | refused by PanoLight: {r['refused']} |||||")
            continue
        p, o = r["panolight"], r["opencv"]
        truth = (f"{p['truth_error']:.3f} / {o['truth_error']:.3f}" if "truth_error" in p else "n/a")
        flies = [f"{x['fireflies']}" + (f" ({x['spurious_fireflies']})" if "spurious_fireflies" in x else "")
                 for x in (p, o)]
        lines.append(f"| {r['set']} | {r['frames']} | {r['pixels']} | {r['agreement']:.3f} | {flies[0]} / "
                     f"{flies[1]} | {truth} | {p['seconds']:.2f} / {o['seconds']:.2f} "
                     f"({p['seconds'] / o['seconds']:.2f}x) |")
    return lines


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m training.benchmarks.bench_merge", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", nargs="+", default=list(DEFAULT_SCENES), help="real HDRs to bracket (simulated sets)")
    ap.add_argument("--stops", type=float, nargs="+", default=[-4.0, -2.0, 0.0, 2.0, 4.0],
                    help="the simulated sets' exposures in stops about the ev-0 one (default -4 -2 0 2 4)")
    ap.add_argument("--width", type=int, default=1024, help="the simulated sets' width (default 1024)")
    ap.add_argument("--frames", type=Path, action="append", default=[], metavar="DIR",
                    help="a real set's folder (repeatable): frames and their times (EXIF or shutter_times.txt)")
    ap.add_argument("--public", action="store_true",
                    help="simulated sets of the eight HDRIs the bpy package ships (real scenes not in ../shared) "
                         "instead of --scenes")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--out", type=Path, default=None, help="write the rows as JSON here")
    args = ap.parse_args(argv)
    rows = []
    for folder in args.frames:
        frames, times, names = read_set(folder)
        try:
            rows.append({"set": folder.name, "frames": len(frames), **score(frames, times, args.repeats, names=names)})
        except PanoLightError as exc:  # a set the merge refuses (its frames are not what it says): said, not scored
            rows.append({"set": folder.name, "frames": len(frames), "refused": str(exc)})
        print("\n".join(table(rows[-1:])[2:]), flush=True)
    if not args.frames:
        from panolight_core.data import STUDIO_HDRIS, load_studio_hdri
        from training.common.real_hdri import DEFAULT_HDRI, load_hdr

        for scene in STUDIO_HDRIS if args.public else args.scenes:
            full = (np.maximum(np.asarray(load_studio_hdri(scene), dtype=np.float64), 0.0) if args.public
                    else load_hdr(next(DEFAULT_HDRI.glob(f"{scene}.*"))))
            hdr = area_downsample(full, min(args.width // 2, full.shape[0]))
            frames, exposures = camera_set(hdr, args.stops)
            truth = hdr * auto_exposure(hdr, 0.0, robust=True)
            rows.append({"set": scene, "frames": len(frames), **score(frames, exposures, args.repeats, truth)})
            print("\n".join(table(rows[-1:])[2:]), flush=True)
    print("\n".join(table(rows)))
    scored = [r for r in rows if "refused" not in r]
    held = [r for r in scored if r.get("held_out")]
    if held:
        print("\n| set | a frame left out, taken again from the others' merge: code error, median / mean: PanoLight "
              "| PanoLight weighed by the hat | OpenCV |\n|---|---:|---:|---:|")
        for r in held:
            p, h, o = (r["held_out"][k] for k in ("panolight", "panolight_hat", "opencv"))
            print(f"| {r['set']} | {p['median']:.0f} / {p['mean']:.2f} | {h['median']:.0f} / {h['mean']:.2f} | "
                  f"{o['median']:.0f} / {o['mean']:.2f} |")
    parts = [r for r in scored if r.get("agreement_parts")]
    if parts:
        print("\n| set | agreement with OpenCV | PanoLight's merge on OpenCV's curve | and Debevec's hat, no ghost "
              "tests |\n|---|---:|---:|---:|")
        for r in parts:
            p = r["agreement_parts"]
            print(f"| {r['set']} | {r['agreement']:.3f} | {p['opencv_curve']:.3f} | "
                  f"{p['opencv_curve_hat_no_ghosts']:.3f} |")
    print("\n| set | curve used | recovered vs OpenCV's | recovered vs sRGB | OpenCV's vs sRGB |\n|---|---|---:|---:|---:|")
    for r in scored:
        c = r["curve"]
        print(f"| {r['set']} | {c['used']} | {c['panolight_vs_opencv']:.3f} | {c['panolight_vs_srgb']:.3f} | "
              f"{c['opencv_vs_srgb']:.3f} |")
    if args.out:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps({"rows": rows, "stops": args.stops}, indent=1))
    return 0 if math.isfinite(sum(r["agreement"] for r in scored)) else 1


if __name__ == "__main__":
    raise SystemExit(main())
