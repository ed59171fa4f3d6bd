"""A bracket set's camera response: the curve from 8-bit code to linear radiance its camera applied, recovered from
the frames themselves (Debevec and Malik 1997, "Recovering high dynamic range radiance maps from photographs")
where it explains them better than sRGB does, else sRGB (numpy only: Blender runs it too).

A camera's JPEG is rarely pure sRGB: makers add a tone curve (an S-curve, a lifted shadow, a rolled-off
highlight), and decoding such frames through sRGB makes each exposure disagree with the next, so the merge blurs
them. With three or more exposures the curve can be solved for: log g(z) = ln E + ln t for every sampled pixel
and frame, weighed by the hat, smooth in z. Only where the recovered curve leaves at most RESPONSE_GAIN of the
frames' disagreement under sRGB is it used: a set the sRGB curve already explains (the evaluation's camera, and
cameras set to a neutral profile) keeps sRGB, and merges exactly as before.

Units: the recovered curve is scaled so that the reference frame's clip (the radiance at which its channels reach
code 250, read from the darker frames; a curve's shoulder makes its extrapolated code 255 unreliable) is where
sRGB puts code 250 (0.955): the reference frame's white is about 1, as with sRGB.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .color import SRGB8_TO_LINEAR, gray8

RESPONSE_SAMPLES = 96  # pixels whose three channels the curve is solved on (256 + 3 x this unknowns)
RESPONSE_SMOOTHNESS = 256.0  # the weight of g's second difference against the data (Debevec's lambda): 16-1024 tried on
# three scenes x three camera curves at JPEG q90; lower follows the JPEG noise (10-20 % waves), higher bends the curve
RESPONSE_GAIN = 0.7  # the recovered curve is used where the frames' disagreement under it is at most this share of
# their disagreement under sRGB: over the 121 real HDRs' camera JPEGs at {-2, 0, +2} and {-4 .. +4} (242 sRGB sets)
# the share is 0.907 or more (a smooth curve explains JPEG noise no better), so every sRGB set keeps sRGB bit for
# bit; real Nikon D90 and Canon 5D II sets reach 0.45-0.67 (their curve fits 1.5-2.2x better, and sRGB misreads
# them by 1.2-1.55x a stop), and a camera a little off sRGB (an S-curve of 1.03-1.04, gamma 2.25) 0.2-0.7: at 0.35
# those kept sRGB, and their merges' mid-tone error was 1.0-1.8x what their own curve gives (no case worse; 13
# real scenes, docs/studies/captures.md)
RESPONSE_CODES = (8, 247)  # codes a frame contributes to the solve and to the disagreement (the hat's reliable part)
MIN_RESPONSE_FRAMES = 3  # two frames pin too little of the curve: sRGB
MIN_RESPONSE_CODES = 64  # ... as do frames whose solved pixels hold fewer distinct codes (a flat scene: any curve
# through its few codes explains it)
CHECK_SAMPLES = 2048  # pixels the disagreement is measured on (other than the solve's)


@dataclass(frozen=True)
class Response:
    """table: (256,) float32 code -> linear radiance (the reference's white about 1); name: "sRGB" or "recovered"; why:
    one line; disagreement: the frames' median disagreement (natural log units) under each curve tried."""

    table: np.ndarray
    name: str
    why: str
    disagreement: dict

    def describe(self) -> dict:
        """For lighting.json's ``source.brackets.response``."""
        return {"curve": self.name, "why": self.why,
                "disagreement": {k: round(float(v), 5) for k, v in self.disagreement.items()}}


SRGB = Response(SRGB8_TO_LINEAR, "sRGB", "the frames are taken as sRGB", {})


def _smooth_pixels(gray: np.ndarray) -> np.ndarray:
    """(n, 2) row, column of the pixels of ``gray`` (the reference's grey on a grid) whose 3 x 3 neighbourhood spans
    at most a few codes: a misaligned frame or the demosaic moves them least."""
    g = gray.astype(np.int16)
    if min(g.shape) < 3:
        return np.zeros((0, 2), np.int64)
    core = g[1:-1, 1:-1]
    spread = np.zeros_like(core)
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            spread = np.maximum(spread, np.abs(g[1 + dy:g.shape[0] - 1 + dy, 1 + dx:g.shape[1] - 1 + dx] - core))
    rows, cols = np.nonzero(spread <= 3)
    return np.stack([rows + 1, cols + 1], axis=1)


def _pick(points: np.ndarray, gray: np.ndarray, n: int, rng: np.random.Generator) -> np.ndarray:
    """Indices of up to ``n`` of ``points``, spread over the reference's grey codes (16 bins, an equal share each,
    the rest drawn from the others), so that every part of the curve is pinned."""
    if len(points) <= n:
        return np.arange(len(points))
    codes = gray[points[:, 0], points[:, 1]].astype(np.int64) // 16
    perm = rng.permutation(len(points))
    idx = perm[np.argsort(codes[perm], kind="stable")]  # by bin, in a random order within each
    bins = codes[idx]
    rank = np.arange(idx.size) - np.searchsorted(bins, bins)  # each point's place in its bin
    return idx[np.argsort(rank, kind="stable")[:n]]  # every bin's first, then every bin's second ...


def _hat(z: np.ndarray) -> np.ndarray:
    lo, hi = RESPONSE_CODES
    w = np.minimum(z - lo + 1.0, hi - z + 1.0)
    return np.where((z >= lo) & (z <= hi), w, 0.0)


def disagreement(table: np.ndarray, samples: np.ndarray, log_exposures: np.ndarray) -> float:
    """The median, over sampled pixel channels seen well exposed in two or more frames, of the hat-weighted standard
    deviation of ln(table[code] / exposure) across the frames: 0 for a curve that explains the set exactly.
    samples: (n, frames, 3) codes; log_exposures: (frames,)."""
    z = samples.astype(np.float64)
    w = _hat(z)
    value = np.log(np.maximum(table.astype(np.float64)[samples], 1e-12)) - log_exposures[None, :, None]
    n = (w > 0).sum(axis=1)
    total = np.maximum(w.sum(axis=1), 1e-12)
    mean = (w * value).sum(axis=1) / total
    var = (w * (value - mean[:, None, :]) ** 2).sum(axis=1) / total
    sel = n >= 2
    return float(np.median(np.sqrt(var[sel]))) if sel.any() else 0.0


KNOT_STEP = 4  # the curve is solved at every 4th code and linear between (65 unknowns; lambda keeps it smoother)


def solve_curve(samples: np.ndarray, log_exposures: np.ndarray) -> np.ndarray:
    """(256,) float64 ln g: Debevec and Malik's least squares for codes ``samples`` (n, frames, 3) at
    ``log_exposures`` (frames,): g(z_ij) - ln E_i = ln t_j weighed by the hat, lambda x the hat x g'' = 0, g(128) = 0;
    one curve for the three channels (a camera's tone curve is the same on each), each channel of each pixel its
    own radiance; g is linear between knots every KNOT_STEP codes. Codes never seen follow the smoothness; the
    result is made non-decreasing.

    The normal equations are assembled term by term, each pixel's radiance eliminated (its block is diagonal), and
    solved by ``_solve_spd``: no BLAS or LAPACK call (it woke OpenBLAS's threads, which then spun ~40 ms against
    the merge's own on a 2-core machine)."""
    n, frames, _ = samples.shape
    z = samples.transpose(0, 2, 1).reshape(-1, frames)  # (3n, frames): a pixel channel per row ...
    w2 = _hat(z.astype(np.float64)) ** 2
    keep = (w2 > 0).sum(axis=1) >= 2  # ... seen well exposed twice or more (once says nothing of the curve)
    z, w2 = z[keep], w2[keep]
    knots = 256 // KNOT_STEP + 1
    lo, t = z // KNOT_STEP, (z % KNOT_STEP) / KNOT_STEP  # g(z) = (1 - t) c[lo] + t c[lo + 1]
    basis = ((lo, 1.0 - t), (lo + 1, t))
    d = w2.sum(axis=1)  # each radiance's diagonal
    mean = (w2 * log_exposures[None, :]).sum(axis=1) / d  # its data term over its diagonal
    s = np.zeros((knots, knots))
    r = np.zeros(knots)
    for ka, ba in basis:
        np.add.at(r, ka, ba * w2 * (log_exposures[None, :] - mean[:, None]))
        for kb, bb in basis:
            np.add.at(s, (ka, kb), ba * bb * w2)
            for j in range(frames):  # minus the coupling through each radiance: w2_j w2_k / d
                for k in range(frames):
                    np.add.at(s, (ka[:, j], kb[:, k]), -ba[:, j] * bb[:, k] * w2[:, j] * w2[:, k] / d)
    s[128 // KNOT_STEP, 128 // KNOT_STEP] += 1.0  # g(128) = 0: the curve's scale (set again by the caller)
    ks = np.arange(1, knots - 1)
    weight = RESPONSE_SMOOTHNESS * np.maximum(_hat(ks * float(KNOT_STEP)), 1.0) * (2.0 / KNOT_STEP ** 2)
    for a, ca in ((ks - 1, 1.0), (ks, -2.0), (ks + 1, 1.0)):  # lambda x the hat x g'' at each inner knot
        for b, cb in ((ks - 1, 1.0), (ks, -2.0), (ks + 1, 1.0)):
            np.add.at(s, (a, b), weight ** 2 * ca * cb)
    c = _solve_spd(s, r)
    codes = np.arange(256)
    lo, t = codes // KNOT_STEP, (codes % KNOT_STEP) / KNOT_STEP
    return np.maximum.accumulate((1.0 - t) * c[lo] + t * c[lo + 1])


def _solve_spd(s: np.ndarray, r: np.ndarray) -> np.ndarray:
    """x with s x = r for a symmetric positive definite (n, n) ``s``: Gaussian elimination without pivoting, in
    numpy's element-wise operations. A LAPACK or BLAS call of this size woke OpenBLAS's threads, which then spun
    for ~40 ms against the merge's own on a 2-core machine (the bracket set's time 3.9x -> 4.2x the JPEG's)."""
    a = np.array(s, dtype=np.float64)
    x = np.array(r, dtype=np.float64)
    n = x.size
    for k in range(n - 1):
        f = a[k + 1:, k] / a[k, k]
        a[k + 1:, k:] -= f[:, None] * a[k, k:][None, :]
        x[k + 1:] -= f * x[k]
    for k in range(n - 1, -1, -1):
        x[k] = (x[k] - (a[k, k + 1:] * x[k + 1:]).sum()) / a[k, k]
    return x


WHITE_PERCENTILE = 2.0  # the reference's clip: this percentile of the radiance its clipped channels hold


def _white(table: np.ndarray, samples: np.ndarray, rel_exposures: np.ndarray, reference: int) -> float:
    """Where the reference frame clips, in ``table``'s units: the WHITE_PERCENTILE-th percentile of the radiance
    (table / exposure, from the frames that see it well exposed) of the sampled channels the reference has at
    its clip (code 250 or more): the curve is then scaled to put that where sRGB puts code 250. Where the
    reference clips nothing the sampled frames resolve, the curve's own extrapolated code 250."""
    clipped = samples[:, reference, :] >= 250  # (n, 3)
    values = []
    for j, k in enumerate(rel_exposures):
        z = samples[:, j, :]
        sure = clipped & (z >= RESPONSE_CODES[0]) & (z <= RESPONSE_CODES[1])
        values.append(table[z[sure]] / k)
    values = np.concatenate(values)
    if values.size < 16:
        return float(table[250])
    return float(np.percentile(values, WHITE_PERCENTILE))


def recover_response(frames, rel_exposures, reference: int) -> Response:
    """The ``Response`` of 8-bit frames (each (H, W, 3) uint8, aligned) at relative exposures ``rel_exposures``:
    the recovered curve (``solve_curve``) where it leaves at most RESPONSE_GAIN of the frames' disagreement under
    sRGB (``disagreement``, on other pixels than the solve's), else sRGB, with the reason."""
    e = np.asarray(rel_exposures, dtype=np.float64)
    if len(frames) < MIN_RESPONSE_FRAMES:
        return Response(SRGB8_TO_LINEAR, "sRGB", f"{len(frames)} frames pin too little of a curve "
                                                 f"(recovered from {MIN_RESPONSE_FRAMES} or more)", {})
    h, w = frames[0].shape[:2]
    step = max(1, int(np.sqrt(h * w / 65536)))  # a grid of about 64 K pixels
    gray = gray8(frames[reference][::step, ::step])
    points = _smooth_pixels(gray)
    rng = np.random.default_rng(0)  # the solve's pixels: the same draw every run
    picked = _pick(points, gray, RESPONSE_SAMPLES, rng)
    rest = np.setdiff1d(np.arange(len(points)), picked)  # the disagreement is measured on other pixels
    solve_at = points[picked] * step
    check_at = points[rng.choice(rest, size=min(CHECK_SAMPLES, rest.size), replace=False)] * step
    if len(solve_at) < RESPONSE_SAMPLES // 4 or not check_at.size:
        return Response(SRGB8_TO_LINEAR, "sRGB", "too few smooth pixels to recover a curve from", {})
    log_e = np.log(e)

    def codes(at):
        return np.stack([f[at[:, 0], at[:, 1]] for f in frames], axis=1)  # (n, frames, 3)

    solve = codes(solve_at)
    lo, hi = RESPONSE_CODES
    seen = np.unique(solve[(solve >= lo) & (solve <= hi)]).size
    if seen < MIN_RESPONSE_CODES:
        return Response(SRGB8_TO_LINEAR, "sRGB", f"the frames hold {seen} distinct codes, too few to pin a curve "
                                                 f"({MIN_RESPONSE_CODES} or more)", {})
    g = solve_curve(solve, log_e)
    check = codes(check_at)
    raw = np.exp(g - g[128])
    table = (raw * (SRGB8_TO_LINEAR[250] / _white(raw, check, e, reference))).astype(np.float32)
    table[0] = 0.0
    found = {"sRGB": disagreement(SRGB8_TO_LINEAR, check, log_e), "recovered": disagreement(table, check, log_e)}
    if found["recovered"] <= RESPONSE_GAIN * found["sRGB"]:
        return Response(table, "recovered", f"the frames disagree {found['sRGB'] / max(found['recovered'], 1e-12):.1f}x "
                                            f"less under their own curve (Debevec) than under sRGB", found)
    return Response(SRGB8_TO_LINEAR, "sRGB", f"their own curve explains the frames less than "
                                             f"{1 / RESPONSE_GAIN:.1f}x better than sRGB does", found)
