"""Restoring an HDR file that clips its own sun: what it costs against reading the file and writing its hdr.exr.

An 8K (8192 x 4096) float32 EXR of a real sunlit scene (../shared/data/hdri, upsampled 8x by pixel repetition),
exposed at ev 0 and clipped per channel at 2^--stops over that white. Timed, medians of --repeats runs after a
warm-up, all in this process:

- decode:        ``io.read_image`` of the file;
- hdr.exr write: ``io.write_exr_rows`` of the decoded pixels (what ``panolight estimate`` writes);
- estimate, as it is:  ``run_estimate`` (decode, estimate, lighting.json and hdr.exr) with ``--restore none``;
- estimate, restored:  the same with ``--restore auto`` (the default: ``sources.restore``).

Issue 45's bar: restored <= 1.5x (decode + hdr.exr write).

And a bracket set against one JPEG, decode to estimate (``io.read_image`` or ``pipeline.brackets.read_brackets``,
then ``estimate_lighting`` with the defaults): the scene's EVALUATION.md camera JPEGs (q90) at 2048 x 1024, the
ev-0 one alone against the three at -2, 0, +2 (exposures from --evs). Bar: the set <= 4x the JPEG.

    python -m training.benchmarks.bench_restore [--scene noon_grass] [--stops 4] [--scale 8] [--repeats 3]
"""
from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

from training.benchmarks import median_seconds

BAR = 1.5
BRACKETS_BAR = 4.0


def make_file(folder: Path, scene: str, stops: float, scale: int) -> Path:
    from panolight_core.camera import auto_exposure
    from panolight_core.io import write_image
    from training.common.real_hdri import DEFAULT_HDRI, load_hdr

    hdr = load_hdr(DEFAULT_HDRI / f"{scene}.hdr")
    clipped = np.minimum(hdr * auto_exposure(hdr, 0.0), 2.0 ** stops).astype(np.float32)
    big = np.repeat(np.repeat(clipped, scale, axis=0), scale, axis=1)
    return write_image(folder / f"{scene}_clipped.exr", big, compression="zip")


def scene_2k(scene: str) -> np.ndarray:
    """The real HDR ``scene`` of ../shared/data/hdri upsampled 2x by pixel repetition: 2048 x 1024."""
    from training.common.real_hdri import DEFAULT_HDRI, load_hdr

    hdr = load_hdr(DEFAULT_HDRI / f"{scene}.hdr")
    return np.repeat(np.repeat(hdr, 2, axis=0), 2, axis=1)


def bracket_files(folder: Path, scene: str, evs=(-2, 0, 2)):
    """(the ev-0 JPEG, the JPEGs at ``evs``) of the scene at 2048 x 1024 (``scene_2k``; EVALUATION.md's camera,
    q90)."""
    from panolight_core.camera import hdr_to_ldr
    from panolight_core.io import write_srgb8

    hdr = scene_2k(scene)
    frames = [write_srgb8(folder / f"{scene}_{ev:+g}.jpg", hdr_to_ldr(hdr, ev, 90)) for ev in evs]
    return frames[list(evs).index(0)], frames


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m training.benchmarks.bench_restore", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene", default="noon_grass", help="a real HDR of ../shared/data/hdri (default %(default)s)")
    ap.add_argument("--stops", type=float, default=4.0, help="clip at 2^STOPS over the ev-0 white (default 4)")
    ap.add_argument("--scale", type=int, default=8, help="upsampling factor of the 1024 x 512 scene (default 8: 8K)")
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args(argv)
    from panolight_core.io import read_image
    from panolight_core.io.images import write_exr_rows
    from panolight_core.pipeline.brackets import read_brackets
    from panolight_core.pipeline.estimate import estimate_lighting
    from panolight_core.pipeline.job import run_estimate
    from panolight_core.pipeline.settings import Settings

    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        path = make_file(folder, args.scene, args.stops, args.scale)
        pixels = read_image(path, ldr_as_uint8=True)
        h, w = pixels.shape[:2]

        def blocks():
            for r in range(0, h, 256):
                yield r, pixels[r:r + 256]

        times = {
            "decode": median_seconds(lambda: read_image(path, ldr_as_uint8=True), args.repeats),
            "hdr.exr write": median_seconds(lambda: write_exr_rows(folder / "w.exr", h, w, blocks()), args.repeats),
        }
        for name, restore in (("estimate, as it is", "none"), ("estimate, restored", "auto")):
            times[name] = median_seconds(lambda r=restore: run_estimate(
                path, folder / f"out_{r}", Settings(restore=r), outputs=("lighting", "hdr"), overwrite=True),
                args.repeats)
        jpeg, frames = bracket_files(folder, args.scene)
        single = median_seconds(lambda: estimate_lighting(read_image(jpeg, ldr_as_uint8=True)), args.repeats)
        three = median_seconds(lambda: estimate_lighting(read_brackets(frames, (-2.0, 0.0, 2.0))[0]), args.repeats)
    base = times["decode"] + times["hdr.exr write"]
    print(f"{args.scene} clipped at +{args.stops:g} stops, {w} x {h}, medians of {args.repeats}")
    print("| step | seconds | over decode + hdr.exr write |")
    print("|---|---:|---:|")
    for name, t in times.items():
        print(f"| {name} | {t:.2f} | {t / base:.2f} |")
    ratio = times["estimate, restored"] / base
    print(f"restored: {ratio:.2f}x decode + hdr.exr write (bar {BAR:g}x): {'met' if ratio <= BAR else 'NOT met'}")
    print()
    print("| 2048 x 1024, decode to estimate | seconds | over the JPEG |")
    print("|---|---:|---:|")
    print(f"| one JPEG (ev 0) | {single:.3f} | 1.00 |")
    print(f"| three brackets (-2, 0, +2), merged | {three:.3f} | {three / single:.2f} |")
    print(f"brackets: {three / single:.2f}x the JPEG (bar {BRACKETS_BAR:g}x): "
          f"{'met' if three / single <= BRACKETS_BAR else 'NOT met'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
