"""Digests of the shipped estimates over the real HDRs: a refactoring's proof that nothing changed.

For every panorama of ../shared/data/hdri (MANIFEST order) and each ev, the EVALUATION.md camera JPEG (q90) is
estimated with the default settings (``pipeline.estimate_lighting``), and two SHA-256 digests are kept: of
the lighting document without its timings (coefficients, lights, the estimator's account) and of the full-
resolution ``hdr.exr`` panorama's float32 rows. ``--compare`` re-runs and lists every estimate whose digest
differs (exit 1 if any).

    python -m training.digests --out runs/digests.json              # before the change
    python -m training.digests --compare runs/digests.json          # after it: bitwise equal, or which differ
"""
from __future__ import annotations

import argparse
import hashlib
import json
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


def _document_digest(doc: dict) -> str:
    return hashlib.sha256(json.dumps(_without_timings(doc), sort_keys=True, default=str).encode()).hexdigest()


def _hdr_digest(result, ldr) -> str:
    h = hashlib.sha256()
    for first, block in result.hdr_blocks(ldr):
        h.update(str(first).encode() + np.ascontiguousarray(block, dtype=np.float32).tobytes())
    return h.hexdigest()


def digests(folder: Path, evs, log=print) -> dict:
    """{"SCENE@EV": {"lighting": sha256, "hdr": sha256}} over the folder's panoramas."""
    from training.source_energy.fit import load_hdr, scene_files

    out = {}
    files = scene_files(folder)
    t0 = time.perf_counter()
    for n, path in enumerate(files, 1):
        hdr = load_hdr(path)
        for ev in evs:
            ldr = hdr_to_ldr(hdr, ev, 90)
            res = estimate_lighting(ldr, Settings())
            out[f"{path.stem}@{ev:g}"] = {"lighting": _document_digest(res.document), "hdr": _hdr_digest(res, ldr)}
        log(f"  {n}/{len(files)} {path.stem} ({time.perf_counter() - t0:.0f} s)")
    return out


def main(argv=None) -> int:
    from training.source_energy.fit import DEFAULT_HDRI

    ap = argparse.ArgumentParser(prog="python -m training.digests", description=__doc__.split("\n\n")[0])
    ap.add_argument("--hdri", type=Path, default=DEFAULT_HDRI, help="folder of real HDR panoramas")
    ap.add_argument("--evs", type=float, nargs="+", default=[-2.0, 0.0, 2.0], help="exposures (default -2 0 2)")
    group = ap.add_mutually_exclusive_group(required=True)
    group.add_argument("--out", type=Path, help="write the digests here (JSON)")
    group.add_argument("--compare", type=Path, help="compare against digests written earlier")
    args = ap.parse_args(argv)
    found = digests(args.hdri, args.evs, log=lambda m: print(m, file=sys.stderr))
    if args.out:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps(found, indent=1, sort_keys=True) + "\n")
        print(f"{len(found)} estimates -> {args.out}", file=sys.stderr)
        return 0
    before = json.loads(args.compare.read_text())
    differ = sorted(k for k in before.keys() | found.keys() if before.get(k) != found.get(k))
    for k in differ:
        what = [part for part in ("lighting", "hdr") if (before.get(k) or {}).get(part) != (found.get(k) or {}).get(part)]
        print(f"differs: {k} ({', '.join(what)})")
    print(f"{len(found) - len(differ)} of {len(found)} estimates bitwise equal", file=sys.stderr)
    return 1 if differ else 0


if __name__ == "__main__":
    raise SystemExit(main())
