"""Experiment (issue 46, "one account of a clipped region's energy"): a clear-sky sun takes its whole region's
decided energy as the light, instead of its fit's (capped) energy with the rest left in the region's fill.

Today a clear-sky sun carries ``keylight.key_energy`` ("hybrid": its fit, capped at the larger of the trees' mean
and the decided fill, floored at the fit's low end where trusted) and the region keeps the decided energy beyond
it as fill, which the SH spreads: the light may hold half the region and the SH the other half, while hdr.exr
puts the fill next to the sun. Here the light takes max(hybrid, the decided energy) (for a trusted sun the decided
energy capped at its fit's high end, as its fill is), so the region's fill is empty: lighting.json, hdr.exr and
Blender's lamps hold one compact amount. The region's energy, and so the work map, are unchanged.

Scored by the key-light cross-validation (``training.keylight.cv``: direction, r, the shadow contrast C and the
whole model's m-RMSE against naive), with the same options:

    python -m training.experiments.one_account --fold-models 'runs/folds/sources_{k}.safetensors' --out runs/one_account.json
"""
from __future__ import annotations

import contextlib
import sys

from panolight_core.estimators import keylight


@contextlib.contextmanager
def one_account():
    """``keylight.key_energy`` as this experiment weighs a clear-sky sun, for the ``with`` block."""
    shipped = keylight.key_energy

    def whole(physical, learned, decided, trusted, params=keylight.PARAMS):
        energy = shipped(physical, learned, decided, trusted, params)
        if physical is None:
            return energy
        return max(energy, min(decided, physical * params.sky_spread) if trusted else decided)

    keylight.key_energy = whole
    try:
        yield
    finally:
        keylight.key_energy = shipped


def main(argv=None) -> int:
    from training.keylight import cv

    with one_account():
        return cv.main(argv)


if __name__ == "__main__":
    sys.exit(main())
