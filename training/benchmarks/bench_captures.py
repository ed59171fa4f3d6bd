"""Accuracy against time, by capture (issue 45: "the user's trade between effort and accuracy"): how long each
kind of capture takes from its files to the estimate, beside how right it comes out.

Time: one real sunlit scene (../shared/data/hdri, upsampled 2x to 2048 x 1024) as each capture hands it to
``panolight estimate``, timed from the files to ``estimate_lighting``'s result (the default estimator; medians of
--repeats rounds after a warm-up, each round running every capture once in turn,
``training.benchmarks.interleaved_medians``, all in this process):

- one JPEG: EVALUATION.md's camera at ev 0 (q90);
- 3 and 5 brackets: the camera's JPEGs at {-2, 0, +2} and {-4 .. +4}, merged (``pipeline.brackets.read_brackets``);
- an HDR clipped at +2 / +4 / +6 stops over the JPEG's white: a float32 EXR (ZIP), restored;
- a RAW whose white is 2 stops over the JPEG's: a DNG (``io.dng``) decoded by LibRaw, restored.

Accuracy: the captures study's out-of-fold medians over the 43 dominant scenes (docs/studies/captures.json and
captures_raw.json: m-RMSE over the naive JPEG's, the dominant source's energy "within", its direction).

    python -m training.benchmarks.bench_captures [--scene noon_grass] [--repeats 5] [--plot docs/studies/captures_time.png]
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

from training.benchmarks import interleaved_medians

DOCS = Path(__file__).resolve().parents[2] / "docs" / "studies"
# capture -> its row in the captures study (docs/studies/captures.json, or captures_raw.json for the RAW)
STUDY_ROWS = {"one JPEG": "JPEG", "3 brackets": "3 brackets {-2, +0, +2}", "5 brackets": "5 brackets {-4, -2, +0, +2, +4}",
              "HDR clipped at +2 stops": "HDR clipped at +2 stops, restored",
              "HDR clipped at +4 stops": "HDR clipped at +4 stops, restored",
              "HDR clipped at +6 stops": "HDR clipped at +6 stops, restored",
              "RAW, white at +2 stops": "RAW, white at +2 stops, restored"}


def capture_readers(folder: Path, scene: str) -> dict:
    """{capture: a function from its files to the pixels ``estimate_lighting`` takes} for the scene at 2048 x 1024,
    its files written into ``folder``."""
    from panolight_core.camera import auto_exposure
    from panolight_core.io import read_image, write_image
    from panolight_core.io.dng import write_dng
    from panolight_core.io.read_raw import read_raw
    from panolight_core.pipeline.brackets import read_brackets
    from training.benchmarks.bench_restore import bracket_files, scene_2k

    hdr = scene_2k(scene)
    truth = (hdr * auto_exposure(hdr, 0.0)).astype(np.float32)
    evs = (-4, -2, 0, 2, 4)
    jpegs = dict(zip(evs, bracket_files(folder, scene, evs)[1]))
    readers = {"one JPEG": lambda: read_image(jpegs[0], ldr_as_uint8=True)}
    for evs in ((-2, 0, 2), (-4, -2, 0, 2, 4)):
        readers[f"{len(evs)} brackets"] = lambda evs=evs: read_brackets([jpegs[ev] for ev in evs], evs)[0]
    for stops in (2, 4, 6):
        path = write_image(folder / f"{scene}_clipped_{stops}.exr", np.minimum(truth, np.float32(2.0 ** stops)),
                           compression="zip")
        readers[f"HDR clipped at +{stops} stops"] = lambda path=path: read_image(path)
    dng = write_dng(folder / f"{scene}.dng", truth, scale=0.25, rng=np.random.default_rng(0))
    readers["RAW, white at +2 stops"] = lambda: read_raw(dng)[0]
    return readers


def study_rows(captures_json: Path, raw_json: Path) -> dict:
    """{study row name: its summary} from the captures study's JSON files (those present)."""
    out = {}
    for path in (captures_json, raw_json):
        if path.is_file():
            out.update(json.loads(path.read_text(encoding="utf-8"))["summary"])
    return out


def table(times: dict, summary: dict) -> list[str]:
    single = times["one JPEG"]
    lines = ["| capture | seconds, files to estimate | over one JPEG | m-RMSE / naive JPEG | energy within | "
             "direction |", "|---|---:|---:|---:|---:|---:|"]
    for name, t in times.items():
        s = summary.get(STUDY_ROWS[name])
        acc = (f"{s['m_rmse_over_naive_median']:.3f} | {s['energy_within']:.2f}x | {s['median_angle_deg']:.1f} deg"
               if s else "n/a | n/a | n/a")
        lines.append(f"| {name} | {t:.3f} | {t / single:.2f}x | {acc} |")
    return lines


def plot(times: dict, summary: dict, out: Path) -> Path:
    """Two panels against the time from files to estimate (log): m-RMSE over the naive JPEG's, and the dominant
    source's energy "within" (log), one marker per capture (the legend names them)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import FuncFormatter, NullFormatter

    names = [n for n in times if STUDY_ROWS[n] in summary]
    t = np.array([1000.0 * times[n] for n in names])
    style = {"one JPEG": ("#47a", "o"), "3 brackets": ("#47a", "s"), "5 brackets": ("#47a", "D"),
             "HDR clipped at +2 stops": ("#2a7", "^"), "HDR clipped at +4 stops": ("#2a7", "v"),
             "HDR clipped at +6 stops": ("#2a7", "P"), "RAW, white at +2 stops": ("#c63", "*")}
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.4))
    for ax, key, label, log in ((axes[0], "m_rmse_over_naive_median", "m-RMSE / naive JPEG (median; lower is better)",
                                 False),
                                (axes[1], "energy_within", "dominant source's energy within (x; 1 is exact)", True)):
        for x, n in zip(t, names):
            colour, marker = style[n]
            ax.scatter([x], [summary[STUDY_ROWS[n]][key]], color=colour, marker=marker, s=60, label=n)
        ax.set_xscale("log")
        if log:
            ax.set_yscale("log")
            ax.set_yticks([1.5, 2, 3, 5, 10, 15])
        for axis in (ax.xaxis, ax.yaxis):  # plain numbers, not powers of ten
            axis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
            axis.set_minor_formatter(FuncFormatter(lambda v, _: f"{v:g}") if axis is ax.xaxis else NullFormatter())
        ax.set_xlabel("ms from the files to the estimate, 2048 x 1024 (2-core CPU)")
        ax.set_title(label, fontsize=9)
        ax.grid(True, which="both", alpha=0.3)
    axes[1].legend(fontsize=8, loc="upper right")
    fig.suptitle("Accuracy (out of fold, 43 scenes with a dominant source) against time, by capture", fontsize=10)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m training.benchmarks.bench_captures", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene", default="noon_grass", help="a sunlit scene of ../shared/data/hdri (default: %(default)s)")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--captures", type=Path, default=DOCS / "captures.json", help="the captures study's JSON")
    ap.add_argument("--raw", type=Path, default=DOCS / "captures_raw.json", help="its RAW rows' JSON")
    ap.add_argument("--plot", type=Path, default=None, metavar="PNG", help="also draw accuracy against time here")
    args = ap.parse_args(argv)
    from panolight_core.pipeline.estimate import estimate_lighting

    with tempfile.TemporaryDirectory() as tmp:
        readers = capture_readers(Path(tmp), args.scene)
        times = interleaved_medians({name: (lambda r=read: estimate_lighting(r())) for name, read in readers.items()},
                                    args.repeats)
    summary = study_rows(args.captures, args.raw)
    print(f"{args.scene} at 2048 x 1024, medians of {args.repeats}")
    print("\n".join(table(times, summary)))
    if args.plot:
        print(f"wrote {plot(times, summary, args.plot)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
