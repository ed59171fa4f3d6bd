"""Many panoramas: input collection, deterministic sharding, a progress line and a report."""
from __future__ import annotations

import hashlib
import json
import re
import sys
import time
import warnings
from pathlib import Path

from ..errors import PanoLightError, PanoLightWarning, printable
from ..estimators.keylight import key_light_note
from ..io.atomic import atomic_path, folder_lock, read_small_file
from ..io.checks import RAW_EXTENSIONS, TIFF_EXTENSIONS
from ..io.metadata import json_object
from ..io.ownership import MANIFEST, digest
from ..io.staging import clean_stale
from .workers import keep_freed_memory, run_workers

EXTENSIONS = (".exr", ".hdr", ".png", ".jpg", ".jpeg") + TIFF_EXTENSIONS + RAW_EXTENSIONS
UNREAD_EXTENSIONS = (".heic", ".heif", ".hif", ".avif")  # a phone's default photos: a folder's are said, not taken


def collect_inputs(paths, list_file=None, recursive: bool = False, exclude=None) -> list[Path]:
    """Files named directly, panoramas found in named folders (by extension), and lines of ``list_file``
    (blank lines and '#' comments skipped). Sorted and de-duplicated, so every copy of a sharded job
    sees the same order. Missing entries are kept: they are reported as failures, not dropped. Nothing
    at or under ``exclude`` (the output folder) is ever an input: a batch never reads its own outputs
    (skipped files are said in a PanoLightWarning)."""
    found = []
    entries = [Path(p) for p in paths]
    if list_file is not None:
        lf = Path(list_file)
        if not lf.is_file():
            raise PanoLightError(f"{lf}: input list not found")
        base = lf.parent
        try:
            text = lf.read_text(encoding="utf-8")
        except UnicodeDecodeError:
            raise PanoLightError(f"{lf}: not a text list of panorama paths (binary data)") from None
        if "\x00" in text:
            raise PanoLightError(f"{lf}: not a text list of panorama paths (binary data)")
        for line in text.splitlines():
            line = line.strip()
            if line and not line.startswith("#"):
                p = Path(line)
                entries.append(p if p.is_absolute() else base / p)
    unread = []
    for p in entries:
        if _is_dir(p):
            for f in p.glob("**/*" if recursive else "*"):  # one walk of the folder: its panoramas and its phone photos
                suffix = f.suffix.lower()
                if suffix in EXTENSIONS + UNREAD_EXTENSIONS and _is_file(f):
                    (found if suffix in EXTENSIONS else unread).append(f)
        else:
            found.append(p)
    if unread:
        warnings.warn(f"skipping {len(unread)} HEIF (HEIC) or AVIF photo(s), e.g. {sorted(unread)[0]}: a phone's "
                      f"default format, which PanoLight does not decode (save or export them as JPEG with their EXIF, "
                      f"or shoot RAW)", PanoLightWarning, stacklevel=2)
    inputs = sorted({_resolved(f) for f in found}, key=str)
    if exclude is None:
        return inputs
    out = _resolved(Path(exclude))
    kept = [f for f in inputs if f != out and out not in f.parents]
    if len(kept) < len(inputs):
        warnings.warn(f"skipping {len(inputs) - len(kept)} file(s) inside the output folder {out}: a batch "
                      f"never takes its own outputs as inputs", PanoLightWarning, stacklevel=2)
    return kept


def _is_dir(p: Path) -> bool:
    try:
        return p.is_dir()
    except OSError:  # a symlink loop, a name too long: it fails later, as one input, with its reason
        return False


def _is_file(p: Path) -> bool:
    try:
        return p.is_file()
    except OSError:
        return False


def _resolved(p: Path) -> Path:
    try:
        return p.resolve()
    except (OSError, RuntimeError):  # a symlink loop: kept as given, reported as a failed input
        return p.absolute()


def parse_shard(text: str | None) -> tuple[int, int]:
    """'I/N' with 1 <= I <= N -> (I, N); None -> (1, 1)."""
    if text is None:
        return 1, 1
    try:
        i, n = (int(v) for v in text.split("/"))
    except ValueError:
        raise PanoLightError(f"--shard must look like I/N (e.g. 2/4), got {text!r}") from None
    if not 1 <= i <= n:
        raise PanoLightError(f"--shard I/N needs 1 <= I <= N, got {text!r}")
    return i, n


def shard(items: list, index: int, count: int) -> list:
    """The items of shard ``index`` (1-based) of ``count``: every count-th item starting at index - 1."""
    return items[index - 1::count]


def _safe_name(stem: str) -> str:
    """A folder name that stays inside the output folder: letters, digits, '-', '_' and inner dots only
    (an input named '...png' has the stem '..', which must not become OUT/..)."""
    name = re.sub(r"[^A-Za-z0-9._-]+", "_", stem).lstrip(".")
    return name or "panorama"


RESERVED = re.compile(r"^batch_report.*\.json$", re.IGNORECASE)  # the reports batch writes beside the folders


def output_names(inputs: list[Path]) -> dict[Path, str]:
    """Folder name per input, unique by construction (compared without case, for case-insensitive file
    systems): its sanitised stem (``_safe_name``) where no other input has it; else, and for names of the
    reports (``batch_report*.json``), the stem plus a short hash of the full path, with a counter if even
    that is taken (an input may be named like another's hashed folder). Computed over the full
    (unsharded), sorted list, so all shards agree."""
    safe = {p: _safe_name(p.stem) for p in inputs}
    counts: dict[str, int] = {}
    for name in safe.values():
        counts[name.lower()] = counts.get(name.lower(), 0) + 1
    names = {p: name for p, name in safe.items() if counts[name.lower()] == 1 and not RESERVED.match(name)}
    taken = {name.lower() for name in names.values()}
    for p in sorted((p for p in inputs if p not in names), key=str):
        base = f"{safe[p]}-{hashlib.sha1(str(p).encode()).hexdigest()[:8]}"
        name, k = base, 1
        while name.lower() in taken or RESERVED.match(name):
            k += 1
            name = f"{base}-{k}"
        names[p] = name
        taken.add(name.lower())
    return {p: names[p] for p in inputs}


class Progress:
    """A one-line progress bar on stderr (a line per item when stderr is not a terminal)."""

    def __init__(self, total: int, quiet: bool = False, stream=None):
        self.total, self.done, self.quiet = total, 0, quiet
        self.stream = stream or sys.stderr
        self.tty = hasattr(self.stream, "isatty") and self.stream.isatty()
        self.start = time.perf_counter()

    def step(self, name: str, status: str):
        self.done += 1
        if self.quiet:
            return
        elapsed = time.perf_counter() - self.start
        eta = elapsed / self.done * (self.total - self.done)
        width = 24
        filled = int(width * self.done / max(1, self.total))
        bar = "#" * filled + "-" * (width - filled)
        line = f"[{bar}] {self.done}/{self.total} {status:<6} {printable(name)}  (eta {eta:.0f} s)"
        if self.tty:
            self.stream.write("\r" + line[:120].ljust(120))
            if self.done == self.total:
                self.stream.write("\n")
        else:
            self.stream.write(line + "\n")
        self.stream.flush()


SIDECAR = ".panolight-batch.json"  # per output folder: the input's SHA-256 and the settings it was made with


def _sha256(path) -> str | None:
    """The file's SHA-256 (a bracket set's: of its frames' in order), or None when one cannot be read (the job
    then reports why)."""
    if hasattr(path, "paths"):  # a pipeline.brackets.BracketSet
        found = [_sha256(p) for p in path.paths]
        return None if None in found else hashlib.sha256(" ".join(found).encode()).hexdigest()
    d = digest(path)
    return d and d["sha256"]


def _up_to_date(digest: str | None, dst: Path, settings) -> bool:
    """True when dst holds a complete output set made from the file of this digest with these settings."""
    if digest is None:
        return False
    try:
        side = json_object(read_small_file(dst / SIDECAR, 1 << 20)) or {}
    except PanoLightError:
        return False
    return (dst / "lighting.json").is_file() and side.get("settings") == settings and side.get("sha256") == digest


def _clean_stale(dst: Path) -> None:
    """Remove what a killed earlier run left in dst, and only what PanoLight can prove it made there
    (io.staging: marked staging folders, temporaries of its own records)."""
    if dst.is_dir():
        clean_stale(dst, {MANIFEST: "files", SIDECAR: "settings"})


def _write_json(path: Path, doc) -> None:
    with atomic_path(path) as tmp:
        tmp.write_text(json.dumps(doc, indent=2) + "\n", encoding="utf-8")


def _process(job, src: Path, dst: Path, settings) -> dict:
    """One input: skip it if up to date, else run ``job(src, dst)`` and record how it was made. Never
    raises for a bad input (the result says why); runs in a batch worker or in the batch process."""
    t = time.perf_counter()
    _clean_stale(dst)
    try:
        digest = _sha256(src)
        if _up_to_date(digest, dst, settings):
            return {"input": str(src), "status": "skipped", "output": str(dst),
                    "why": "up to date (same input and settings)"}
        (dst / SIDECAR).unlink(missing_ok=True)
        with warnings.catch_warnings(record=True) as said:
            warnings.simplefilter("always", PanoLightWarning)
            doc = job(src, dst)
        _write_json(dst / SIDECAR, {"sha256": digest, "settings": settings})
        result = {"input": str(src), "status": "ok", "output": str(dst), "seconds": round(time.perf_counter() - t, 4)}
        notes = [str(w.message) for w in said if issubclass(w.category, PanoLightWarning)]
        if notes:
            result["warnings"] = notes
        note = key_light_note(doc) if isinstance(doc, dict) else ""
        result = {**result, "key_light": note} if note else result
        left = _left_out(doc) if hasattr(src, "paths") else []
        return _alone(job, left, result, f"{len(left)} frame(s) left out of the set were estimated alone", dst,
                      settings) if left else result
    except PanoLightError as exc:
        error = str(exc)
        if hasattr(src, "paths"):  # a bracket set refused: each frame is still a photo to estimate
            return _frames_alone(job, src, dst, settings, error, t)
    except (KeyboardInterrupt, SystemExit):
        raise
    except Exception as exc:  # keep going past anything one file can cause; the report names it
        error = f"{type(exc).__name__}: {exc}"
    return {"input": str(src), "status": "failed", "error": error, "seconds": round(time.perf_counter() - t, 4)}


def _alone(job, files, result: dict, note: str, dst: Path, settings) -> dict:
    """``result`` with ``files`` (a bracket set's frames) each estimated alone into ``dst/<frame>/`` and ``note``
    saying why: a batch never ends with no output for a photo that could be estimated. "failed" when one of them
    fails."""
    frames = [_process(job, Path(p), dst / Path(p).stem, settings) for p in files]
    failed = [f for f in frames if f["status"] == "failed"]
    result = {**result, "note": note, "frames": frames}
    if failed:
        result.update(status="failed", error="; ".join(f["error"] for f in failed))
    return result


def _frames_alone(job, src, dst: Path, settings, why: str, t: float) -> dict:
    """A refused bracket set's frames, each estimated alone (``_alone``); the report entry says why the set was
    refused and what each frame got; "ok" when every frame was estimated."""
    result = _alone(job, src.paths, {"input": str(src), "status": "ok", "output": str(dst)},
                    f"the set was refused ({why}): its frames were estimated alone", dst, settings)
    return {**result, "seconds": round(time.perf_counter() - t, 4)}


def _left_out(doc) -> list[str]:
    """The files a bracket set's merge left out (lighting.json's ``source.brackets.left_out``), or none."""
    brackets = (doc.get("source") or {}).get("brackets") if isinstance(doc, dict) else None
    return [d["file"] for d in (brackets or {}).get("left_out", ()) if isinstance(d, dict) and "file" in d]


def _process_task(task):
    k, job, src, dst, settings = task
    return k, _process(job, src, dst, settings)


def run_batch(inputs: list[Path], out_dir: Path, job, shard_spec=(1, 1), quiet: bool = False,
              settings=None, jobs: int = 1) -> dict:
    """Run ``job(src, dst_dir)`` for this shard's inputs, continuing past failures; resumable.

    jobs > 1 runs that many worker processes (``job`` must then be picklable: a module-level function or
    a functools.partial of one); the report is the same whatever the number, in input order.
    An input whose folder already holds a complete output set made from the same file (SHA-256) with
    the same ``settings`` (a JSON-able dict of the job's options) is skipped. What interrupted runs left
    is cleaned first. The report out_dir/batch_report.json (or batch_report-I-of-N.json) is rewritten
    after every input, so an interrupted run leaves an accurate record of this run alone ("interrupted":
    true); per input: status ("ok", "skipped" or "failed"), output folder or error, seconds.
    """
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise PanoLightError(f"{out_dir}: cannot create the output folder ({exc.strerror or exc})") from None
    # one batch per output folder (and shard: the shards of one job run side by side) at a time
    i, n = shard_spec
    with folder_lock(out_dir, ".panolight.lock" if n == 1 else f".panolight-shard-{i}-of-{n}.lock"):
        return _run_locked(inputs, out_dir, job, shard_spec, quiet, settings, jobs)


def _run_locked(inputs, out_dir, job, shard_spec, quiet, settings, jobs) -> dict:
    names = output_names(inputs)
    mine = shard(inputs, *shard_spec)
    prog = Progress(len(mine), quiet)
    done: dict[int, dict] = {}
    i, n = shard_spec
    report_path = out_dir / ("batch_report.json" if n == 1 else f"batch_report-{i}-of-{n}.json")

    def report(interrupted=False):
        results = [done[k] for k in sorted(done)]
        doc = {"shard": f"{i}/{n}", "total_inputs": len(inputs), "this_shard": len(mine), "settings": settings,
               "ok": sum(r["status"] == "ok" for r in results),
               "skipped": sum(r["status"] == "skipped" for r in results),
               "failed": sum(r["status"] == "failed" for r in results),
               "interrupted": interrupted, "results": results}
        _write_json(report_path, doc)
        return doc

    def record(k, result):
        done[k] = result
        shown = " + ".join(Path(part).name for part in result["input"].split(" + "))  # a bracket set: its frames
        prog.step(shown, {"ok": "ok", "skipped": "skip"}.get(result["status"], "FAILED"))
        report()

    tasks = [(k, job, src, out_dir / names[src], settings) for k, src in enumerate(mine)]
    report()
    keep_freed_memory()
    try:
        if jobs <= 1 or len(tasks) <= 1:
            for task in tasks:
                record(*_process_task(task))
        else:
            run_workers(tasks, jobs, _process_task, record)
    except KeyboardInterrupt:  # Ctrl-C or SIGTERM (the workers are stopped): the report says how far it got
        report(interrupted=True)
        raise
    doc = report()
    doc["report_path"] = str(report_path)
    return doc
