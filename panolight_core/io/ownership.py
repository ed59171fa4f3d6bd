"""Which files in a folder PanoLight wrote: a manifest of each file's content (size, SHA-256) and identity (device
and inode), so a run replaces or removes only its own files. A copied lighting.json proves nothing about its
neighbours, and a manifest written by hand that lists a user's file by its content does not make it ours: the file
must still be the one PanoLight wrote (renaming a file into place keeps its inode; a copy or a rewrite by another
program is another file). The ctime is not part of the identity: a rename, a chmod or a backup tool moves it."""
from __future__ import annotations

import hashlib
import json
import re
from pathlib import Path

from ..errors import PanoLightError
from .atomic import atomic_path, read_small_file
from .metadata import integer, json_object, too_deep

MANIFEST = ".panolight-files.json"  # {"files": {name: [{"size": bytes, "sha256": hex, "dev": int, "ino": int}, ...]}}


def digest(path) -> dict | None:
    """{"size", "sha256"} of a file, or None when it cannot be read."""
    h = hashlib.sha256()
    try:
        with open(path, "rb") as f:
            size = 0
            for block in iter(lambda: f.read(1 << 22), b""):
                h.update(block)
                size += len(block)
    except OSError:
        return None
    return {"size": size, "sha256": h.hexdigest()}


def written(path) -> dict | None:
    """``digest`` of a file PanoLight just wrote, with its identity (``dev``, ``ino``): a manifest's entry."""
    import os

    found = digest(path)
    try:
        st = os.stat(path)
    except OSError:
        return None
    return None if found is None else {**found, "dev": st.st_dev, "ino": st.st_ino}


MANIFEST_MAX_BYTES = 1 << 20  # a manifest lists a few files: ~1 KB; anything this large is not ours


def _entries(folder: Path) -> dict[str, list[dict]]:
    """The manifest's entries; {} when there is none or it is not a manifest (nothing is owned then).
    PanoLightError naming it when it is not a regular file, over MANIFEST_MAX_BYTES, or nested too deep
    to parse: a hostile manifest is refused, never parsed at any cost."""
    path = Path(folder) / MANIFEST
    text = read_small_file(path, MANIFEST_MAX_BYTES)
    if text is None:
        return {}
    doc = json_object(text, MANIFEST_MAX_BYTES)
    if doc is None and too_deep(text):  # its depth read again only for a manifest that does not parse
        raise PanoLightError(f"{path}: nested too deeply to be PanoLight's manifest; remove it")
    files = (doc or {}).get("files")  # not a manifest: nothing is owned
    if not isinstance(files, dict):
        return {}
    return {str(k): [e for e in v if _entry(e)] for k, v in files.items() if isinstance(v, list)}


def _entry(e) -> bool:
    """Whether a manifest entry has the shape ``written`` gives (ints that are not bools, a 64-digit hex string)."""
    return (isinstance(e, dict) and all(integer(e.get(k), 0, 1 << 64) is not None for k in ("size", "dev", "ino"))
            and re.fullmatch(r"[0-9a-f]{64}", str(e.get("sha256"))) is not None)


def owned(folder, name: str, entries: dict | None = None) -> bool:
    """Whether ``folder/name`` is a file PanoLight wrote there and nobody changed since (size, then hash)."""
    import os
    import stat

    path = Path(folder) / name
    known = (_entries(folder) if entries is None else entries).get(name, [])
    try:
        st = os.stat(path, follow_symlinks=False)
    except OSError:
        return False
    same = [e for e in known if (e["size"], e["dev"], e["ino"]) == (st.st_size, st.st_dev, st.st_ino)]
    if not stat.S_ISREG(st.st_mode) or not same:
        return False
    d = digest(path)
    return d is not None and any(e["sha256"] == d["sha256"] for e in same)


def foreign(folder, names) -> list[str]:
    """The ``names`` that exist in ``folder`` but were not written there by PanoLight."""
    entries = _entries(folder)
    return [n for n in names if _exists(Path(folder) / n) and not owned(folder, n, entries)]


def _exists(path: Path) -> bool:
    return path.exists() or path.is_symlink()


def record(folder, digests: dict[str, dict], keep: dict[str, list[dict]] | None = None) -> None:
    """Write the manifest: ``digests`` (name -> digest) as the files PanoLight wrote, plus ``keep`` (name ->
    earlier digests still accepted, for the moment between renames). Entries of other names whose files
    still match are kept (several tools may write into one folder)."""
    folder = Path(folder)
    old = _entries(folder)
    files = {n: v for n, v in old.items() if n not in digests and owned(folder, n, old)}
    for name, d in digests.items():
        files[name] = [d] + [e for e in (keep or {}).get(name, []) if e != d]
    with atomic_path(folder / MANIFEST) as tmp:
        tmp.write_text(json.dumps({"files": files}, indent=1) + "\n", encoding="utf-8")


def current(folder, names) -> dict[str, list[dict]]:
    """The manifest entries of those ``names`` that are owned now (kept accepted while they are replaced)."""
    entries = _entries(folder)
    return {n: entries[n] for n in names if owned(folder, n, entries)}
