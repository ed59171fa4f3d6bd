"""Reading panoramas: decode time per format at one size, and the peak memory of a whole estimate per
format at 16K, against the peers measured in the same run.

- time:  ``io.read_image`` of the same 4096 x 2048 sky saved as an RLE Radiance .hdr (OpenImageIO's
         writer, as most tools write them), a float32 ZIP EXR (the peer: target .hdr <= 3x), a half PIZ
         EXR, 8- and 16-bit PNGs and a q90 JPEG; and the numpy-only .hdr decoder (io.hdr, the fallback
         without OpenImageIO). Medians of --repeats runs.
- peak:  ``panolight estimate`` (every output) in a fresh process per file of 16384 x 8192 (or
         --peak-width) black pixels (what a decompression bomb within the budget decodes to): the
         process's maximum resident set, against the size of the pixels it holds (uint8, or an HDR
         above PACKED_ABOVE_MEGAPIXELS packed: RGBE bytes, half floats).

    python -m training.benchmarks.bench_io [--width 4096] [--repeats 5] [--peak-width 16384] [--no-peaks]
"""
from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from training.benchmarks import median_seconds

TARGET_HDR_OVER_EXR = 3.0


def _sky(width: int) -> np.ndarray:
    """A smooth sky with a bright sun and some texture: RLE-friendly where real skies are."""
    h = width // 2
    y, x = np.mgrid[0:h, 0:width].astype(np.float32)
    img = np.stack([0.4 + 0.3 * np.sin(x / 97.0), 0.6 + 0.2 * np.cos(y / 53.0), 1.0 + 0.1 * np.sin((x + y) / 31.0)], -1)
    img[: h // 2] *= 2.0
    img[h // 4 - 4:h // 4 + 4, width // 3 - 4:width // 3 + 4] = 5e4
    return img.astype(np.float32)


def _write_oiio(path: Path, img: np.ndarray, fmt: str) -> Path:
    import OpenImageIO as oiio

    out = oiio.ImageOutput.create(str(path))
    out.open(str(path), oiio.ImageSpec(img.shape[1], img.shape[0], 3, fmt))
    out.write_image(img)
    out.close()
    return path


def make_files(folder: Path, width: int) -> dict[str, Path]:
    from panolight_core.camera.color import linear_to_srgb
    from panolight_core.io import write_image, write_srgb8

    sky = _sky(width)
    srgb = linear_to_srgb(np.clip(sky / 4.0, 0, 1))
    return {
        "hdr (RLE)": _write_oiio(folder / "sky.hdr", sky, "float"),
        "exr float32 zip": write_image(folder / "sky32.exr", sky, compression="zip"),
        "exr half piz": write_image(folder / "sky16.exr", sky, half=True, compression="piz"),
        "png 8-bit": write_srgb8(folder / "sky8.png", np.round(srgb * 255).astype(np.uint8)),
        "png 16-bit": _write_oiio(folder / "sky16.png", np.round(srgb * 65535).astype(np.uint16), "uint16"),
        "jpeg q90": write_srgb8(folder / "sky.jpg", np.round(srgb * 255).astype(np.uint8), quality=90),
    }


def time_table(width: int, repeats: int) -> list[str]:
    from panolight_core.io import hdr as hdr_codec
    from panolight_core.io import read_image

    with tempfile.TemporaryDirectory() as tmp:
        files = make_files(Path(tmp), width)
        times = {name: median_seconds(lambda p=p: read_image(p, ldr_as_uint8=True), repeats) for name, p in files.items()}
        data = files["hdr (RLE)"].read_bytes()
        times["hdr (RLE), numpy fallback"] = median_seconds(lambda: hdr_codec.decode(data), max(1, repeats // 2))
    peer = times["exr float32 zip"]
    rows = [f"| {name} | {t * 1e3:.0f} | {t / peer:.2f}x |" for name, t in times.items()]
    ratio = times["hdr (RLE)"] / peer
    return [f"Decoding a {width} x {width // 2} panorama (`io.read_image`, median of {repeats}):", "",
            "| file | ms | vs float32 ZIP EXR |", "|---|---|---|", *rows, "",
            f".hdr / float32 EXR = {ratio:.2f}x (target <= {TARGET_HDR_OVER_EXR:g}x): "
            f"{'met' if ratio <= TARGET_HDR_OVER_EXR else 'NOT met'}", ""]


_BLACK = """
import sys, numpy as np, OpenImageIO as oiio
path, w, fmt = sys.argv[1], int(sys.argv[2]), sys.argv[3]
h = w // 2
out = oiio.ImageOutput.create(path)
out.open(path, oiio.ImageSpec(w, h, 3, fmt))
rows = np.zeros((256, w, 3), fmt in ("float", "half") and np.float32 or (fmt == "uint16" and np.uint16 or np.uint8))
for r in range(0, h, 256):
    out.write_scanlines(r, min(h, r + 256), 0, rows[:min(256, h - r)])
out.close()
"""


def peak_table(width: int) -> list[str]:
    from panolight_core.io import read_image
    from panolight_core.io.images import PACKED_ABOVE_MEGAPIXELS

    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name, suffix, fmt in (("JPEG", "jpg", "uint8"), ("PNG 8-bit", "png", "uint8"), ("PNG 16-bit", "png", "uint16"),
                                  ("Radiance .hdr", "hdr", "float"), ("EXR half", "exr", "half"),
                                  ("EXR float32", "exr", "float")):
            path = Path(tmp) / f"black_{fmt}.{suffix}"
            subprocess.run([sys.executable, "-c", _BLACK, str(path), str(width), fmt], check=True)
            out = Path(tmp) / f"out_{suffix}_{fmt}"
            cmd = [sys.executable, "-c", "import sys, resource\nfrom panolight_core.apps.cli import main\n"
                   "rc = main(sys.argv[1:])\n"
                   "print('PEAK', resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024)\nsys.exit(rc)",
                   "estimate", str(path), "-o", str(out), "-q"]
            t = time.perf_counter()
            r = subprocess.run(cmd, capture_output=True, text=True)
            dt = time.perf_counter() - t
            peak = next((int(line.split()[1]) for line in r.stdout.splitlines() if line.startswith("PEAK")), 0)
            held = read_image(path, ldr_as_uint8=True, packed_above=PACKED_ABOVE_MEGAPIXELS).nbytes  # what the CLI holds
            rows.append(f"| {name} | {path.stat().st_size / 1e6:.1f} | {peak / 1e9:.2f} | {held / 1e9:.2f} | "
                        f"{dt:.0f} | {r.returncode} |")
            path.unlink()
    return [f"`panolight estimate` (every output) of {width} x {width // 2} black pixels, a fresh process each:", "",
            "| file | MB on disk | peak GB | pixels held GB | s | exit |", "|---|---|---|---|---|---|", *rows, ""]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--width", type=int, default=4096)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--peak-width", type=int, default=16384)
    ap.add_argument("--no-peaks", action="store_true", help="skip the 16K peak-memory runs (minutes)")
    args = ap.parse_args(argv)
    lines = time_table(args.width, args.repeats)
    if not args.no_peaks:
        lines += peak_table(args.peak_width)
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
