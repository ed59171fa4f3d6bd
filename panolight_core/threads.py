"""Threads for the block-wise pixel passes (sRGB decoding, area means, clipped masks, the HDRI fill):
numpy releases the GIL inside these loops, so row blocks run on every CPU at once.

``count()`` is the number of threads a pass may use: the CPUs this process may run on, or
PANOLIGHT_THREADS, or what ``limited(n)`` sets for a while (batch workers, which are already one per
CPU, run with one). Results come back in the blocks' order, so they never depend on the count.
"""
from __future__ import annotations

import contextlib
import contextvars
import os
import threading
from collections import deque
from concurrent.futures import ThreadPoolExecutor

_limit: int | None = None


def cpus() -> int:
    """The CPUs this process may run on (>= 1)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not Linux
        return max(1, os.cpu_count() or 1)


def count() -> int:
    """Threads a pass may use (>= 1)."""
    if _limit is not None:
        return _limit
    env = os.environ.get("PANOLIGHT_THREADS", "").strip()
    if env.isdigit() and int(env) > 0:
        return int(env)
    return cpus()


def set_count(n: int) -> None:
    """From now on, passes in this process use at most ``n`` threads (a batch worker: one)."""
    global _limit
    _limit = max(1, int(n))


@contextlib.contextmanager
def limited(n: int):
    """Run the passes inside with at most ``n`` threads."""
    global _limit
    before, _limit = _limit, max(1, int(n))
    try:
        yield
    finally:
        _limit = before


_stop: contextvars.ContextVar = contextvars.ContextVar("panolight_stop", default=None)


@contextlib.contextmanager
def cancellable(stop: threading.Event):
    """The passes run inside (in this thread) stop with ``errors.Cancelled`` at their next block once
    ``stop`` is set: how Blender's Esc stops an estimate running in a worker thread."""
    token = _stop.set(stop)
    try:
        yield
    finally:
        _stop.reset(token)


def check_cancelled(stop: threading.Event | None = None) -> None:
    """Raise ``errors.Cancelled`` when ``stop`` (default: the caller's ``cancellable`` event) is set: a
    block boundary. Pool threads pass the event itself (context variables do not follow them)."""
    stop = _stop.get() if stop is None else stop
    if stop is not None and stop.is_set():
        from .errors import Cancelled

        raise Cancelled("stopped on request")


def imap(fn, items, ahead: int | None = None):
    """``fn(item)`` for each item, yielded in order, computed by ``count()`` threads with at most
    ``ahead`` (default: the thread count) results waiting: a consumer that streams the results (a file
    writer) bounds the memory in flight. With one thread, or one item, it runs in the caller's thread.
    Inside ``cancellable`` every item first checks the event (``check_cancelled``)."""
    stop = _stop.get()
    if stop is not None:
        inner = fn

        def fn(item):
            check_cancelled(stop)
            return inner(item)
    items = list(items)
    n = min(count(), len(items))
    if n <= 1:
        for item in items:
            yield fn(item)
        return
    ahead = max(n, ahead or n)
    with ThreadPoolExecutor(max_workers=n, thread_name_prefix="panolight") as pool:
        pending = deque()
        try:
            for item in items:
                pending.append(pool.submit(fn, item))
                if len(pending) >= ahead:
                    yield pending.popleft().result()
            while pending:
                yield pending.popleft().result()
        finally:  # a consumer that stops early (an error, a full disk) cancels what has not started
            for f in pending:
                f.cancel()


def map_ordered(fn, items) -> list:
    """``[fn(item) for item in items]`` computed by ``count()`` threads."""
    return list(imap(fn, items, ahead=len(items) if hasattr(items, "__len__") else None))


def process_context():
    """The multiprocessing context for worker processes: forkserver (spawn where it is missing). Workers
    start from a clean process, never a fork of one whose library thread pools (OpenImageIO's, OpenEXR's,
    BLAS's) would hang in the child."""
    import multiprocessing

    methods = multiprocessing.get_all_start_methods()
    return multiprocessing.get_context("forkserver" if "forkserver" in methods else "spawn")


@contextlib.contextmanager
def signals_held():
    """Hold SIGINT and SIGTERM for the block, then deliver each that came, once, to the handler in force before
    it: for imports whose C++ code catches Python's exceptions (usd-core's plugin registration, interrupted,
    prints a KeyboardInterrupt's traceback and goes on). Outside the main thread the block runs as it is."""
    import signal

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    caught: list[int] = []
    kinds = (signal.SIGINT, signal.SIGTERM)
    previous = {s: signal.signal(s, lambda signum, frame: caught.append(signum)) for s in kinds}
    try:
        yield
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)
        for s in dict.fromkeys(caught):
            signal.raise_signal(s)


def optional_module(name: str):
    """The module ``name`` (a C extension PanoLight may use: OpenImageIO, OpenEXR, simplejpeg, rawpy, pxr), or None
    when it is not installed. Imported with SIGINT and SIGTERM held (``signals_held``): interrupted while it
    initialises, an extension's import can fail as an ImportError (OpenImageIO then read as missing) or swallow
    the interrupt (usd-core); the signal is delivered once the import ends."""
    import importlib
    import sys

    module = sys.modules.get(name)
    if module is not None and not getattr(getattr(module, "__spec__", None), "_initializing", False):
        return module  # imported already (one another thread is still importing waits in import_module below)
    with signals_held():
        try:
            return importlib.import_module(name)
        except ImportError:
            return None
