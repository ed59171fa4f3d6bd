"""Tabulate Mitsuba 3.9's ``sunsky`` emitter (Hosek-Wilkie sky and solar radiance from one atmosphere)
into the small array file the core's clear-sky model reads with numpy alone
(``panolight_core/models/sky.safetensors``; ``panolight_core.estimators.sky``).

For each sun elevation e (degrees) and turbidity T (ground albedo fixed at SKY_ALBEDO):
  sky   (E, T, NTHETA, NPHI, 3)  linear RGB sky radiance at view zenith angle theta (0..90 degrees) and
                                 azimuth phi from the sun's azimuth (0..180 degrees; the sky is symmetric)
  sun   (E, T, 3)                the solar disk's RGB energy: radiance integrated over its solid angle
                                 (radiance units x sr; Mitsuba's default 0.5358 degree aperture)
The scale is Mitsuba's (sun_scale = sky_scale = 1); only ratios matter to the core, which fits a scale.

    python -m training.keylight.sky_table [--out panolight_core/models/sky.safetensors]
"""
from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np

ELEVATIONS = (0.5, 2.0, 4.0, 7.0, 10.0, 14.0, 19.0, 25.0, 32.0, 40.0, 50.0, 60.0, 72.0, 85.0)
TURBIDITIES = (1.7, 2.0, 2.5, 3.0, 4.0, 5.0, 6.5, 8.0, 10.0)
NTHETA, NPHI = 31, 46  # 3 degree zenith steps, 4 degree azimuth steps
SKY_ALBEDO = 0.3
SUN_APERTURE_DEG = 0.5358  # Mitsuba's default solar disk diameter
OUT = Path(__file__).resolve().parents[2] / "panolight_core" / "models" / "sky.safetensors"


def _direction(theta, phi, sun_azimuth=0.0):
    """Z-up unit vector at zenith angle theta and azimuth phi (radians); the sun at azimuth 0 (+X)."""
    theta, phi = np.broadcast_arrays(np.asarray(theta, float), np.asarray(phi, float) + sun_azimuth)
    return np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)], -1)


def tabulate(elevations=ELEVATIONS, turbidities=TURBIDITIES, log=print) -> dict:
    import mitsuba as mi

    mi.set_variant("scalar_rgb")  # LLVM may be unusable here (CONVENTIONS.md); the table is small
    theta = np.radians(np.linspace(0.0, 90.0, NTHETA))
    theta[-1] = math.radians(89.9)  # Hosek-Wilkie is undefined exactly at the horizon
    phi = np.radians(np.linspace(0.0, 180.0, NPHI))
    views = _direction(theta[:, None], phi[None, :]).reshape(-1, 3)
    # the solar disk: a polar grid over the aperture, each sample weighted by its solid angle
    half = math.radians(0.5 * SUN_APERTURE_DEG)
    nr, na = 24, 32
    r_edges = np.linspace(0.0, half * 0.999, nr + 1)
    r_mid = 0.5 * (r_edges[:-1] + r_edges[1:])
    ring_sr = 2.0 * math.pi * (np.cos(r_edges[:-1]) - np.cos(r_edges[1:])) / na
    sky = np.zeros((len(elevations), len(turbidities), NTHETA, NPHI, 3), np.float32)
    sun = np.zeros((len(elevations), len(turbidities), 3), np.float64)
    si = mi.SurfaceInteraction3f()
    t0 = time.perf_counter()
    for i, e in enumerate(elevations):
        s = _direction(math.radians(90.0 - e), 0.0)
        # an orthonormal frame around the sun for the disk samples
        a = np.cross(s, [0.0, 0.0, 1.0])
        a /= np.linalg.norm(a)
        b = np.cross(s, a)
        for j, t in enumerate(turbidities):
            em = mi.load_dict({"type": "sunsky", "sun_direction": s.tolist(), "turbidity": float(t),
                               "albedo": SKY_ALBEDO})
            vals = np.zeros((views.shape[0], 3))
            for k, v in enumerate(views):
                si.wi = mi.Vector3f(*(-v))
                vals[k] = np.asarray(em.eval(si))
            sky[i, j] = vals.reshape(NTHETA, NPHI, 3)
            energy = np.zeros(3)
            for r, om in zip(r_mid, ring_sr):
                for ang in (np.arange(na) + 0.5) * 2.0 * math.pi / na:
                    d = math.cos(r) * s + math.sin(r) * (math.cos(ang) * a + math.sin(ang) * b)
                    si.wi = mi.Vector3f(*(-d))
                    energy += np.asarray(em.eval(si)) * om
            si.wi = mi.Vector3f(*(-s))
            centre = np.asarray(em.eval(si)) * 2.0 * math.pi * (1.0 - math.cos(half))
            if not np.allclose(energy, centre, rtol=0.1):  # seen once: a run whose disk samples missed the sun
                raise RuntimeError(f"sunsky at elevation {e} turbidity {t}: the solar disk's samples ({energy}) "
                                   f"disagree with its centre ({centre}); run the tabulation again")
            sun[i, j] = energy
        log(f"sky table: elevation {e:g} done ({time.perf_counter() - t0:.0f} s)")
    return {"sky": sky, "sun": sun.astype(np.float32),
            "elevations": np.asarray(elevations, np.float32), "turbidities": np.asarray(turbidities, np.float32)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m training.keylight.sky_table", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=Path, default=OUT, help="where to write the table (default: %(default)s)")
    args = ap.parse_args(argv)
    import mitsuba
    from safetensors.numpy import save_file

    tables = tabulate()
    meta = {"source": f"mitsuba {mitsuba.__version__} sunsky (Hosek-Wilkie), scalar_rgb",
            "albedo": str(SKY_ALBEDO), "sun_aperture_deg": str(SUN_APERTURE_DEG),
            "theta_deg": json.dumps([0.0, 90.0, NTHETA]), "phi_deg": json.dumps([0.0, 180.0, NPHI]),
            "command": "python -m training.keylight.sky_table"}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    save_file(tables, str(args.out), metadata=meta)
    print(f"wrote {args.out} ({args.out.stat().st_size / 1e6:.2f} MB)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
