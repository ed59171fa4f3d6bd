"""What a user sees of a restored HDR: ``panolight estimate``'s own preview (input | SH radiance and lights | a white
sphere under them) of real scenes clipped at +STOPS over the JPEG's white, taken as they are (``--restore none``),
restored (the default), and of their un-clipped truth, one strip each under a caption, stacked into one picture
(docs/studies/captures.md, "What a user sees"). Prints each strip's dominant-source energy ratio r (on hdr.exr) and
shadow contrast C against the truth's. The shipped models saw these scenes in training: a picture of the product,
not a cross-validated score (docs/studies/captures.json has those).

    python -m training.experiments.restore_previews [--scenes noon_grass quarry_01] [--stops 4]
        [--out docs/studies/restore_previews.jpg]
"""
from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

from panolight_core import metrics
from panolight_core.apps.cli import main as cli
from panolight_core.camera import auto_exposure
from panolight_core.io import read_image, write_image
from training.common.real_hdri import DEFAULT_HDRI, load_hdr
from training.keylight.captures import score

CAPTION = 18  # rows of the white band above each strip


def strips(hdri: Path, scene: str, stops: float, work: Path) -> list[tuple[str, np.ndarray]]:
    """(caption, preview) of one scene: clipped as it is, clipped and restored, the truth."""
    path = next(p for p in sorted(hdri.iterdir()) if p.stem == scene)
    hdr = load_hdr(path)
    truth = hdr * auto_exposure(hdr, 0.0)
    ds = metrics.dominant_source(hdr)
    clipped = write_image(work / f"{scene}_clipped.exr", np.minimum(truth, 2.0 ** stops).astype(np.float32))
    whole = write_image(work / f"{scene}_truth.exr", truth.astype(np.float32))
    out = []
    for caption, src, restore in ((f"{scene}: clipped at +{stops:g} stops, as it is (--restore none)", clipped,
                                   "none"),
                                  (f"{scene}: clipped at +{stops:g} stops, restored (default)", clipped, "auto"),
                                  (f"{scene}: the un-clipped truth", whole, "auto")):
        dst = work / f"{scene}_{len(out)}"
        if cli(["estimate", str(src), "-o", str(dst), "-q", "--restore", restore]) != 0:
            raise SystemExit(f"restore_previews: panolight estimate failed on {src}")
        got = score(truth, ds, read_image(src), restore=restore)  # the numbers of the same estimate, in process
        print(f"| {caption} | {got['ratio']:.2f} | {got['contrast']:.2f} | "
              f"{metrics.true_shadow_contrast(hdr, ds['direction']):.2f} |")
        out.append((caption, read_image(dst / "preview.png", equirect=False, ldr_as_uint8=True)))
    return out


def sheet(rows: list[tuple[str, np.ndarray]]) -> np.ndarray:
    """The strips stacked, each under a white band with its caption."""
    from PIL import Image, ImageDraw

    width = max(img.shape[1] for _, img in rows)
    parts = []
    for caption, img in rows:
        band = Image.new("RGB", (width, CAPTION), (255, 255, 255))
        ImageDraw.Draw(band).text((4, 3), caption, fill=(0, 0, 0))
        parts += [np.asarray(band), np.pad(img, ((0, 0), (0, width - img.shape[1]), (0, 0)), constant_values=255)]
    return np.concatenate(parts, axis=0)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m training.experiments.restore_previews", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--hdri", type=Path, default=DEFAULT_HDRI, help="folder of real HDR panoramas (default: %(default)s)")
    ap.add_argument("--scenes", nargs="+", default=["noon_grass", "quarry_01"])
    ap.add_argument("--stops", type=float, default=4.0)
    ap.add_argument("--out", type=Path, default=None, help="write the picture here (JPEG)")
    args = ap.parse_args(argv)
    print("| strip | r (within 5 deg of the truth's source) | C | the truth's C |\n|---|---:|---:|---:|")
    with tempfile.TemporaryDirectory() as tmp:
        rows = [row for scene in args.scenes for row in strips(args.hdri, scene, args.stops, Path(tmp))]
    if args.out:
        from PIL import Image

        Image.fromarray(sheet(rows)).save(args.out, quality=88)
        print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
