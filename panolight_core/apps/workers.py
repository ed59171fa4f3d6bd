"""The worker processes of ``batch --jobs N``: started from a clean process (forkserver), fed one task at a time
over a pipe each, stopped cleanly on Ctrl-C or SIGTERM (they remove their staging folders), and never left
running when the batch process is gone, however it went."""
from __future__ import annotations

import sys
import time
from collections import deque

from ..errors import PanoLightError
from ..io.atomic import pid_alive

STOP_GRACE_S = 5.0  # an interrupted batch's workers get this long to remove their staging folders, then SIGKILL


def run_workers(tasks, jobs: int, work, record) -> None:
    """Run ``work(task)`` (a module-level function: it is pickled by name; it returns (k, result) with k =
    task[0]) for each of ``tasks`` on ``jobs`` worker processes, each fed over a pipe of its own, calling
    ``record(k, result)`` as each finishes. No queue or lock is shared, so a worker stopped, killed or crashed
    mid-task cannot stall the others: a worker killed while it held multiprocessing.Pool's queue lock made
    Pool.terminate() hang forever (1 Ctrl-C in 30 here). A worker that dies mid-task fails that input (its exit
    said) and a new one takes its place. Interrupted, or on any error, every worker is stopped (``_stop_workers``)
    before the exception goes on."""
    import os
    from multiprocessing.connection import wait

    from .. import threads

    ctx = threads.process_context()  # never a fork: library thread pools would hang in the child
    _quiet_resource_tracker()
    parent, pending, busy, idle, workers = os.getpid(), deque(tasks), {}, [], []
    starts = 0

    def start():
        nonlocal starts
        starts += 1
        if starts > 2 * jobs + len(tasks):
            raise PanoLightError("batch: its worker processes keep dying before they take an input (run it with "
                                 "--jobs 1 to see why)")
        here, there = ctx.Pipe()
        process = ctx.Process(target=_worker_main, args=(there, parent, work), daemon=True,
                              name="panolight-worker")
        process.start()
        there.close()
        workers.append((process, here))
        idle.append((process, here))

    try:
        for _ in range(min(jobs, len(tasks))):
            start()
        while pending or busy:
            while idle and pending:
                process, conn = idle.pop()
                task = pending.popleft()
                try:
                    conn.send(task)
                except OSError:  # it died idle: the task goes to another
                    pending.appendleft(task)
                    start()
                    continue
                busy[conn] = (process, task)
            for conn in wait(list(busy)):  # ready: a result, or the end of a worker that died
                process, task = busy.pop(conn)
                try:
                    k, result = conn.recv()
                except (EOFError, OSError):
                    process.join(1.0)
                    record(task[0], _worker_died(task, process.exitcode))
                    if pending:
                        start()
                    continue
                record(k, result)
                idle.append((process, conn))
        for _, conn in idle:
            try:
                conn.send(None)  # done: each worker returns
            except OSError:  # it died idle: nothing to tell it
                pass
        for process, _ in workers:
            process.join(STOP_GRACE_S)
    finally:
        _stop_workers(workers)


def _worker_main(conn, parent: int, work) -> None:
    """A batch worker: takes tasks over its pipe until None (or the batch process is gone), sends each result."""
    _worker_init(parent)
    try:
        while (task := conn.recv()) is not None:
            conn.send(work(task))
    except (EOFError, OSError):  # the batch process closed its end
        pass


def _worker_died(task, exitcode) -> dict:
    """The report entry of an input whose worker process ended mid-task (killed, out of memory, a crash)."""
    how = f"signal {-exitcode}" if exitcode is not None and exitcode < 0 else f"exit status {exitcode}"
    return {"input": str(task[2]), "status": "failed", "error": f"its worker process ended while estimating it "
            f"({how}; out of memory?)", "seconds": 0.0}


def _stop_workers(workers) -> None:
    """Stop every worker still running: SIGTERM (each unwinds and removes its staging folder), then SIGKILL for
    any still there after STOP_GRACE_S; each is reaped and its pipe closed."""
    for process, _ in workers:
        if process.is_alive():
            process.terminate()
    deadline = time.monotonic() + STOP_GRACE_S
    for process, conn in workers:
        process.join(max(0.0, deadline - time.monotonic()))
        if process.is_alive():
            process.kill()
            process.join(1.0)
        conn.close()


def _worker_init(parent: int):
    """Batch workers leave Ctrl-C to the batch process, which stops them (SIGTERM: they clean up), and
    run their pixel passes on one thread: the workers already fill the CPUs."""
    import signal

    from .. import threads

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, _exit_on_sigterm)
    sys.stderr = _QuietOrphan(sys.stderr, parent)
    _die_with_parent(parent)
    threads.set_count(1)
    keep_freed_memory()


class _QuietOrphan:
    """A worker's stderr that falls silent once the batch process is gone (killed with SIGKILL): the
    worker's last result then meets a broken pipe, and multiprocessing would print that traceback on
    the user's terminal. While the batch runs, every line passes through."""

    def __init__(self, stream, parent: int):
        self.stream, self.parent = stream, parent

    def write(self, text):
        return self.stream.write(text) if pid_alive(self.parent) else len(text)

    def flush(self):
        if pid_alive(self.parent):
            self.stream.flush()

    def __getattr__(self, name):
        return getattr(self.stream, name)


def _quiet_resource_tracker() -> None:
    """Start multiprocessing's resource tracker with its stderr on the null device. It outlives a batch
    killed with SIGKILL and then warns, on the user's terminal, of 'leaked semaphore objects',
    which it cleans up itself (nothing is lost; the message is noise). No-op where it already runs."""
    import os

    try:
        from multiprocessing import resource_tracker
    except ImportError:  # no tracker on this platform
        return
    sys.stderr.flush()
    saved = os.dup(2)
    try:
        with open(os.devnull, "wb") as null:
            os.dup2(null.fileno(), 2)
            resource_tracker.ensure_running()
    finally:
        os.dup2(saved, 2)
        os.close(saved)


def _exit_on_sigterm(signum, frame):
    """A worker told to stop (``_stop_workers``, or its parent gone) unwinds: the writers' ``finally`` blocks
    remove their staging folders, and SystemExit ends the process without a traceback."""
    raise SystemExit(128 + signum)


def _die_with_parent(pid: int) -> None:
    """Stop this worker (SIGTERM to itself, so it cleans up) once the batch process ``pid`` is gone, however
    it went (SIGKILL included): a killed batch leaves no orphans writing or printing tracebacks. A
    watcher thread, because a forkserver's workers outlive their parent by design (they keep it alive)."""
    import os
    import signal
    import threading

    def watch():
        while pid_alive(pid):
            time.sleep(0.5)
        os.kill(os.getpid(), signal.SIGTERM)

    threading.Thread(target=watch, name="panolight-parent-watch", daemon=True).start()


def keep_freed_memory() -> None:
    """Let glibc's malloc reuse freed memory instead of returning every large temporary to the kernel:
    each estimate makes hundreds of MB of short-lived numpy arrays, and mapping them afresh (page
    faults) cost a fifth of batch's time (bench_scale: 9.5 -> 10.3 inputs / s, 2 workers; the system
    time of a serial run halved). No-op off glibc."""
    import ctypes
    import ctypes.util

    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        libc.mallopt(-3, 256 << 20)  # M_MMAP_THRESHOLD: allocations below 256 MB come from the heap
        libc.mallopt(-1, 1 << 30)  # M_TRIM_THRESHOLD: keep up to 1 GB of freed heap for reuse
    except (OSError, AttributeError):
        pass


def default_jobs() -> int:
    """Worker processes for ``batch``: one more than the CPUs this process may use, so that one worker's
    file writes overlap the others' computing (bench_scale, 2 CPUs: 2 workers 12.7 inputs / s, 3 15.3,
    4 15.6)."""
    from .. import threads

    return threads.cpus() + 1
