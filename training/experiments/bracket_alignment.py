"""How well ``camera.brackets.align_shift`` aligns a bracket set, over the real HDRs with an un-clipped truth: each
scene's EVALUATION.md camera JPEGs (q90) at {-4, -2, 0, +2, +4}, aligned onto the ev-0 frame

- as they are (a still set: every shift should be (0, 0));
- with every other frame moved by (--rows, --columns) (a 360 camera tipped and turned in the hand: every shift
  should be the opposite move).

    python -m training.experiments.bracket_alignment [--rows 2] [--columns -30] [--out docs/studies/bracket_alignment.json]
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from panolight_core.camera import hdr_to_ldr
from panolight_core.camera.brackets import align_shift, shift_frame
from training.common.real_hdri import DEFAULT_HDRI, clipped_truth, load_hdr, scene_files
from training.common.study import save_study

EVS = (-4.0, -2.0, 0.0, 2.0, 4.0)


def scene_shifts(path: Path, rows: int, columns: int) -> dict:
    """The shifts found for one scene's frames, still and moved (the ev-0 frame left out)."""
    hdr = load_hdr(path)
    frames = [(ev, hdr_to_ldr(hdr, ev, 90)) for ev in EVS]
    ref = frames[EVS.index(0.0)][1]
    width = ref.shape[1]
    still = {ev: align_shift(ref, f, 2.0 ** ev) for ev, f in frames if ev != 0.0}
    moved = {ev: align_shift(ref, shift_frame(f, rows, columns), 2.0 ** ev) for ev, f in frames if ev != 0.0}
    want = (-rows, (-columns) % width)
    return {"scene": path.stem, "still": {str(k): list(v) for k, v in still.items()},
            "moved": {str(k): list(v) for k, v in moved.items()},
            "still_ok": sum(v == (0, 0) for v in still.values()), "moved_ok": sum(v == want for v in moved.values())}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m training.experiments.bracket_alignment", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--hdri", type=Path, default=DEFAULT_HDRI)
    ap.add_argument("--rows", type=int, default=2)
    ap.add_argument("--columns", type=int, default=-30)
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)
    clipped = clipped_truth(args.hdri)
    rows = [scene_shifts(p, args.rows, args.columns) for p in scene_files(args.hdri) if p.name not in clipped]
    frames = 4 * len(rows)
    still = sum(r["still_ok"] for r in rows)
    moved = sum(r["moved_ok"] for r in rows)
    print(f"{len(rows)} scenes, {frames} frames aligned onto their ev-0 frame:")
    print(f"  still set: {still} of {frames} frames left where they are; off: "
          + ", ".join(f"{r['scene']} {r['still']}" for r in rows if r["still_ok"] < 4))
    print(f"  moved by ({args.rows}, {args.columns}): {moved} of {frames} frames put back exactly; scenes with a miss: "
          + ", ".join(r["scene"] for r in rows if r["moved_ok"] < 4))
    save_study({"rows": rows, "move": [args.rows, args.columns], "still_ok": still, "moved_ok": moved,
                "frames": frames}, args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
