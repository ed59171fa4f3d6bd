"""The learned estimator's training set, prepared once and cached as arrays (fast epochs, reused by
every ablation variant).

Three kinds of example, all turned into the camera's 8-bit LDR by the EVALUATION.md model (exposure
ev ~ N(0, 1) clipped to +-2.5, JPEG q90 half of the time) and reduced to the network input
(panolight_core.estimators.nn.inputs):
- ``procedural``: a procedural environment (panolight_core/synthetic.py: CIE skies with a sun,
  rooms with lamps and windows) rendered at 256 rows; its lighting is its own SH (coupled data).
- ``synthetic``: a Mitsuba panorama from ``panolight synth`` seen as it is; lighting = its own SH.
- ``relit``: the paper's Eq. 5: the same panorama's LDR image relit through its normals by two blended
  pool lightings (x100, deringed); lighting = the coefficients that relit it (uncoupled data made
  coupled). Its normals and image are kept for the photometric loss.
- ``hdr``: a real HDR panorama from a folder of your own (Laval style; Blender's studio HDRIs are
  refused); its lighting is its own SH.
Targets are in the LDR's linear units (the HDR times the camera's exposure k; 1 = clip level): ``sh``
(K, 3) the exact projection at the source resolution, ``log_hdr`` (3, h, 2h) log(1 + area-averaged HDR)
for the autoencoder.
"""
from __future__ import annotations

import contextlib
import hashlib
import json
import os
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from panolight_core import sh, threads
from panolight_core.camera import auto_exposure, hdr_to_ldr
from panolight_core.camera.resample import area_downsample
from panolight_core.estimators.nn.inputs import network_input

KINDS = ("procedural", "synthetic", "relit", "hdr")
PROCEDURAL_HEIGHT = 256
EV_SIGMA, EV_LIMIT, JPEG_SHARE = 1.0, 2.5, 0.5
FORMAT_VERSION = 2


def _camera_settings(rng) -> tuple[float, int | None]:
    """(ev, JPEG quality or None) of a random auto-exposing camera."""
    ev = float(np.clip(rng.normal(0.0, EV_SIGMA), -EV_LIMIT, EV_LIMIT))
    return ev, (90 if rng.random() < JPEG_SHARE else None)


@dataclass(frozen=True)
class NetInput:
    """What the network sees (panolight_core.estimators.nn.inputs): its height and whose guess it
    corrects ("analytic", or "sources" with an optional per-source model file). Where an int height is
    given, the analytic guess."""

    height: int
    guess: str = "analytic"
    source_model: str | None = None

    def __call__(self, ldr) -> np.ndarray:
        return network_input(ldr, self.height, self.guess, self.source_model)


def _net_input(height) -> NetInput:
    return height if isinstance(height, NetInput) else NetInput(int(height))


def _arrays(ldr, exposed, coeffs, height, kind, ev) -> dict:
    net = _net_input(height)
    return {"x": net(ldr).astype(np.float16),
            "log_hdr": np.moveaxis(np.log1p(area_downsample(exposed, net.height)), -1, 0).astype(np.float16),
            "sh": np.asarray(coeffs, np.float32), "kind": KINDS.index(kind), "ev": ev}


def _coupled(hdr, rng, height, lmax, kind) -> dict:
    """A panorama seen by the camera; its lighting is its own SH."""
    ev, jpeg = _camera_settings(rng)
    k = auto_exposure(hdr, ev, robust=True)
    exposed = np.asarray(hdr, np.float64) * k
    return _arrays(hdr_to_ldr(hdr, ev, jpeg, scale=k), exposed, sh.project(exposed, lmax), height, kind, ev)


def procedural_example(seed: int, height: int, lmax: int) -> dict:
    from panolight_core.synthetic import environment

    hdr, _ = environment(seed, PROCEDURAL_HEIGHT)
    return _coupled(hdr, np.random.default_rng([seed, 1]), height, lmax, "procedural")


def synthetic_examples(path, index: int, height: int, lmax: int, pool: np.ndarray, seed: int) -> list[dict]:
    """The coupled and the relit example (relight_data.make_pair, paper Eq. 5) of one Mitsuba sample."""
    from training.neural.relight_data import load_source, make_pair

    image, normals, mask, radiance = load_source({"kind": "synthetic", "path": path})
    rng = np.random.default_rng([seed, index, 2])
    coupled = _coupled(radiance, rng, height, lmax, "synthetic")
    ev, jpeg = _camera_settings(rng)
    ldr, _, _, relit_exposed, used = make_pair(image, normals, mask, pool, rng, ev=ev, jpeg_quality=jpeg,
                                               details=True)
    relit = _arrays(ldr, relit_exposed, used, height, "relit", ev)
    height = _net_input(height).height
    n_small = area_downsample(normals * mask[..., None], height)
    length = np.linalg.norm(n_small, axis=-1, keepdims=True)
    relit["normals"] = np.moveaxis(np.where(length > 0.5, n_small / np.maximum(length, 1e-12), 0.0), -1, 0)
    relit["image"] = np.moveaxis(area_downsample(image, height), -1, 0)
    return [coupled, relit]


def hdr_example(path, index: int, height: int, lmax: int, seed: int, copy: int | None = None) -> dict:
    """A real HDR panorama seen by the camera (coupled: its lighting is its own SH). copy (0, 1, ...):
    one of several augmented views instead, through source_energy's camera (yaw, mirror, white balance,
    resolution, ev -3..3, tone curves other than sRGB, JPEG quality): the data the per-source model
    learns from, so the two are compared on the same footing."""
    from panolight_core.io import read_image

    hdr = np.maximum(read_image(path).astype(np.float64), 0.0)
    if copy is None:
        return _coupled(hdr, np.random.default_rng([seed, index, 3]), height, lmax, "hdr")
    from training.source_energy.data import camera

    ldr, exposed = camera(hdr, np.random.default_rng([seed, index, 4, copy]))
    return _arrays(ldr, exposed, sh.project(exposed, lmax), height, "hdr", float("nan"))


def _job(args):
    kind, a, b, height, lmax, pool, seed = args
    if kind == "procedural":
        return [procedural_example(a, height, lmax)]
    if kind == "hdr":
        return [hdr_example(a, b, height, lmax, seed)]
    if kind == "hdr-augmented":
        index, copy = b
        return [hdr_example(a, index, height, lmax, seed, copy)]
    return synthetic_examples(a, b, height, lmax, pool, seed)


def _files(synth) -> list:
    """Sample files of a synth folder, or the given list of them."""
    from training.synth.store import list_samples

    if not synth:
        return []
    return list(synth) if isinstance(synth, (list, tuple)) else list_samples(synth)


def prepare(out, *, synth=None, procedural: int = 0, hdr=None, height: int = 64, lmax: int = 2, seed: int = 0,
            workers: int | None = None, progress=None, hdr_copies: int = 0, guess: str = "analytic",
            source_model=None, pool_hdr=None) -> Path:
    """Write the arrays of ``procedural`` procedural examples (seeds seed*10^7 + i) and of every sample
    of ``synth`` (a folder or a list of sample files; coupled + relit) and every panorama of ``hdr`` (a
    list of .exr/.hdr files, common.real_hdri.hdr_files; with ``hdr_copies`` that many augmented views of
    each) to ``out`` (.npz, uncompressed, no pickles). guess, source_model: the network input's guess
    (NetInput). pool_hdr: real HDR panoramas whose lightings (relight_data.hdr_pool: 8 yaws, mirrored)
    relight the synthetic samples (Eq. 5, as the paper relights with Laval); default: 256 procedural
    environments. Returns ``out``."""
    from training.neural.relight_data import hdr_pool, procedural_pool

    files = _files(synth)
    pool = None
    if files:
        pool = hdr_pool(pool_hdr, lmax) if pool_hdr else procedural_pool(256, lmax, seed=10 ** 6 + seed)
    net = NetInput(height, guess, None if source_model is None else str(source_model))
    jobs = [("procedural", seed * 10 ** 7 + i, None, net, lmax, None, seed) for i in range(procedural)]
    jobs += [("synthetic", f, i, net, lmax, pool, seed) for i, f in enumerate(files)]
    if hdr_copies:
        jobs += [("hdr-augmented", f, (i, c), net, lmax, None, seed) for i, f in enumerate(hdr or [])
                 for c in range(hdr_copies)]
    else:
        jobs += [("hdr", f, i, net, lmax, None, seed) for i, f in enumerate(hdr or [])]
    if not jobs:
        raise ValueError("nothing to prepare: give procedural > 0, synthetic samples or HDR panoramas")
    examples = []
    workers = workers or min(len(jobs), os.cpu_count() or 1)
    with ProcessPoolExecutor(workers, mp_context=threads.process_context()) if workers > 1 else contextlib.nullcontext() as pool_ex:
        chunks = pool_ex.map(_job, jobs, chunksize=16) if pool_ex else (_job(j) for j in jobs)
        for done, exs in enumerate(chunks, 1):
            examples.extend(exs)
            if progress:
                progress(done, len(jobs))
    geo = [i for i, e in enumerate(examples) if "normals" in e]
    geo_index = np.full(len(examples), -1, np.int32)
    geo_index[geo] = np.arange(len(geo))
    arrays = {"x": np.stack([e["x"] for e in examples]), "log_hdr": np.stack([e["log_hdr"] for e in examples]),
              "sh": np.stack([e["sh"] for e in examples]), "kind": np.array([e["kind"] for e in examples], np.uint8),
              "ev": np.array([e["ev"] for e in examples], np.float32), "geo_index": geo_index,
              "normals": np.array([examples[i]["normals"] for i in geo], np.float16).reshape(-1, 3, height, 2 * height),
              "image": np.array([examples[i]["image"] for i in geo], np.float16).reshape(-1, 3, height, 2 * height),
              "meta": np.array(json.dumps({"version": FORMAT_VERSION, "height": height, "lmax": lmax, "seed": seed,
                                           "procedural": procedural, "synthetic": len(files),
                                           "hdr": len(hdr or []), "hdr_copies": hdr_copies, "guess": guess,
                                           "relight_pool": [Path(p).name for p in pool_hdr] if pool_hdr
                                           else "procedural"}))}
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(f".{out.name}.tmp{os.getpid()}.npz")
    np.savez(tmp, **arrays)
    os.replace(tmp, out)
    return out


def cache_name(*, synth, procedural, height, lmax, seed, hdr=None, hdr_copies: int = 0, guess: str = "analytic",
               source_model=None, pool_hdr=None) -> str:
    """A file name that changes whenever what ``prepare`` would write changes."""
    files = [Path(p).name for p in _files(synth)]
    key = json.dumps([FORMAT_VERSION, files, procedural, height, lmax, seed]
                     + ([[str(Path(p).resolve()) for p in hdr]] if hdr else [])
                     + ([hdr_copies] if hdr_copies else [])
                     + ([guess, hashlib.sha256(Path(source_model).read_bytes()).hexdigest() if source_model else None]
                        if guess != "analytic" else [])
                     + ([["pool", *(str(Path(p).resolve()) for p in pool_hdr)]] if pool_hdr and synth else []))
    return f"prepared-{hashlib.sha256(key.encode()).hexdigest()[:12]}.npz"


def load(path) -> dict:
    """The prepared arrays (float16 kept as stored; no pickles) and meta as a dict."""
    with np.load(path, allow_pickle=False) as z:
        out = {k: z[k] for k in z.files}
    out["meta"] = json.loads(str(out["meta"]))
    return out


def concat(parts: list[dict]) -> dict:
    """One set of arrays from several prepared parts (geometry indices shifted)."""
    if len(parts) == 1:
        return parts[0]
    out, offset, geo = {}, 0, []
    for p in parts:
        g = p["geo_index"].copy()
        g[g >= 0] += offset
        geo.append(g)
        offset += len(p["normals"])
    for k in ("x", "log_hdr", "sh", "kind", "ev", "normals", "image"):
        out[k] = np.concatenate([p[k] for p in parts])
    out["geo_index"] = np.concatenate(geo)
    out["meta"] = [p["meta"] for p in parts]
    return out


def probe_geometry(height: int) -> tuple[np.ndarray, np.ndarray]:
    """(normals, image) (3, h, 2h) of a white diffuse sphere seen from inside: each pixel's normal is its
    own direction, so relighting it renders the lighting's irradiance map (the photometric loss of
    examples without their own geometry)."""
    n = np.moveaxis(sh.pixel_directions(height, 2 * height), -1, 0).astype(np.float32)
    return n, np.ones_like(n)
