"""Connected components of boolean masks on the equirectangular grid (CONVENTIONS.md): 4-neighbours, the seam
u = 0 joined to the last column, the first (last) row joined across its pole. The clipped regions of the estimators
and the bright spots of the lighting model are both found with them."""
from __future__ import annotations

import numpy as np


def label_blobs(mask: np.ndarray) -> tuple[np.ndarray, int]:
    """Connected components of a boolean equirect mask: 4-neighbours, wrapping around the seam u = 0
    and joining the first (last) row across the pole. Returns (labels, -1 outside; count).

    Union-find over horizontal runs, so the cost is the number of runs, not the blob diameter.
    """
    h, w = mask.shape
    parent: list[int] = []

    def find(a):
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a

    def union(a, b):
        ra, rb = find(a), find(b)
        if ra != rb:
            parent[max(ra, rb)] = min(ra, rb)

    run_id = np.full((h, w), -1, dtype=np.int64)
    for y in range(h):
        row = mask[y]
        if not row.any():
            continue
        edges = np.flatnonzero(np.diff(np.concatenate([[0], row.astype(np.int8), [0]])))
        for x0, x1 in zip(edges[::2], edges[1::2]):
            rid = len(parent)
            parent.append(rid)
            run_id[y, x0:x1] = rid
        if row[0] and row[-1]:  # wraps around the seam
            union(run_id[y, 0], run_id[y, -1])
        if y > 0:
            both = (run_id[y] >= 0) & (run_id[y - 1] >= 0)
            for a, b in set(zip(run_id[y][both].tolist(), run_id[y - 1][both].tolist())):
                union(a, b)
    for y in (0, h - 1):  # across the poles: column x meets column x + w/2
        opposite = np.roll(run_id[y], w // 2)
        both = (run_id[y] >= 0) & (opposite >= 0)
        for a, b in set(zip(run_id[y][both].tolist(), opposite[both].tolist())):
            union(a, b)
    if not parent:
        return run_id, 0
    roots = np.array([find(i) for i in range(len(parent))])
    ids, compact = np.unique(roots, return_inverse=True)
    labels = np.where(run_id >= 0, compact[np.maximum(run_id, 0)], -1)
    return labels, int(ids.size)


def component_at(mask: np.ndarray, y: int, x: int) -> np.ndarray:
    """Boolean mask of the connected component of ``mask`` holding pixel (y, x), with label_blobs'
    connectivity (4-neighbours, the seam, across the poles), found by a flood fill over horizontal runs
    from that pixel: the cost is the component's runs, not the whole map's. Empty if (y, x) is outside."""
    h, w = mask.shape
    out = np.zeros((h, w), dtype=bool)
    if not mask[y, x]:
        return out
    runs = {}

    def row_runs(r):
        if r not in runs:
            edges = np.flatnonzero(np.diff(np.concatenate([[0], mask[r].astype(np.int8), [0]])))
            runs[r] = (edges[::2], edges[1::2])
        return runs[r]

    stack = [(y, x)]
    while stack:
        r, c = stack.pop()
        if out[r, c] or not mask[r, c]:
            continue
        starts, ends = row_runs(r)
        k = int(np.searchsorted(starts, c, side="right")) - 1
        x0, x1 = int(starts[k]), int(ends[k])
        out[r, x0:x1] = True
        if x0 == 0 and mask[r, w - 1]:  # the seam joins the first and last columns
            stack.append((r, w - 1))
        if x1 == w and mask[r, 0]:
            stack.append((r, 0))
        for rr in (r - 1, r + 1):
            if 0 <= rr < h:
                s2, e2 = row_runs(rr)
                for a in np.flatnonzero((s2 < x1) & (e2 > x0)):
                    stack.append((rr, max(int(s2[a]), x0)))
        if r in (0, h - 1):  # across the pole: column x meets column x + w/2
            cols = np.arange(x0, x1)
            for t in np.unique(np.concatenate([(cols + w // 2) % w, (cols - w // 2) % w])):
                if mask[r, t] and not out[r, t]:
                    stack.append((r, int(t)))
    return out
