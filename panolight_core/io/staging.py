"""Private staging folders, and cleaning what a killed run left: only what PanoLight can prove it made.

A run writes its set into ``OUT/.panolight-PID-XXXX/`` (a fresh folder, never one that existed) holding a
marker file that names the writing process, then renames the files into place. A run killed with
SIGKILL leaves that folder behind; the next run into OUT removes it when its marker proves it is
PanoLight's and its process is gone. A folder without the marker, a file of the user's that merely looks
like a temporary name, and anything below a staging folder's top level are never deleted.
"""
from __future__ import annotations

import json
import logging
import os
import re
import stat
import tempfile
from pathlib import Path

from ..errors import PanoLightError
from .atomic import pid_alive, read_small_file
from .metadata import integer, json_object

logger = logging.getLogger(__name__)

MARKER = ".panolight-staging"  # {"tool": "panolight", "pid": N}: proves the folder is a run's staging
_STAGE = re.compile(r"^\.panolight-(\d{1,10})(?:-[A-Za-z0-9_]{1,32})?$")
_TEMP = re.compile(r"^\.(.+)\.tmp(\d{1,10})(\.[A-Za-z]{1,8})?$")  # atomic.atomic_path's names, anchored


def make_stage(folder) -> Path:
    """A new, empty staging folder in ``folder`` (same file system: the renames out of it are atomic),
    marked as this process's. PanoLightError when it cannot be made."""
    folder = Path(folder)
    try:
        stage = Path(tempfile.mkdtemp(prefix=f".panolight-{os.getpid()}-", dir=folder))
        (stage / MARKER).write_text(json.dumps({"tool": "panolight", "pid": os.getpid()}), encoding="utf-8")
    except OSError as exc:
        raise PanoLightError(f"{folder}: cannot write there ({exc.strerror or exc})") from None
    return stage


def _marker_pid(stage: Path) -> int | None:
    """The pid a staging folder's marker names, or None when it has no valid marker."""
    try:
        doc = json_object(read_small_file(stage / MARKER, 256)) or {}
    except PanoLightError:
        return None
    return integer(doc.get("pid"), 1, 1 << 32) if doc.get("tool") == "panolight" else None


def _is_record(path: Path, key: str) -> bool:
    """Whether ``path`` is a regular file holding a JSON object with ``key`` (what PanoLight writes)."""
    try:
        doc = json_object(read_small_file(path, 1 << 20))
    except PanoLightError:
        return False
    return doc is not None and key in doc


def clean_stale(folder, records: dict[str, str] | None = None) -> list[str]:
    """Remove what killed PanoLight runs left in ``folder``; returns the names removed.

    - a staging folder ``.panolight-PID[-X]`` whose marker names PID, when PID no longer runs: its
      regular files, then the folder (kept when anything else is inside);
    - a temporary ``.NAME.tmpPID`` of a record PanoLight writes there (``records``: NAME -> a key its
      JSON object always has, e.g. the manifest's "files"), when PID no longer runs and the file is such
      a record.
    Nothing is followed through a link; nothing else is touched."""
    folder = Path(folder)
    removed = []
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return removed
    for e in entries:
        st = e.stat(follow_symlinks=False)
        m = _STAGE.match(e.name)
        if m and stat.S_ISDIR(st.st_mode):
            pid = int(m.group(1))
            if _marker_pid(Path(e.path)) == pid and not pid_alive(pid) and _remove_stage(Path(e.path)):
                removed.append(e.name)
            continue
        t = _TEMP.match(e.name)
        if t and stat.S_ISREG(st.st_mode) and t.group(1) in (records or {}) and not t.group(3):
            if not pid_alive(int(t.group(2))) and _is_record(Path(e.path), records[t.group(1)]):
                Path(e.path).unlink(missing_ok=True)
                removed.append(e.name)
    if removed:
        logger.info("removed what an interrupted PanoLight run left in %s: %s", folder, ", ".join(sorted(removed)))
    return removed


def _remove_stage(stage: Path) -> bool:
    """A proven staging folder's regular files, then the folder itself if nothing else is left."""
    for e in os.scandir(stage):
        if e.is_file(follow_symlinks=False) or e.is_symlink():
            Path(e.path).unlink(missing_ok=True)
    try:
        stage.rmdir()
    except OSError:  # something else (a folder) is inside: left as it is
        return False
    return True
