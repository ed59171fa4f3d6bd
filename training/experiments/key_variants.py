"""Experiments on what a key light carries (issue 46), each scored by the key-light cross-validation
(``training.keylight.cv``: direction, r, the shadow contrast C and the whole model's m-RMSE against naive):

- ``one-account``: a clear-sky sun takes its whole region's decided energy as the light, instead of its fit's
  (capped) energy with the rest left in the region's fill (which the SH spreads, while hdr.exr keeps it next to
  the sun): max(hybrid, the decided energy), for a trusted sun the decided energy capped at its fit's high end
  as its fill is. The region's energy, and so the work map, are unchanged.
- ``belief:DEG``: a trusted clear-sky sun placed within DEG degrees (its direction's 68 % radius) carries its fit's
  belief (the median of its 68 % range, x sky_correction), not the cautious capped energy; its region's fill
  gives way to it as for any light. ``belief:DEG:any``: any clear-sky sun so placed, low suns (under the trusted
  elevation) and wide patches included.

    python -m training.experiments.key_variants --variant one-account --fold-models 'runs/folds/sources_{k}.safetensors' --out runs/one.json
    python -m training.experiments.key_variants --variant belief:3 --fold-models ... --out runs/belief3.json
"""
from __future__ import annotations

import argparse
import contextlib
import math
import sys
from dataclasses import replace

from panolight_core.estimators import keylight
from panolight_core.estimators.keylight import find, weighing


@contextlib.contextmanager
def one_account():
    """``keylight.key_energy`` as ``one-account`` weighs a clear-sky sun, for the ``with`` block (``weighing.weigh``
    calls it)."""
    shipped = weighing.key_energy

    def whole(physical, learned, decided, trusted, params=keylight.PARAMS):
        energy = shipped(physical, learned, decided, trusted, params)
        if physical is None:
            return energy
        return max(energy, min(decided, physical * params.sky_spread) if trusted else decided)

    weighing.key_energy = whole
    try:
        yield
    finally:
        weighing.key_energy = shipped


@contextlib.contextmanager
def belief(within_deg: float, untrusted: bool = False):
    """``keylight.find_key_lights`` as ``belief:DEG`` (``untrusted``: ``belief:DEG:any``) weighs a sure sun, for the
    ``with`` block (``find.with_key_lights`` calls it)."""
    shipped = find.find_key_lights

    def sure(maps, regions, prediction, params=keylight.PARAMS, fits=None):
        keys = shipped(maps, regions, prediction, params, fits)
        return [replace(k, energy=k.physical) if (k.method.startswith("clear-sky") and (k.trusted or untrusted)
                                                  and k.physical and math.degrees(k.direction_68) <= within_deg) else k
                for k in keys]

    find.find_key_lights = sure
    try:
        yield
    finally:
        find.find_key_lights = shipped


def variant(text: str):
    """The context manager of a --variant: "one-account" or "belief:DEG"."""
    name, _, arg = text.partition(":")
    if name == "one-account" and not arg:
        return one_account()
    if name == "belief":
        deg, _, scope = arg.partition(":")
        try:
            if scope in ("", "any"):
                return belief(float(deg), scope == "any")
        except ValueError:
            pass
    raise SystemExit(f"--variant must be one-account, belief:DEG or belief:DEG:any (e.g. belief:3), got {text!r}")


def main(argv=None) -> int:
    from training.keylight import cv

    ap = argparse.ArgumentParser(prog="python -m training.experiments.key_variants", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter,
                                 epilog="Every other option is the key-light cross-validation's (python -m "
                                        "training.keylight.cv --help): --fold-models, --evs, --out, ...")
    ap.add_argument("--variant", required=True, metavar="NAME",
                    help="one-account, belief:DEG or belief:DEG:any (e.g. belief:3)")
    args, rest = ap.parse_known_args(argv)
    with variant(args.variant):
        return cv.main(rest)


if __name__ == "__main__":
    sys.exit(main())
