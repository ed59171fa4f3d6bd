"""Writing files whole or not at all: a temporary sibling renamed into place."""
from __future__ import annotations

import os
from contextlib import contextmanager
from pathlib import Path

from ..errors import PanoLightError


@contextmanager
def atomic_path(path, suffix: str = ""):
    """Yield a temporary sibling ``.NAME.tmpPID<suffix>`` to write; on success it replaces ``path``. On any
    failure or interruption (Ctrl-C, SIGTERM) it is removed, so no half-written file is ever left; a
    failed write (disk full, ``ulimit -f``) is a PanoLightError naming ``path`` and the reason. The pid in
    the name lets ``batch`` clean what a dead process left."""
    p = Path(path)
    tmp = p.with_name(f".{p.name}.tmp{os.getpid()}{suffix}")
    try:
        yield tmp
        os.replace(tmp, p)
    except OSError as exc:  # a full disk, a file-size limit (ulimit -f), no permission
        raise PanoLightError(f"{p}: cannot write it ({exc.strerror or exc})") from None
    except RuntimeError as exc:  # OpenEXR reports the same failures as RuntimeError("... <file>. <reason>")
        reason = str(exc).rsplit('". ', 1)[-1].rstrip(".") or type(exc).__name__
        raise PanoLightError(f"{p}: cannot write it ({reason})") from None
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


class folder_lock:
    """One writer per output folder, for the whole run: an exclusive ``flock`` on OUT/.panolight.lock (the
    kernel releases it when its process dies, however it dies), which holds the writer's pid for the
    message (``name``: another lock file, e.g. one per batch shard). A second writer is refused at once,
    in one line. Where ``fcntl`` is missing (Windows) the
    file is created exclusively and a lock whose pid no longer runs is taken over."""

    def __init__(self, folder: Path, name: str = ".panolight.lock"):
        self.path = Path(folder) / name
        self.fd = None

    def _refuse(self, pid_text: str):
        pid = pid_text.strip()
        return PanoLightError(f"{self.path.parent}: another PanoLight process{f' (pid {pid})' if pid else ''} is "
                              f"writing there; wait for it or choose another folder (-o)")

    def __enter__(self):
        try:
            import fcntl
        except ImportError:
            return self._enter_without_flock()
        for _ in range(100):
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError:
                text = os.read(fd, 32).decode("ascii", "replace")
                os.close(fd)
                raise self._refuse(text) from None
            try:
                same = os.stat(self.path).st_ino == os.fstat(fd).st_ino
            except FileNotFoundError:  # its last holder removed it as we opened it: take a fresh one
                same = False
            if same:
                os.ftruncate(fd, 0)
                os.write(fd, str(os.getpid()).encode())
                self.fd = fd
                return self
            os.close(fd)
        raise PanoLightError(f"{self.path.parent}: cannot take the output folder's lock {self.path.name}")

    def _enter_without_flock(self):
        for _ in range(2):
            try:
                fd = os.open(self.path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
            except FileExistsError:
                try:
                    text = self.path.read_text()
                    pid = int(text.strip() or 0)
                except (OSError, ValueError):
                    text, pid = "", 0
                if pid and pid_alive(pid):
                    raise self._refuse(text) from None
                self.path.unlink(missing_ok=True)  # stale: its writer is gone
                continue
            with os.fdopen(fd, "w") as f:
                f.write(str(os.getpid()))
            return self
        raise PanoLightError(f"{self.path.parent}: cannot take the output folder's lock {self.path.name}")

    def __exit__(self, *exc):
        self.path.unlink(missing_ok=True)  # removed while still held, so nobody locks a removed file
        if self.fd is not None:
            os.close(self.fd)
            self.fd = None
        return False
