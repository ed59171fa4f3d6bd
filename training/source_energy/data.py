"""The per-source model's training data: every real HDR seen through many cameras (yaw, mirror, white balance,
ev -3..3, tone curves, JPEG quality, input size; ``camera``), and each clipped region of each picture one row of
features and target (the natural log of true / held energy; ``region_rows``), built in parallel and cached
(``build_table``, ``cached_table``). ``fit.py`` fits the trees on them."""
from __future__ import annotations

import json
import os
import time
from pathlib import Path

import numpy as np

from panolight_core import sh, threads
from panolight_core.camera import auto_exposure, jpeg_roundtrip, lanczos_resize, tone_curve
from panolight_core.camera.ceiling import find_ceiling
from panolight_core.camera.color import LUMINANCE_WEIGHTS
from panolight_core.camera.resample import area_downsample
from panolight_core.estimators import sources
from panolight_core.estimators.sources.restore import Source
from training.common.real_hdri import load_hdr

RESAVE = 0.0  # the share of training cameras saved again (``camera``, ``--resave``): 0.35 improved the cross-validation
# at ev 0 and +2 at two seeds but weakened the real photos' key lights and over-lit the public city (docs/keylight.md)


def scene_view(hdr: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """The scene as one random camera frames it: turned (yaw), perhaps mirrored, white-balanced (gains of about
    8 %, luminance kept) and at 512, 1024 or 2048 wide."""
    p = np.roll(hdr, int(rng.integers(hdr.shape[1])), axis=1)
    if rng.random() < 0.5:
        p = p[:, ::-1]
    gains = np.exp(rng.normal(0.0, 0.08, 3))
    p = p * (gains / float(gains @ LUMINANCE_WEIGHTS))
    size = rng.choice([0, 1, 1, 2])  # 512, 1024, 1024, 2048 wide
    if size == 0:
        p = area_downsample(p, p.shape[0] // 2)
    elif size == 2:
        p = np.repeat(np.repeat(p, 2, axis=0), 2, axis=1)
    return p


HDR_STOPS = (1.0, 7.0)  # a clipped HDR camera's ceiling: 2^U(these) times the ev-0 JPEG's white


def clipped_hdr_camera(hdr: np.ndarray, rng: np.random.Generator):
    """A random HDR file that clips its own source (what ``sources.restore`` restores): the scene framed as by
    ``scene_view``, exposed at ev 0 and clipped per channel at 2^U(HDR_STOPS) times that white, as a merge shot
    without an ND filter clips its sun. Returns (float32 clipped file, exposed linear truth)."""
    p = scene_view(hdr, rng)
    truth = np.clip(auto_exposure(p, 0.0, robust=True) * p, 0.0, None)
    ceiling = 2.0 ** rng.uniform(*HDR_STOPS)
    return np.minimum(truth, ceiling).astype(np.float32), truth


def camera(hdr: np.ndarray, rng: np.random.Generator, inject: float = 0.0, resave: float = 0.0):
    """A random camera: returns (ldr uint8, exposed linear truth k P') where P' is the augmented scene.
    inject: the probability of adding a synthetic compact source first (``inject_source``; an experiment:
    0, the default, draws nothing extra, so the stream of cameras is unchanged). resave: the probability that
    the picture is saved again as a JPEG of quality 75-95, half the time made half as wide (Lanczos) first when it
    is at least 1024 wide: a second generation, as a web page or a chat makes of a photo (the per-source model
    trains with RESAVE = 0: 0.35 was tried and not kept; 0 draws nothing extra)."""
    p = scene_view(hdr, rng)
    if inject and rng.random() < inject:
        p = inject_source(p, rng)
    ev = float(rng.uniform(-3.0, 3.0))
    k = auto_exposure(p, ev, robust=True)
    x = np.clip(k * p, 0.0, None)
    curve = rng.random()
    if curve < 0.7:
        enc = tone_curve(x, "srgb")
    elif curve < 0.85:
        enc = tone_curve(x, "gamma", rng.uniform(1.8, 2.6))
    else:  # a soft shoulder reaching white at wp
        enc = tone_curve(x, "shoulder", rng.uniform(2.0, 8.0))
    ldr = np.round(enc * 255.0).astype(np.uint8)
    q = rng.choice([0, 75, 85, 90, 95])
    if q:
        ldr = jpeg_roundtrip(ldr, int(q))
    if resave and rng.random() < resave:
        if rng.random() < 0.5 and ldr.shape[1] >= 1024:
            ldr = lanczos_resize(ldr, ldr.shape[1] // 2, ldr.shape[0] // 2)
        ldr = jpeg_roundtrip(ldr, int(rng.choice([75, 85, 90, 95])))
    return ldr, k * p


def inject_source(p: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """p (H, W, 3) linear plus a synthetic compact source: a disk of angular radius 0.25-2 degrees
    (log-uniform) holding 5 %-300 % of the scene's energy, 10 % of it or less in a power-law glare halo
    (t^-q, q in 2..3, out to 30 degrees), above the horizon 70 % of the time, slightly tinted."""
    H, W = p.shape[:2]
    d = sh.pixel_directions(H, W)
    om = sh.pixel_solid_angles(H, W)
    z = rng.uniform(0.0, 1.0) if rng.random() < 0.7 else rng.uniform(-1.0, 1.0)
    phi = rng.uniform(0.0, 2.0 * np.pi)
    c = np.array([np.sqrt(1.0 - z * z) * np.cos(phi), np.sqrt(1.0 - z * z) * np.sin(phi), z])
    t = np.arccos(np.clip(d @ c, -1.0, 1.0))
    a = np.radians(np.exp(rng.uniform(np.log(0.25), np.log(2.0))))
    energy = np.exp(rng.uniform(np.log(0.05), np.log(3.0))) * float(((p @ LUMINANCE_WEIGHTS) * om).sum())
    halo_share = np.exp(rng.uniform(np.log(0.01), np.log(0.1)))
    q = rng.uniform(2.0, 3.0)
    disk = t <= max(a, float(t.min()))  # at least the nearest pixel
    prof = np.zeros_like(t)
    prof[disk] = (1.0 - halo_share) * energy / om[disk].sum()
    halo = (t > a) & (t < np.radians(30.0)) & ~disk
    if halo.any():
        w = t[halo] ** (-q)
        prof[halo] = halo_share * energy * w / (w * om[halo]).sum()
    color = np.exp(rng.normal(0.0, 0.1, 3))
    return p + prof[..., None] * (color / float(color @ LUMINANCE_WEIGHTS))


def region_rows(ldr: np.ndarray, truth: np.ndarray):
    """(features (n, F), target log ratio (n,), true share of scene energy (n,)) of one LDR."""
    rad, frac, frac_all = sources.work_maps(ldr)
    reg = sources.region_features(rad, frac, frac_all)
    if reg.count == 0:
        return np.zeros((0, len(sources.FEATURES))), np.zeros(0), np.zeros(0)
    target, share = region_targets(reg, truth)
    return reg.features, target, share


def hdr_region_rows(clipped: np.ndarray, truth: np.ndarray):
    """``region_rows`` of a clipped HDR file (``clipped_hdr_camera``): its plateau's regions as ``sources.restore``
    sees them (clip units), none where ``camera.ceiling`` finds no plateau."""
    ceiling = find_ceiling(clipped)
    if ceiling is None:
        return np.zeros((0, len(sources.FEATURES))), np.zeros(0), np.zeros(0)
    reg = sources.region_features(*Source(clipped, ceiling).work_maps())
    if reg.count == 0:
        return np.zeros((0, len(sources.FEATURES))), np.zeros(0), np.zeros(0)
    target, share = region_targets(reg, truth / ceiling.level)
    return reg.features, target, share


def region_targets(regions, truth: np.ndarray):
    """(target log ratio (n,), at least 0, true share of scene energy (n,)) of ``regions`` (``sources.Regions`` of a
    work map, e.g. a ``recover``'s) against the exposed linear truth (H, W, 3) of their picture."""
    h, w = regions.labels.shape
    true_lum = area_downsample(truth, h) @ LUMINANCE_WEIGHTS
    omega = sh.pixel_solid_angles(h, w)
    m = regions.labels >= 0
    true_e = np.bincount(regions.labels[m], (true_lum * omega)[m], regions.count)
    target = np.log(np.maximum(true_e, 1e-12) / np.maximum(regions.held, 1e-12))
    share = true_e / max(float((true_lum * omega).sum()), 1e-12)
    return np.maximum(target, 0.0), share


HDR_STREAM = 7  # the clipped HDR cameras draw from their own stream: the photo cameras stay what they were


def _scene_job(args):
    index, path, augment, seed, inject, resave, hdr_cameras = args
    hdr = load_hdr(path)
    rng = np.random.default_rng([seed, index])
    xs, ys, ws, ks = [], [], [], []
    for _ in range(augment):
        ldr, truth = camera(hdr, rng, inject, resave)
        x, y, s = region_rows(ldr, truth)
        xs.append(x), ys.append(y), ws.append(s), ks.append(np.zeros(y.size, np.int8))
    rng_hdr = np.random.default_rng([seed, index, HDR_STREAM])
    for _ in range(hdr_cameras):
        x, y, s = hdr_region_rows(*clipped_hdr_camera(hdr, rng_hdr))
        xs.append(x), ys.append(y), ws.append(s), ks.append(np.ones(y.size, np.int8))
    return index, np.concatenate(xs), np.concatenate(ys), np.concatenate(ws), np.concatenate(ks)


def build_table(files, augment: int = 16, seed: int = 0, workers: int | None = None, log=print,
                inject: float = 0.0, resave: float = RESAVE, hdr_cameras: int = 0):
    """Rows of every scene's augmented cameras: (X, y, share, scene index, kind: 0 a photo, 1 a clipped HDR file).
    inject, resave: see ``camera``; hdr_cameras: clipped HDR files per scene (``clipped_hdr_camera``) after the
    ``augment`` photos."""
    from concurrent.futures import ProcessPoolExecutor

    jobs = [(i, str(f), augment, seed, inject, resave, hdr_cameras) for i, f in enumerate(files)]
    workers = workers or max(1, min(4, os.cpu_count() or 1))
    out = {}
    t0 = time.perf_counter()
    with ProcessPoolExecutor(workers, mp_context=threads.process_context()) as pool:
        for done, (i, x, y, s, k) in enumerate(pool.map(_scene_job, jobs), 1):
            out[i] = (x, y, s, k)
            if done % 10 == 0 or done == len(jobs):
                log(f"  regions: {done}/{len(jobs)} scenes, {sum(v[0].shape[0] for v in out.values())} rows "
                    f"({time.perf_counter() - t0:.0f} s)")
    X = np.concatenate([out[i][0] for i in range(len(files))])
    y = np.concatenate([out[i][1] for i in range(len(files))])
    s = np.concatenate([out[i][2] for i in range(len(files))])
    g = np.concatenate([np.full(out[i][1].size, i) for i in range(len(files))])
    k = np.concatenate([out[i][3] for i in range(len(files))])
    return X, y, s, g, k


def cached_table(path, files, augment: int, seed: int, inject: float, log=print, resave: float = RESAVE,
                 hdr_cameras: int = 0):
    """``build_table`` of ``files``, kept in ``path`` (.npz, no pickle) and read back when it was made from the same
    scenes, cameras and FEATURES: one table serves the shipped model and every fold's (``--hold-out`` then drops
    the fold's rows, so every model sees the same cameras of the scenes it trains on)."""
    key = {"scenes": [Path(f).name for f in files], "augment": augment, "seed": seed, "inject": inject,
           "resave": resave, "features": list(sources.FEATURES)}
    key = json.dumps({**key, "hdr_cameras": hdr_cameras} if hdr_cameras else key)  # older tables stay valid
    path = Path(path)
    if path.exists():
        with np.load(path, allow_pickle=False) as z:
            if str(z["key"]) == key:
                log(f"  regions: read from {path}")
                return (z["X"], z["y"], z["share"], z["scene"],
                        z["kind"] if "kind" in z.files else np.zeros(z["y"].size, np.int8))
        log(f"  {path} was made from other scenes, cameras or features: building the table again")
    X, y, s, g, k = build_table(files, augment, seed, log=log, inject=inject, resave=resave, hdr_cameras=hdr_cameras)
    path.parent.mkdir(parents=True, exist_ok=True)
    np.savez(path, X=X, y=y, share=s, scene=g, kind=k, key=np.array(key))
    return X, y, s, g, k
