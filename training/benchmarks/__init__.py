"""Benchmarks: scripts that print tables of timings and ratios against peers measured in the same run."""
from __future__ import annotations

import statistics
import time


def median_seconds(fn, repeats: int) -> float:
    """Median wall time of ``fn()`` over ``repeats`` runs, after one warm-up run."""
    fn()
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times)


def interleaved_medians(fns: dict, repeats: int) -> dict:
    """{name: median wall time of ``fns[name]()``} over ``repeats`` rounds, each round running every one once in
    turn, after one warm-up round: a noisy machine's slow minute falls on all of them alike, where timing one after
    the other puts it on whichever ran then."""
    for fn in fns.values():
        fn()
    times = {name: [] for name in fns}
    for _ in range(repeats):
        for name, fn in fns.items():
            t = time.perf_counter()
            fn()
            times[name].append(time.perf_counter() - t)
    return {name: statistics.median(v) for name, v in times.items()}

