"""Writing files whole or not at all: a temporary sibling renamed into place."""
from __future__ import annotations

import os
import stat
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
    """Whether a process with this pid runs (the owner of a lock or a temporary file). A zombie (killed,
    not yet reaped by its parent) does not run."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # it runs, as another user
        return True
    except (OverflowError, OSError):  # not a pid this system can have
        return False
    try:
        with open(f"/proc/{pid}/stat", "rb") as f:  # Linux: "pid (name) STATE ..."
            return f.read().rsplit(b")", 1)[-1].split()[0] not in (b"Z", b"X")
    except (OSError, IndexError):  # no /proc (macOS): kill(0) is the answer
        return True


def read_small_file(path, limit: int) -> str | None:
    """The text of ``path`` when it is a regular file (not a link, a FIFO or a device: opened without
    following links and without blocking) of at most ``limit`` bytes; None when there is no such file;
    PanoLightError naming it when it is something else or larger (a hostile file is never parsed)."""
    p = Path(path)
    try:
        fd = os.open(p, os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0))
    except FileNotFoundError:
        return None
    except OSError as exc:  # ELOOP: a symbolic link; EACCES; ...
        if p.is_symlink():
            raise PanoLightError(f"{p}: is a symbolic link, not a file PanoLight wrote; remove it") from None
        raise PanoLightError(f"{p}: cannot be read ({exc.strerror or exc})") from None
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise PanoLightError(f"{p}: is not a regular file (a folder, FIFO or device), so not one PanoLight "
                                 f"wrote; remove it")
        if st.st_size > limit:
            raise PanoLightError(f"{p}: is {st.st_size} bytes, more than PanoLight ever writes there "
                                 f"({limit} at most); remove it")
        with os.fdopen(fd, "rb", closefd=False) as f:
            data = f.read(limit + 1)
    finally:
        os.close(fd)
    if len(data) > limit:
        raise PanoLightError(f"{p}: grew past {limit} bytes while it was read; remove it")
    return data.decode("utf-8", "replace")


class folder_lock:
    """One writer per output folder, for the whole run: an exclusive ``flock`` on OUT/.panolight.lock (the
    kernel releases it when its process dies, however it dies), which holds the writer's pid for the
    message (``name``: another lock file, e.g. one per batch shard). A second writer is refused at once,
    in one line. The lock file is opened without following links and without blocking, and must be a
    regular file with one name: a symbolic or hard link, a FIFO or a device named like the lock is
    refused, never written through (it could point outside the folder). Where ``fcntl`` is missing
    (Windows) the file is created exclusively and a lock whose pid no longer runs is taken over."""

    def __init__(self, folder: Path, name: str = ".panolight.lock"):
        self.path = Path(folder) / name
        self.fd = None

    def _refuse(self, pid_text: str):
        pid = pid_text.strip()
        return PanoLightError(f"{self.path.parent}: another PanoLight process{f' (pid {pid})' if pid else ''} is "
                              f"writing there; wait for it or choose another folder (-o)")

    def _not_a_lock(self, what: str):
        return PanoLightError(f"{self.path}: {what}, not PanoLight's lock file; PanoLight does not write through "
                              f"it: remove it, or choose another output folder (-o)")

    def _open(self) -> int:
        """The lock file's descriptor, created if absent; refuses anything but a regular file of one link."""
        flags = os.O_RDWR | os.O_CREAT | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0) | \
            getattr(os, "O_CLOEXEC", 0)
        try:
            fd = os.open(self.path, flags, 0o644)
        except OSError as exc:
            if self.path.is_symlink():
                raise self._not_a_lock("is a symbolic link") from None
            raise PanoLightError(f"{self.path}: cannot open the output folder's lock ({exc.strerror or exc})") from None
        st = os.fstat(fd)
        problem = ("is a folder, FIFO, socket or device" if not stat.S_ISREG(st.st_mode) else
                   f"is a file with {st.st_nlink} names (a hard link)" if st.st_nlink != 1 else "")
        if problem:
            os.close(fd)
            raise self._not_a_lock(problem)
        return fd

    def __enter__(self):
        try:
            import fcntl
        except ImportError:
            return self._enter_without_flock()
        for _ in range(100):
            fd = self._open()
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError:
                text = os.read(fd, 32).decode("ascii", "replace")
                os.close(fd)
                raise self._refuse(text) from None
            if self._is_ours(fd):
                os.ftruncate(fd, 0)
                os.write(fd, str(os.getpid()).encode())
                self.fd = fd
                return self
            os.close(fd)  # its last holder removed it as we opened it: take a fresh one
        raise PanoLightError(f"{self.path.parent}: cannot take the output folder's lock {self.path.name}")

    def _is_ours(self, fd: int) -> bool:
        """Whether the lock's name still names the file ``fd`` holds (no link put in its place)."""
        try:
            return os.lstat(self.path).st_ino == os.fstat(fd).st_ino
        except FileNotFoundError:
            return False

    def _enter_without_flock(self):
        for _ in range(2):
            try:
                fd = os.open(self.path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
            except FileExistsError:
                text = read_small_file(self.path, 64) or ""  # refuses a link or anything but a file
                try:
                    pid = int(text.strip() or 0)
                except ValueError:
                    pid = 0
                if pid and pid_alive(pid):
                    raise self._refuse(text) from None
                self.path.unlink(missing_ok=True)  # stale: its writer is gone
                continue
            with os.fdopen(fd, "w") as f:
                f.write(str(os.getpid()))
            return self
        raise PanoLightError(f"{self.path.parent}: cannot take the output folder's lock {self.path.name}")

    def __exit__(self, *exc):
        if self.fd is None or self._is_ours(self.fd):  # never a link someone put in its place
            self.path.unlink(missing_ok=True)  # removed while still held, so nobody locks a removed file
        if self.fd is not None:
            os.close(self.fd)
            self.fd = None
        return False
