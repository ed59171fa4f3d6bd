"""The per-pixel half of ``camera.brackets.merge_brackets``: a set's aligned frames averaged into one HDR, row block
by row block, through tables made once per set (numpy only: Blender runs it too).

A pixel's weight in a frame is read from one (256 x 256) table by (the reference frame's code, the frame's own code)
of the pixel's brightest channel: the noise weight (``weights.noise_weights``), and 0 where the ghost test sees the
frame GHOST_RATIO off the reference. A JPEG's ringing round a clipped edge weighs nothing (``clipped_or_ringing``),
nor a reading the outlier test drops (``weights.outlying_frames``). The frames' logarithms are averaged under those
weights, channel by channel (Debevec and Malik's ln E = sum w (g(Z) - ln t) / sum w); a pixel no frame weighs takes
the darkest frame's channels, those it clipped at the set's ceiling.
"""
from __future__ import annotations

import numpy as np

from .weights import CLIPPED_CODE, GHOST_RATIO, noise_weights, outlying_frames, sure_codes, sure_readings

RING_CODE = 230  # a JPEG rings 10-20 codes round a clipped patch (codes 230-249 beside a clipped edge) ...
RING_BLOCK = 16  # ... inside the compression's blocks that hold the edge (8 x 8 luma, 16 x 16 with 4:2:0 chroma): a
# code from RING_CODE up in a block of this size that holds a clipped code is taken as clipped, never as the light
# there (a brighter frame's ringing pixel, trusted where every darker frame clipped, came out at 0.2 where the truth
# was over 100)


def clipped_or_ringing(top: np.ndarray) -> np.ndarray:
    """(n, W) bool: the pixels of a frame's brightest-channel codes ``top`` (n, W) uint8 (rows starting on the
    RING_BLOCK grid) that are clipped (CLIPPED_CODE up) or may be a JPEG's ringing round a clipped edge (RING_CODE up
    in a RING_BLOCK square holding a clipped code)."""
    n, w = top.shape
    b = RING_BLOCK
    pad = np.zeros((-(-n // b) * b, -(-w // b) * b), dtype=bool)
    pad[:n, :w] = top >= CLIPPED_CODE
    blocks = pad.reshape(pad.shape[0] // b, b, pad.shape[1] // b, b).any(axis=(1, 3))
    near = np.repeat(np.repeat(blocks, b, axis=0), b, axis=1)[:n, :w]
    return pad[:n, :w] | (near & (top >= RING_CODE))


class Blend:
    """A set's per-pixel merge: ``frames`` (each (H, W, 3) uint8 codes, aligned; for camera RAWs their nearest sRGB
    codes, with ``linear`` their float32 values whose white is 1), exposed ``rel`` times the reference frame ``ref``,
    decoded through ``curve`` (a ``camera.response`` curve), with the ghost and outlier tests where ``ghosts``.
    ``ceiling``: what a pixel clipped in every frame reads (units: the reference's white is 1)."""

    def __init__(self, frames, linear, rel: np.ndarray, ref: int, curve, ghosts: bool, ceiling: float):
        self.frames, self.linear, self.rel, self.ref, self.ghosts = frames, linear, rel, ref, ghosts
        self.ceiling = np.float32(ceiling)
        self.dark = int(np.argmin(rel))
        weight = noise_weights(curve.table)  # by code: a table lookup per pixel, not arithmetic
        self.radiance = [(curve.table / np.float32(k)).astype(np.float32) for k in rel]  # each frame's code -> light
        self.floor = np.float32(0.5 * curve.table[1])  # half the first code's light: a code 0 reads no light, not -inf
        self.logs = [np.log(np.maximum(r, self.floor / np.float32(k))).astype(np.float32)
                     for r, k in zip(self.radiance, rel)]
        # each frame's weight by (the reference's code, its own code) of a pixel's brightest channel: the noise
        # weight, and 0 where the two differ by GHOST_RATIO in radiance though both are well exposed (``sure_codes``)
        sure = sure_codes(curve.table)
        self.weights = []
        for i, k in enumerate(rel):
            table = np.broadcast_to(weight[None, :], (256, 256)).copy()  # [reference code, own code]
            if ghosts and i != ref:
                level = curve.table.astype(np.float64)
                ratio = level[None, :] / (k * np.maximum(level[:, None], 1e-12))  # own radiance over the reference's
                table[sure[:, None] & sure[None, :] & ((ratio > GHOST_RATIO) | (ratio < 1.0 / GHOST_RATIO))] = 0.0
            self.weights.append(table.ravel())  # read at reference code x 256 + own code
        self.readings = [sure_readings(r, sure, w) for r, w in zip(self.radiance, self.weights)]  # the outlier test's

    def block_weights(self, r0: int, r1: int) -> list[np.ndarray]:
        """Each frame's (r1 - r0, W) float32 weights of rows r0:r1 (np.take: a third of fancy indexing's time)."""
        top = [np.maximum(np.maximum(f[r0:r1, :, 0], f[r0:r1, :, 1]), f[r0:r1, :, 2]) for f in self.frames]
        row = top[self.ref].astype(np.uint16) << 8
        ws, trusted = [], []
        for i, t in enumerate(top):
            index = row | t
            ws.append(np.take(self.weights[i], index, mode="clip"))
            if self.ghosts:
                trusted.append(np.take(self.readings[i], index, mode="clip"))
            if t.max() >= RING_CODE:  # a JPEG's ringing round a clipped edge is no measure of the light there (RAWs
                lost = clipped_or_ringing(t)  # too, by their nearest codes: one rule for every set)
                ws[i][lost] = 0.0
                if self.ghosts:
                    trusted[i][lost] = np.nan
        dropped = outlying_frames(trusted, ws, self.ref) if self.ghosts else None
        for w, d in zip(ws, dropped or ()):
            if d is not None:
                w[d] = 0.0
        return ws

    def merge_rows(self, out: np.ndarray, r0: int, r1: int) -> int:
        """Write rows r0:r1 of the merged HDR into ``out`` (H, W, 3) float32; the number of their pixels clipped in
        every frame (by their brightest channel: each takes the darkest frame's channels, those it clipped at the
        ceiling, a lower bound the restoration weighs as an HDR file's clipped channels)."""
        num = out[r0:r1]  # summed in place: a block's fresh pages cost as much as its sums
        seen = np.empty_like(num)
        den = np.zeros(num.shape[:2], np.float32)
        for i, w in enumerate(self.block_weights(r0, r1)):
            if self.linear is None:
                np.take(self.logs[i], self.frames[i][r0:r1], out=seen, mode="clip")
            else:
                np.maximum(self.linear[i][r0:r1], self.floor, out=seen)
                seen *= np.float32(1.0 / self.rel[i])
                np.log(seen, out=seen)
            for c in range(seen.shape[-1]):  # channel by channel: a (..., 3) broadcast runs 3x slower
                seen[..., c] *= w
            if i:
                num += seen
            else:
                num[...] = seen
            den += w
        none = den == 0
        den[none] = 1.0
        for c in range(num.shape[-1]):
            num[..., c] /= den
        np.exp(num, out=num)  # Debevec and Malik's ln E = sum w (g(Z) - ln t) / sum w
        if none.any():
            dark, k = self.dark, np.float32(1.0 / self.rel[self.dark])
            codes = self.frames[dark][r0:r1][none]
            held = self.radiance[dark][codes] if self.linear is None else self.linear[dark][r0:r1][none] * k
            num[none] = np.where(codes >= CLIPPED_CODE, self.ceiling, held)
        return int(none.sum())
