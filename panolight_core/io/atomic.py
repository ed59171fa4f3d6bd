"""Writing files whole or not at all: a temporary sibling renamed into place."""
from __future__ import annotations

import os
from contextlib import contextmanager
from pathlib import Path


@contextmanager
def atomic_path(path, suffix: str = ""):
    """Yield a temporary sibling ``.NAME.tmpPID<suffix>`` to write; on success it replaces ``path``. On any
    failure or interruption (Ctrl-C, SIGTERM) it is removed, so no half-written file is ever left. The
    pid in the name lets ``batch`` clean what a dead process left."""
    p = Path(path)
    tmp = p.with_name(f".{p.name}.tmp{os.getpid()}{suffix}")
    try:
        yield tmp
        os.replace(tmp, p)
    finally:
        if tmp.exists():
            tmp.unlink()


def pid_alive(pid: int) -> bool:
    """Whether a process with this pid runs (the owner of a lock or a temporary file)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # it runs, as another user
        return True
    except (OverflowError, OSError):  # not a pid this system can have
        return False
    return True
