"""Digests of the shipped estimates over the real HDRs: a refactoring's proof that nothing changed.

For every panorama of ../shared/data/hdri (MANIFEST order) and each ev, the EVALUATION.md camera JPEG (q90), the
HDR itself clipped 4 stops over its ev-0 white (a file that clips its sun: restored), and each 8-bit photo of
../shared/data/ldr are estimated with the default settings (``pipeline.estimate_lighting``), and kept: the lighting document without
its timings (coefficients, lights, the estimator's account), and the SHA-256 and per-channel float64 sums of the
full-resolution ``hdr.exr`` panorama's float32 rows. ``--compare`` re-runs and sorts every estimate into
bitwise equal, equal to rounding (every number within RTOL: the same code run twice differs in the last bit in
a few estimates, as numpy's SIMD sums vary with the arrays' memory alignment), or different (exit 1 if any).

    python -m training.digests --out runs/digests.json              # before the change
    python -m training.digests --compare runs/digests.json          # after it: bitwise equal, or which differ
    panolight eval -o runs/eval && python -m training.digests --eval docs/eval/eval.json runs/eval/eval.json
                                                                    # every number of panolight eval but its timings
"""
from __future__ import annotations

import argparse
import hashlib
import json
import re
import sys
import time
from pathlib import Path

import numpy as np

from panolight_core.camera import hdr_to_ldr
from panolight_core.pipeline.estimate import estimate_lighting
from panolight_core.pipeline.settings import Settings


def _without_timings(doc):
    """The document without its wall-clock times ("timings", and every "*_s" key: model.fit_s, ...)."""
    if isinstance(doc, dict):
        return {k: _without_timings(v) for k, v in doc.items() if k != "timings" and not k.endswith("_s")}
    if isinstance(doc, list):
        return [_without_timings(v) for v in doc]
    return doc


RTOL = 1e-12  # "equal to rounding": the last bits of a float64
_TIMING = re.compile(r"(^|_)(time|times|timings|seconds|speed|s|ms)(_|$)")  # eval.json's wall-clock keys


def _hdr_digest(result, ldr) -> tuple[str, list]:
    h = hashlib.sha256()
    sums = np.zeros((2, 3))
    for first, block in result.hdr_blocks(ldr):
        block = np.ascontiguousarray(block, dtype=np.float32)
        h.update(str(first).encode() + block.tobytes())
        b = block.reshape(-1, 3).astype(np.float64)
        sums += [b.sum(axis=0), (b * b).sum(axis=0)]
    return h.hexdigest(), sums.tolist()


def _close(a, b) -> bool:
    """Whether two JSON values are equal but for float rounding (RTOL)."""
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_close(a[k], b[k]) for k in a)
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(_close(x, y) for x, y in zip(a, b))
    if isinstance(a, float) and isinstance(b, float):
        return abs(a - b) <= RTOL * max(abs(a), abs(b))
    return a == b


CLIPPED_STOPS = 4.0  # each HDR also clipped this many stops over its ev-0 JPEG's white: the restoration's path


def _entry(pixels) -> dict:
    res = estimate_lighting(pixels, Settings())
    digest, sums = _hdr_digest(res, pixels)
    return {"lighting": json.loads(json.dumps(_without_timings(res.document), default=str)), "hdr": digest,
            "hdr_sums": sums}


def digests(folder: Path, evs, photos: Path | None = None, log=print) -> dict:
    """{"SCENE@EV" (its camera JPEG), "SCENE@clip+4" (the HDR clipped 4 stops over its JPEG's white: restored),
    "photo:NAME" (each 8-bit photo of ``photos``): {"lighting": document without timings, "hdr": sha256,
    "hdr_sums": [[sum], [sum of squares]]}} over the folder's panoramas."""
    from panolight_core.camera import auto_exposure
    from panolight_core.io import read_image
    from training.common.real_hdri import load_hdr, scene_files

    out = {}
    files = scene_files(folder)
    t0 = time.perf_counter()
    for n, path in enumerate(files, 1):
        hdr = load_hdr(path)
        for ev in evs:
            out[f"{path.stem}@{ev:g}"] = _entry(hdr_to_ldr(hdr, ev, 90))
        clipped = np.minimum(hdr * auto_exposure(hdr, 0.0), 2.0 ** CLIPPED_STOPS).astype(np.float32)
        out[f"{path.stem}@clip+{CLIPPED_STOPS:g}"] = _entry(clipped)
        log(f"  {n}/{len(files)} {path.stem} ({time.perf_counter() - t0:.0f} s)")
    for path in sorted(photos.glob("*.jpg")) if photos is not None and photos.is_dir() else ():
        out[f"photo:{path.name}"] = _entry(read_image(path, ldr_as_uint8=True))
        log(f"  {path.name} ({time.perf_counter() - t0:.0f} s)")
    return out


def eval_differences(before, after, path: str = "") -> list[str]:
    """Where two results (``panolight eval``'s eval.json, a study's JSON) differ beyond rounding (RTOL), wall-clock times left out
    (``_TIMING``: keys naming times, seconds, milliseconds or speed)."""
    if isinstance(before, dict) and isinstance(after, dict):
        return [d for k in sorted(before.keys() | after.keys())
                if not _TIMING.search(k)
                for d in eval_differences(before.get(k), after.get(k), f"{path}/{k}")]
    if isinstance(before, list) and isinstance(after, list) and len(before) == len(after):
        return [d for i, (a, b) in enumerate(zip(before, after)) for d in eval_differences(a, b, f"{path}[{i}]")]
    return [] if _close(before, after) else [f"{path}: {before!r} -> {after!r}"]


def model_differences(before: Path, after: Path) -> list[str]:
    """Where two safetensors model files differ: a tensor's name, shape or bits, or a metadata entry (the order
    of the header's keys aside, which the format leaves free)."""
    from safetensors import safe_open

    def read(path):
        with safe_open(str(path), "np") as f:
            return {k: f.get_tensor(k) for k in f.keys()}, dict(f.metadata() or {})

    (ta, ma), (tb, mb) = read(before), read(after)
    out = [f"tensor {k}" for k in sorted(ta.keys() | tb.keys())
           if k not in ta or k not in tb or ta[k].dtype != tb[k].dtype or not np.array_equal(ta[k], tb[k])]
    return out + [f"metadata {k}" for k in sorted(ma.keys() | mb.keys()) if ma.get(k) != mb.get(k)]


def main(argv=None) -> int:
    from training.common.real_hdri import DEFAULT_HDRI

    ap = argparse.ArgumentParser(prog="python -m training.digests", description=__doc__.split("\n\n")[0])
    ap.add_argument("--hdri", type=Path, default=DEFAULT_HDRI, help="folder of real HDR panoramas")
    ap.add_argument("--evs", type=float, nargs="+", default=[-2.0, 0.0, 2.0], help="exposures (default -2 0 2)")
    ap.add_argument("--photos", type=Path, default=DEFAULT_HDRI.parent / "ldr",
                    help="folder of 8-bit photos estimated too (default ../shared/data/ldr)")
    group = ap.add_mutually_exclusive_group(required=True)
    group.add_argument("--out", type=Path, help="write the digests here (JSON)")
    group.add_argument("--compare", type=Path, help="compare against digests written earlier")
    group.add_argument("--models", type=Path, nargs=2, metavar=("BEFORE", "AFTER"),
                       help="compare two safetensors models (tensors and metadata) instead: the same training made by "
                            "two versions of the code")
    group.add_argument("--eval", type=Path, nargs=2, metavar=("BEFORE", "AFTER"),
                       help="compare two result files instead, timings left out: panolight eval's eval.json, or a "
                            "study's JSON (keylight-cv's, the per-source CV's) made by two versions of the code")
    args = ap.parse_args(argv)
    if args.models:
        differ = model_differences(*args.models)
        for d in differ:
            print(f"differs: {d}")
        print(f"{args.models[1].name}: {'the same model' if not differ else f'{len(differ)} entries differ'}",
              file=sys.stderr)
        return 1 if differ else 0
    if args.eval:
        differ = eval_differences(*(json.loads(f.read_text()) for f in args.eval))
        for d in differ:
            print(f"differs: {d}")
        print(f"{args.eval[1].name}: {'the same numbers' if not differ else f'{len(differ)} numbers differ'}", file=sys.stderr)
        return 1 if differ else 0
    found = digests(args.hdri, args.evs, args.photos, log=lambda m: print(m, file=sys.stderr))
    if args.out:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps(found, indent=1, sort_keys=True) + "\n")
        print(f"{len(found)} estimates -> {args.out}", file=sys.stderr)
        return 0
    before = json.loads(args.compare.read_text())
    exact, rounding, differ = [], [], []
    for k in sorted(before.keys() | found.keys()):
        a, b = before.get(k), found.get(k)
        if a == b:
            exact.append(k)
        elif a is not None and b is not None and _close(a["lighting"], b["lighting"]) and \
                _close(a["hdr_sums"], b["hdr_sums"]):
            rounding.append(k)
        else:
            differ.append(k)
            what = [part for part in ("lighting", "hdr_sums") if not _close((a or {}).get(part), (b or {}).get(part))]
            print(f"differs: {k} ({', '.join(what)})")
    print(f"{len(found)} estimates: {len(exact)} bitwise equal, {len(rounding)} equal to rounding "
          f"({', '.join(rounding) or 'none'}), {len(differ)} different", file=sys.stderr)
    return 1 if differ else 0

if __name__ == "__main__":
    raise SystemExit(main())
