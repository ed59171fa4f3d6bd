"""Whether a bracket set's frames agree with their exposures (``camera.agreement.frame_agreement``), over the real
HDRs: each scene's camera JPEGs (q90, EVALUATION.md's camera and three other tone curves, ``camera.TONE_CURVES``)
at {-2, 0, +2} and {-4, -2, 0, +2, +4}, each frame against its neighbour in exposure (the pairs the check compares),
as a set is taken and as a set goes wrong:

- right: the exposures the frames were shot at; and the same with the brighter frame 1 or 2 pixels off (what the
  alignment leaves of a hand-held set's move);
- reversed: the frames in the opposite order to their exposures (the files listed the other way round);
- steps halved / doubled: a set shot 1 stop apart told 2 (``--evs=-2,0,2``), and one shot 2 apart told 1;
- one stop off: the +2 frame shot at +3;
- one exposure listed as two: the ev-0 frame and one shot 0.05 stops over it, listed a stop apart (a camera's auto
  ISO undoing a bracket's step: four real sets);
- another scene: the ev -2 and +2 frames of the next scene of the same size (a set grouped across two scenes).

Prints, by case and curve, the pairs the merge refuses (``camera.agreement._verdict``), and the share of
contradicting blocks, the rank correlation and the share of crossing steps (median, and the worst for the check: the
right sets' largest and smallest, the wrong ones' opposite), where the refusal's thresholds
(``BAD_SET_CONTRADICTING``, ``BAD_SET_RANK``, ``BAD_SET_CROSSING``) stand between them; and the stops off through
sRGB, which a test of the exposures' values would read: a camera's own curve moves it as far as a wrong exposure does
(the exponential ambiguity of a response curve), so no such test ships.

    python -m training.experiments.bracket_agreement [--out docs/studies/bracket_agreement.json]
    python -m training.experiments.bracket_agreement --sets --out docs/studies/bracket_sets.json   # one wrong frame
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from panolight_core.camera import hdr_to_ldr
from panolight_core.camera.agreement import (
    AGREE_CODES,
    BAD_SET_CONTRADICTING,
    BAD_SET_CROSSING,
    BAD_SET_RANK,
    FLAT_STEP_CODES,
    MIN_AGREE_BLOCKS,
    Agreement,
    _verdict,
    frame_agreement,
)
from panolight_core.camera.brackets import shift_frame
from panolight_core.camera.color import SRGB8_TO_LINEAR
from training.common.real_hdri import DEFAULT_HDRI, load_hdr, scene_files
from training.common.study import save_study

CURVES = (("srgb", None), ("contrast", 1.6), ("gamma", 2.8), ("shoulder", 4.0))


def frames_of(hdr, evs, curve) -> dict:
    return {ev: hdr_to_ldr(hdr, ev, 90, curve=curve[0], curve_param=curve[1]) for ev in evs}


def scene_rows(hdr, other, scene: str) -> list[dict]:
    """One scene's rows: each pair of frames a set's check compares (neighbours in exposure), as (case, curve, set,
    the pair's stated evs, contradicting, stops off through sRGB, compared, rank correlation); ``other``: another
    scene of its size (None: no such, and no "another scene" rows)."""
    rows = []
    for curve in CURVES:
        shot = frames_of(hdr, (-4, -3, -2, -1, 0, 1, 2, 3, 4), curve)
        elsewhere = frames_of(other, (-2, 2), curve) if other is not None else {}
        name = curve[0] if curve[1] is None else f"{curve[0]} {curve[1]:g}"
        cases = []  # (case, set, stated evs of the pair, the pair's frames as shown)
        for a, b in ((-4, -2), (-2, 0), (0, 2), (2, 4)):
            kind = "5 brackets" if 4 in (abs(a), abs(b)) else "3 brackets"
            cases.append(("right", kind, (a, b), shot[a], shot[b]))
            for dy, dx in ((1, 1), (2, 0)):  # what an alignment leaves of a hand-held set's move
                cases.append((f"right, {max(dy, dx)} px off", kind, (a, b), shot[a], shift_frame(shot[b], dy, dx)))
        cases += [("reversed", "3 brackets", (a, b), shot[-a], shot[-b]) for a, b in ((-2, 0), (0, 2))]
        cases += [("steps halved", "3 brackets", (a, b), shot[a // 2], shot[b // 2]) for a, b in ((-2, 0), (0, 2))]
        cases += [("steps doubled", "3 brackets", (a, b), shot[2 * a], shot[2 * b]) for a, b in ((-1, 0), (0, 1))]
        cases += [("one stop off", "3 brackets", (0, 2), shot[0], shot[3])]
        nudged = frames_of(hdr, (0.05,), curve)[0.05]  # a camera's auto ISO undid the step, a twentieth of a stop left
        # (four real sets' undone steps moved -5.4 to +1.6 codes: 0.05 stops moves 1-2)
        cases += [("one exposure listed as two", "3 brackets", (0, 1), shot[0], nudged)]
        cases += [("another scene", "3 brackets", tuple(sorted((0, ev))), *((f, shot[0]) if ev < 0 else (shot[0], f)))
                  for ev, f in elsewhere.items()]
        for case, kind, (a, b), darker, brighter in cases:
            agree = frame_agreement(darker, brighter, 2.0 ** (b - a))
            rows.append({"scene": scene, "case": case, "curve": name, "set": kind, "evs": [a, b],
                         "contradicting": agree.contradicting, "stops_off": srgb_stops_off(darker, brighter, b - a),
                         "compared": agree.compared, "rank_correlation": agree.rank_correlation,
                         "crossing": agree.crossing, "step_codes": agree.step_codes})
    return rows


SET_EVS = (-4, -2, 0, 2, 4)


def set_rows(hdr, other, scene: str) -> list[dict]:
    """``--sets``: what ``consistent_frames`` does with a whole 5-frame set ({-4 .. +4}, through sRGB and the
    contrast S-curve): as shot, and with each frame in turn taken from ``other`` at its exposure (a set grouped
    across two scenes). Each row: (scene, curve, the wrong frame's position or None, outcome): "kept whole",
    "left out the wrong frame", "left out a right frame", "refused"."""
    from panolight_core.camera.agreement import consistent_frames
    from panolight_core.errors import PanoLightError

    rows = []
    rel = np.array([2.0 ** ev for ev in SET_EVS])
    for curve in CURVES[:2]:
        name = curve[0] if curve[1] is None else f"{curve[0]} {curve[1]:g}"
        shot = [frames_of(hdr, (ev,), curve)[ev] for ev in SET_EVS]
        elsewhere = [frames_of(other, (ev,), curve)[ev] for ev in SET_EVS] if other is not None else None
        for wrong in [None] + (list(range(len(SET_EVS))) if elsewhere is not None else []):
            frames = [elsewhere[k] if k == wrong else f for k, f in enumerate(shot)]
            try:
                _, _, left = consistent_frames(frames, rel)
                out = {d["frame"] for d in left}
                outcome = ("kept whole" if not out else "left out the wrong frame" if out == {wrong}
                           else "left out a right frame")
            except PanoLightError:
                outcome = "refused"
            rows.append({"scene": scene, "curve": name, "wrong": wrong, "outcome": outcome})
    return rows


def set_summary(rows: list[dict]) -> list[str]:
    """The ``--sets`` table: by case (the set as shot; the wrong frame at each position) the count of each outcome."""
    outcomes = ("kept whole", "left out the wrong frame", "left out a right frame", "refused")
    lines = ["| set | sets | " + " | ".join(outcomes) + " |", "|---|---:|" + "---:|" * len(outcomes)]
    for wrong in [None] + list(range(len(SET_EVS))):
        sel = [r for r in rows if r["wrong"] == wrong]
        if sel:
            case = "as shot" if wrong is None else f"the {SET_EVS[wrong]:+d} EV frame of another scene"
            lines.append(f"| {case} | {len(sel)} | " + " | ".join(str(sum(r["outcome"] == o for r in sel))
                                                             for o in outcomes) + " |")
    return lines


def srgb_stops_off(darker: np.ndarray, brighter: np.ndarray, stops: float) -> float:
    """The median over the pixels both frames expose well (AGREE_CODES, brightest channel) of log2(the brighter
    frame's sRGB radiance over the darker's) less the stated ``stops``: what a test of the exposures' values would
    read, were every camera's curve sRGB (0 for a right sRGB set)."""
    a, b = (np.maximum(np.maximum(f[..., 0], f[..., 1]), f[..., 2]) for f in (darker, brighter))
    lo, hi = AGREE_CODES
    both = (a >= lo) & (a <= hi) & (b >= lo) & (b <= hi)
    if not both.any():
        return 0.0
    lin = SRGB8_TO_LINEAR.astype(np.float64)
    return float(np.median(np.log2(lin[b[both]] / lin[a[both]]))) - stops


def refused(row: dict) -> bool:
    """Whether the merge refuses the pair of ``row`` (``camera.agreement._verdict``, the shipped thresholds)."""
    agree = Agreement(row["contradicting"], row["rank_correlation"], row["compared"], row.get("crossing"),
                      row.get("step_codes"))
    return _verdict(agree, "darker", "brighter", float(row["evs"][1] - row["evs"][0])) is not None


def refused_by_rank(row: dict) -> bool:
    """Whether the check before session 54 refused the pair (the rank alone said "another scene")."""
    rho = row["rank_correlation"]
    return row["compared"] >= MIN_AGREE_BLOCKS and (row["contradicting"] > BAD_SET_CONTRADICTING
                                                    or (rho is not None and rho < BAD_SET_RANK))


def summary(rows: list[dict]) -> list[str]:
    """The table: by case and curve, the pairs refused, and each measure's median and worst case for the check
    (the right sets' largest contradicting share and smallest correlation, the wrong ones' opposite)."""
    lines = ["| case | curve | pairs | refused (by the rank alone) | contradicting: median, worst "
             "| rank correlation: median, worst "
             "| crossing steps: median, worst | codes a stop moves: median, worst "
             "| stops off through sRGB: median, worst |",
             "|---|---|---:|---:|---:|---:|---:|---:|---:|"]
    for case in dict.fromkeys(r["case"] for r in rows):
        for curve in dict.fromkeys(r["curve"] for r in rows):
            sel = [r for r in rows if r["case"] == case and r["curve"] == curve]
            c = np.array([r["contradicting"] for r in sel if r["compared"] >= MIN_AGREE_BLOCKS])
            rho = np.array([r["rank_correlation"] for r in sel
                            if r["compared"] >= MIN_AGREE_BLOCKS and r["rank_correlation"] is not None])
            cross = np.array([r["crossing"] for r in sel
                              if r["compared"] >= MIN_AGREE_BLOCKS and r.get("crossing") is not None])
            off = np.abs([r["stops_off"] for r in sel])
            moves = np.array([r["step_codes"] / (r["evs"][1] - r["evs"][0]) for r in sel
                              if r["compared"] >= MIN_AGREE_BLOCKS and r.get("step_codes") is not None])
            right = case.startswith("right")
            lines.append(f"| {case} | {curve} | {len(sel)} | {sum(map(refused, sel))} "
                         f"({sum(map(refused_by_rank, sel))}) | "
                         f"{np.median(c):.3f}, {(c.max() if right else c.min()):.3f} | "
                         f"{np.median(rho):.3f}, {(rho.min() if right else rho.max()):.3f} | "
                         + (f"{np.median(cross):.3f}, {(cross.max() if right else cross.min()):.3f} | " if cross.size
                            else "n/a | ")
                         + (f"{np.median(moves):.1f}, {(moves.min() if right else moves.max()):.1f} | " if moves.size
                            else "n/a | ") +
                         f"{np.median(off):.2f}, {(off.max() if right else off.min()):.2f} |")
    return lines


def evidence(rows: list[dict], table: list[str]) -> dict:
    """What the study keeps (its 7,000 rows are made again in minutes): the table, the right pairs nearest the
    thresholds (the 10 with the most contradicting pixels and the 10 ranked least alike) and every wrong pair of
    another order or scene the check lets through, each row's measures rounded."""
    def short(row):
        return {k: round(v, 4) if isinstance(v, float) else v for k, v in row.items()}
    right = [r for r in rows if r["case"].startswith("right") and r["compared"] >= MIN_AGREE_BLOCKS]
    ranked = [r for r in right if r["rank_correlation"] is not None]
    return {"table": table, "thresholds": {"contradicting": BAD_SET_CONTRADICTING, "rank": BAD_SET_RANK,
                                           "crossing": BAD_SET_CROSSING, "flat_step_codes": FLAT_STEP_CODES,
                                           "min_blocks": MIN_AGREE_BLOCKS},
            "right_most_contradicting": [short(r) for r in sorted(right, key=lambda r: -r["contradicting"])[:10]],
            "right_least_alike": [short(r) for r in sorted(ranked, key=lambda r: r["rank_correlation"])[:10]],
            "wrong_passed": [short(r) for r in rows if r["case"] in ("reversed", "another scene",
                                                                     "one exposure listed as two") and not refused(r)]}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m training.experiments.bracket_agreement", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--hdri", type=Path, default=DEFAULT_HDRI)
    ap.add_argument("--out", type=Path, default=None)
    ap.add_argument("--sets", action="store_true",
                    help="whole 5-frame sets instead of pairs: as shot, and with one frame of another scene at each "
                         "position; what consistent_frames keeps, leaves out or refuses")
    args = ap.parse_args(argv)
    files = scene_files(args.hdri)
    rows = []
    hdrs = {p: load_hdr(p) for p in files}
    for i, path in enumerate(files):
        other = next((hdrs[q] for q in files[i + 1:] + files[:i] if hdrs[q].shape == hdrs[path].shape),
                     None)  # a set's frames have one size
        rows += (set_rows if args.sets else scene_rows)(hdrs[path], other, path.stem)
        print(f"[{i + 1}/{len(files)}] {path.stem}", flush=True)
    if args.sets:
        table = set_summary(rows)
        print("\n".join(table))
        save_study({"table": table, "rows": rows}, args.out)
        return 0
    table = summary(rows)
    print("\n".join(table))
    save_study(evidence(rows, table), args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
