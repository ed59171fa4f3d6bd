"""PanoLight at scale: 16K CLI estimates, 8K/16K Blender runs and batch throughput, against their peers.

Every figure is measured in a fresh child process (peak memory is that process's maximum resident set),
against a peer measured in the same run on the same file:
- cli:     ``panolight estimate`` of a 16384 x 8192 JPEG (all outputs, and without hdr.exr: the outputs
           estimate had when the target was set) against Pillow's full decode of the file into a numpy
           array, and the peak for a JPEG whose sun clipped millions of pixels (city upsampled smoothly).
           Targets: time <= 2.0x, peak <= 1.3 GB.
- blender: Load panorama + Estimate lighting + Build environment of an 8192 x 4096 JPEG with the bpy
           module (with the Python packages Blender ships on its path, as inside Blender), against one
           ``image.pixels.foreach_get`` of the same image (target <= 2.5x), and the peak of the same at
           16384 x 8192 (target <= 3 GB).
- batch:   ``panolight batch`` over N 1024 x 512 JPEGs: inputs per second (target >= 3x the 4.8 / s
           measured by this benchmark before the scale work: commit b8df6d8, 2026-12-01, this 2-core machine).
Panoramas are made from Blender's city HDRI (EVALUATION.md camera, ev 0, q90) with film grain, so the
JPEGs are as costly to decode as photographs. Results go to stdout as a markdown table.

    python -m training.benchmarks.bench_scale [--parts cli blender batch] [--repeats 3] [--batch-count 200]
"""
from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import textwrap
from pathlib import Path

BATCH_BASELINE_PER_S = 4.8  # inputs / s of `panolight batch` at 1024 x 512 before the scale work (this benchmark at commit b8df6d8, 2026-12-01, this 2-core machine)
TARGETS = {"cli_time": 2.0, "cli_peak_gb": 1.3, "blender_time": 2.5, "blender_peak_gb": 3.0, "batch_speedup": 3.0}

_MAKE = """
import sys, warnings
import numpy as np
from panolight_core.camera import hdr_to_ldr
from panolight_core.camera.resample import area_downsample
from panolight_core.data import load_studio_hdri
from panolight_core.io import read_image, write_srgb8
warnings.simplefilter("ignore")
out, width, count = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
hdr = load_studio_hdri("city")
rng = np.random.default_rng(0)
for i in range(count):
    f = max(1, width // 1024)
    img = area_downsample(hdr, width // 2) if width < 1024 else hdr
    ldr = hdr_to_ldr(np.roll(img, 37 * i, axis=1), 0.0)
    rows = []
    for r in range(0, ldr.shape[0]):  # upsample row by row (a 16K image has no room for float copies)
        rows.append(np.repeat(ldr[r:r + 1], f, axis=1))
    big = np.repeat(np.concatenate(rows), f, axis=0) if f > 1 else np.concatenate(rows)
    grain = rng.integers(-6, 7, size=(min(big.shape[0], 512), big.shape[1], 3), dtype=np.int16)
    for r in range(0, big.shape[0], grain.shape[0]):
        block = big[r:r + grain.shape[0]]
        block[:] = np.clip(block.astype(np.int16) + grain[:len(block)], 0, 255).astype(np.uint8)
    write_srgb8(f"{out}/pano{i:04d}.jpg" if count > 1 else out, big, quality=90)
"""

_PEAK = "import resource; print('PEAK', resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024)"


def _child(code: str, *args) -> dict:
    """Run code in a fresh interpreter; it prints 'TIME seconds' lines; returns times and peak bytes."""
    r = subprocess.run([sys.executable, "-c", code + "\n" + _PEAK, *map(str, args)], capture_output=True,
                       text=True, timeout=3600)
    if r.returncode != 0:
        raise SystemExit(f"bench_scale: child failed:\n{r.stdout[-2000:]}{r.stderr[-3000:]}")
    out = {"peak": 0, "times": {}}
    for line in r.stdout.splitlines():
        key, _, value = line.partition(" ")
        if key == "PEAK":
            out["peak"] = int(value)
        elif key == "TIME":
            name, _, seconds = value.partition(" ")
            out["times"][name] = float(seconds)
    return out


def _make(path, width, count=1):
    _child(_MAKE, path, width, count)


_MAKE_CLIPPED = """
import sys, warnings
from PIL import Image
from panolight_core.camera import hdr_to_ldr
from panolight_core.data import load_studio_hdri
warnings.simplefilter("ignore")
Image.fromarray(hdr_to_ldr(load_studio_hdri("city"), 0.0)).resize((16384, 8192), Image.BICUBIC).save(sys.argv[1],
                                                                                                   quality=95)
"""  # the city sun's clipped patch upsampled smoothly (no film grain to break it up): 6.4 M clipped pixels


def bench_cli(tmp: Path, repeats: int) -> list[dict]:
    src = tmp / "pano16k.jpg"
    _make(src, 16384)
    pillow = textwrap.dedent("""
        import sys, time
        import numpy as np
        from PIL import Image
        Image.MAX_IMAGE_PIXELS = None
        t = time.perf_counter()
        with Image.open(sys.argv[1]) as im:
            a = np.asarray(im)
        print("TIME decode", time.perf_counter() - t)
    """)
    cli = textwrap.dedent("""
        import sys, time
        from panolight_core.apps.cli import main
        t = time.perf_counter()
        rc = main(["estimate", sys.argv[1], "-o", sys.argv[2], "-q", "--overwrite"] + sys.argv[3:])
        print("TIME estimate", time.perf_counter() - t)
        assert rc == 0
    """)
    clipped = tmp / "clipped16k.jpg"
    _child(_MAKE_CLIPPED, clipped)
    rows = []
    for _ in range(repeats):  # interleaved, so drift hits all alike
        p = _child(pillow, src)
        c = _child(cli, src, tmp / "out16k")
        n = _child(cli, src, tmp / "out16k_nohdr", "--outputs", "lighting,previews")
        k = _child(cli, clipped, tmp / "out16k_clipped")
        rows.append({"decode_s": p["times"]["decode"], "decode_peak": p["peak"],
                     "estimate_s": c["times"]["estimate"], "estimate_peak": c["peak"],
                     "nohdr_s": n["times"]["estimate"], "nohdr_peak": n["peak"], "clipped_peak": k["peak"]})
    return rows


_BLENDER = """
import glob, sys, time
from pathlib import Path
import bpy
# Blender's own Python has the packages it ships (OpenImageIO) on its path; the bpy module does not
sys.path += glob.glob(str(Path(bpy.__file__).parents[3] / "python" / "lib" / "python3*" / "site-packages"))
import numpy as np
import blender_addon
bpy.ops.wm.read_factory_settings(use_empty=True)
blender_addon.register()
path = sys.argv[1]
if sys.argv[2] == "read":
    image = bpy.data.images.load(path)
    t = time.perf_counter()
    buf = np.empty(image.size[0] * image.size[1] * image.channels, np.float32)
    image.pixels.foreach_get(buf)
    print("TIME read", time.perf_counter() - t)
else:
    t = time.perf_counter()
    assert bpy.ops.panolight.load_panorama(filepath=path) == {"FINISHED"}
    assert bpy.ops.panolight.estimate_lighting() == {"FINISHED"}
    assert bpy.ops.panolight.build_environment() == {"FINISHED"}
    print("TIME lit", time.perf_counter() - t)
"""


def bench_blender(tmp: Path, repeats: int) -> dict:
    src8, src16 = tmp / "pano8k.jpg", tmp / "pano16k.jpg"
    _make(src8, 8192)
    if not src16.exists():
        _make(src16, 16384)
    rows = []
    for _ in range(repeats):
        read = _child(_BLENDER, src8, "read")
        lit = _child(_BLENDER, src8, "lit")
        rows.append({"read_s": read["times"]["read"], "lit_s": lit["times"]["lit"]})
    peak16 = _child(_BLENDER, src16, "lit")
    return {"rows": rows, "peak16": peak16["peak"], "lit16_s": peak16["times"]["lit"]}


_BATCH = """
import sys, time
if sys.argv[3] != "-":  # a checkout of an earlier commit, measured in the same run
    sys.path.insert(0, sys.argv[3])
    for name in [m for m in sys.modules if m.startswith("panolight_core")]:
        del sys.modules[name]
from panolight_core.apps.cli import main
t = time.perf_counter()
rc = main(["batch", sys.argv[1], "-o", sys.argv[2], "-q", "--overwrite"] + sys.argv[4:])
print("TIME batch", time.perf_counter() - t)
"""


def bench_batch(tmp: Path, count: int, repeats: int, extra: list[str], before: str | None) -> dict:
    """Seconds per run of this checkout's batch and (with ``before``, a checkout of an earlier commit)
    the earlier code's, interleaved."""
    folder = tmp / "batch_in"
    folder.mkdir(exist_ok=True)
    _make(folder, 1024, count)
    times = {"now": [], "before": []}
    for k in range(repeats):
        times["now"].append(_child(_BATCH, folder, tmp / f"batch_out{k}", "-", *extra)["times"]["batch"])
        if before:
            times["before"].append(_child(_BATCH, folder, tmp / f"batch_before{k}", before)["times"]["batch"])
    return times


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--parts", nargs="+", choices=("cli", "blender", "batch"), default=["cli", "blender", "batch"])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--batch-count", type=int, default=200)
    ap.add_argument("--batch-args", nargs=argparse.REMAINDER, default=[],
                    help="extra arguments for panolight batch (e.g. --outputs lighting)")
    ap.add_argument("--before", metavar="CHECKOUT",
                    help="a checkout of the commit before the scale work (git worktree add /tmp/before b8df6d8): "
                         "its batch is measured in the same run, interleaved, instead of the recorded rate")
    ap.add_argument("--json", help="also write the raw numbers here")
    args = ap.parse_args(argv)
    med = statistics.median
    gb = 1e9
    lines = ["| measurement | PanoLight | peer | ratio | target | met |", "|---|---:|---:|---:|---:|---|"]
    raw = {}
    with tempfile.TemporaryDirectory() as t:
        tmp = Path(t)
        if "cli" in args.parts:
            rows = raw["cli"] = bench_cli(tmp, args.repeats)
            est, dec = med(r["estimate_s"] for r in rows), med(r["decode_s"] for r in rows)
            peak = max(r["estimate_peak"] for r in rows) / gb
            lines.append(f"| CLI estimate, 16K JPEG (s) | {est:.2f} | Pillow decode {dec:.2f} | {est / dec:.2f}x | "
                         f"<= {TARGETS['cli_time']}x | {'yes' if est / dec <= TARGETS['cli_time'] else 'no'} |")
            nohdr = med(r["nohdr_s"] for r in rows)
            lines.append(f"| CLI estimate --outputs lighting,previews (no hdr.exr), 16K JPEG (s) | {nohdr:.2f} | "
                         f"Pillow decode {dec:.2f} | {nohdr / dec:.2f}x | <= {TARGETS['cli_time']}x | "
                         f"{'yes' if nohdr / dec <= TARGETS['cli_time'] else 'no'} |")
            lines.append(f"| CLI peak memory, 16K JPEG (GB) | {peak:.2f} | Pillow decode "
                         f"{max(r['decode_peak'] for r in rows) / gb:.2f} | | <= {TARGETS['cli_peak_gb']} | "
                         f"{'yes' if peak <= TARGETS['cli_peak_gb'] else 'no'} |")
            clipped = max(r["clipped_peak"] for r in rows) / gb
            lines.append(f"| CLI peak memory, 16K JPEG with 6.4 M clipped pixels (GB) | {clipped:.2f} | | | "
                         f"<= {TARGETS['cli_peak_gb']} | {'yes' if clipped <= TARGETS['cli_peak_gb'] else 'no'} |")
        if "blender" in args.parts:
            b = raw["blender"] = bench_blender(tmp, args.repeats)
            lit, read = med(r["lit_s"] for r in b["rows"]), med(r["read_s"] for r in b["rows"])
            lines.append(f"| Blender load + estimate + build, 8K JPEG (s) | {lit:.2f} | one pixel read {read:.2f} | "
                         f"{lit / read:.2f}x | <= {TARGETS['blender_time']}x | "
                         f"{'yes' if lit / read <= TARGETS['blender_time'] else 'no'} |")
            lines.append(f"| Blender peak memory, 16K JPEG (GB) | {b['peak16'] / gb:.2f} | | | "
                         f"<= {TARGETS['blender_peak_gb']} | {'yes' if b['peak16'] / gb <= TARGETS['blender_peak_gb'] else 'no'} |")
        if "batch" in args.parts:
            times = raw["batch"] = bench_batch(tmp, args.batch_count, args.repeats, args.batch_args, args.before)
            rate = args.batch_count / med(times["now"])
            base = args.batch_count / med(times["before"]) if times["before"] else BATCH_BASELINE_PER_S
            how = "measured in this run" if times["before"] else "recorded"
            lines.append(f"| batch, {args.batch_count} JPEGs of 1024 x 512 (inputs / s) | {rate:.1f} | before "
                         f"({how}) {base:.1f} | {rate / base:.2f}x | >= {TARGETS['batch_speedup']}x | "
                         f"{'yes' if rate / base >= TARGETS['batch_speedup'] else 'no'} |")
    print("\n".join(lines))
    if args.json:
        Path(args.json).write_text(json.dumps(raw, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
