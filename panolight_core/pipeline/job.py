"""A panorama file in, a lighting folder out: the job behind ``panolight estimate`` and ``batch``."""
from __future__ import annotations

import logging
import os
import time
import warnings
from pathlib import Path

import numpy as np

from .. import sh
from ..camera import linear, units
from ..camera.resample import area_downsample_rows
from ..errors import PanoLightError, PanoLightWarning, naming
from ..estimators.keylight import key_light_note
from ..io import ownership, read_image, write_image, write_srgb8
from ..io.atomic import folder_lock
from ..io.capture import read_capture, read_exposure
from ..io.checks import file_state
from ..io.images import PACKED_ABOVE_MEGAPIXELS, RAW_FORMAT, sniff_format, write_exr_rows
from ..io.lighting import write_lighting
from ..io.read_raw import read_raw
from ..io.staging import clean_stale, make_stage
from .brackets import BracketSet, read_brackets
from .estimate import estimate_lighting, require_finite
from .settings import Settings, check_map_cost

logger = logging.getLogger(__name__)

OUTPUT_GROUPS = {  # --outputs: what each group writes
    "lighting": ("lighting.json", "radiance.exr", "lighting.usda"),  # the model; usda needs usd-core
    "hdr": ("hdr.exr",),  # the full-resolution HDR panorama (the costly one at 8K-16K)
    "previews": ("irradiance.exr", "preview.png", "clipped.png"),  # clipped.png: a bracket set's only
}
OUTPUT_FILES = ("lighting.json", "hdr.exr", "radiance.exr", "irradiance.exr", "preview.png", "clipped.png",
                "lighting.usda")


def parse_outputs(text) -> tuple[str, ...]:
    """'lighting,hdr' (or a sequence of group names; 'all' for every group) -> the OUTPUT_GROUPS chosen,
    in table order. lighting is always written (it is the record the others belong to)."""
    names = [n.strip() for n in (text.split(",") if isinstance(text, str) else text) if n.strip()]
    if names == ["all"]:
        return tuple(OUTPUT_GROUPS)
    bad = [n for n in names if n not in OUTPUT_GROUPS]
    if bad or not names:
        raise PanoLightError(f"--outputs takes 'all' or a comma-separated list of {', '.join(OUTPUT_GROUPS)}, "
                             f"got {text!r}")
    return tuple(g for g in OUTPUT_GROUPS if g in names or g == "lighting")


def run_estimate(src, out_dir, settings: Settings = Settings(), *, resolution=(512, 256),
                 repair_nonfinite: bool = False, max_megapixels: float | None = None, overwrite: bool = False,
                 outputs=tuple(OUTPUT_GROUPS)) -> dict:
    """Estimate the lighting of panorama ``src`` (a file, or a ``brackets.BracketSet`` of exposures merged into one
    HDR first; pipeline.estimate_lighting with ``settings``) and write
    the files of the ``outputs`` groups (OUTPUT_GROUPS) into ``out_dir`` (created). resolution: (W, H) of
    radiance.exr / irradiance.exr. max_megapixels: the decoding budget (io.images). The folder is locked
    for the whole run (a second writer is refused at once). Output-named files that PanoLight did not
    write there (io.ownership's manifest) are refused unless ``overwrite``; an earlier run's outputs that
    this run does not write are removed, a user's are kept, so the folder never mixes two runs. Returns
    the lighting document written; progress goes to the ``panolight_core.pipeline.job`` logger (INFO).
    Raises PanoLightError."""
    src = src if isinstance(src, BracketSet) else Path(src)
    out_dir = Path(out_dir)
    outputs = parse_outputs(outputs)
    check_map_cost(settings.order, resolution[1])
    for name in OUTPUT_FILES:  # an output never replaces the input (estimate hdr.exr -o . would)
        for path in _paths(src):
            if _same_file(out_dir / name, path):
                raise PanoLightError(f"{path}: the output {name} in {out_dir} would overwrite the input; "
                                     f"choose another output folder (-o)")
    created = not out_dir.exists()
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise PanoLightError(f"{out_dir}: cannot create the output folder ({exc.strerror or exc})") from None
    try:
        with folder_lock(out_dir):  # the whole run: a second writer is refused before it reads anything
            clean_stale(out_dir, {ownership.MANIFEST: "files"})  # what a killed run left, proven its own
            writes = _planned_files(outputs, isinstance(src, BracketSet))
            _check_destinations(out_dir, writes)
            if not overwrite:
                _check_foreign_outputs(out_dir, writes)
            return _estimate_into(src, out_dir, settings, resolution, repair_nonfinite, max_megapixels, outputs)
    except BaseException:  # refused or interrupted: a folder this run made is not left behind
        if created and out_dir.is_dir() and not any(out_dir.iterdir()):
            out_dir.rmdir()
        raise


def _paths(src) -> tuple:
    """The input files of a run: one panorama, or a ``BracketSet``'s frames."""
    return src.paths if isinstance(src, BracketSet) else (src,)


def _same_file(a: Path, b: Path) -> bool:
    try:
        return a.resolve() == b.resolve()
    except (OSError, RuntimeError):  # a symlink loop: reading it fails later, with its name
        return False


def _planned_files(outputs, bracket: bool = False) -> tuple[str, ...]:
    """The files a run with these output groups writes (lighting.usda only where usd-core is installed; clipped.png
    only for a ``bracket`` set)."""
    from ..io.usd import usd_available

    names = [n for g in outputs for n in OUTPUT_GROUPS[g]]
    return tuple(n for n in OUTPUT_FILES if n in names and (n != "lighting.usda" or usd_available())
                 and (n != "clipped.png" or bracket))


def _estimate_into(src, out_dir, settings, resolution, repair_nonfinite, max_megapixels, outputs) -> dict:
    t0 = time.perf_counter()
    logger.info("reading %s", src)
    states = [file_state(p) for p in _paths(src)]  # what the estimate reads: checked again once it is hashed
    budget = {} if max_megapixels is None else {"max_megapixels": max_megapixels}
    bracket = raw = None
    if isinstance(src, BracketSet):
        pixels, bracket = read_brackets(src.paths, src.evs, src.align, **budget)
        logger.info(f"merged {len(src.paths)} frames (exposures from {bracket['exposures_from']}; "
                    f"{', '.join(f'{v:+g}' for v in bracket['stops'])} stops"
                    f"{'; ' + bracket['response']['curve'] + ' curve' if 'response' in bracket else ''}; ceiling "
                    f"{bracket['ceiling']:g}x the "
                    f"reference's white, {100 * bracket['clipped_in_every_frame']:.2g} % of pixels clipped in every "
                    f"frame)")
    elif sniff_format(src) == RAW_FORMAT:  # linear, in its sensor's white: an HDR whose ceiling is 1
        pixels, raw = read_raw(src, **budget)
        logger.info(f"decoded the camera RAW ({raw['reader']}; white balance {raw['white_balance']}; "
                    f"{100 * raw['sensor_clipped_fraction']:.2g} % of pixels clipped by the sensor)")
    else:
        pixels = read_image(src, ldr_as_uint8=True, nonfinite="repair" if repair_nonfinite else "error",
                            packed_above=PACKED_ABOVE_MEGAPIXELS, **budget)
    t_read = time.perf_counter() - t0
    scaled = f", sun strength {settings.sun_strength:g}" if settings.sun_strength != 1.0 else ""
    logger.info(f"estimating ({settings.estimator}, model {settings.model}, lmax {settings.lmax or 'default'}{scaled}) "
                f"on {pixels.shape[1]}x{pixels.shape[0]}")
    try:
        photo = src if bracket is None else src.paths[bracket["reference"]]  # a set: its reference frame's
        camera = pixels.dtype == np.uint8 or bracket or raw  # a picture whose white is its camera's
        capture = read_capture(photo) if camera and settings.sun_direction is None and settings.sun_metadata else None
        exposure = read_exposure(photo) if camera else None  # the absolute scale (camera.units): the set's reference
        result = estimate_lighting(pixels, settings, capture, exposure)
    except PanoLightError as exc:
        raise naming(src, exc) from None
    for problem in result.warnings:
        warnings.warn(f"{src}: {problem}", PanoLightWarning, stacklevel=4)
    fitted = result.model
    w, h = resolution
    logger.info(f"reconstructing radiance and irradiance at {w}x{h}" +
        (f" ({len(fitted.lights)} light(s))" if fitted.lights else ""))
    with np.errstate(over="ignore", invalid="ignore"):
        emitter, made = sh.emitter_map(fitted.coeffs, h, w)  # no negative light, the same bands 0-2
        maps = {"radiance.exr": emitter.astype(np.float32)}
        if "previews" in outputs:
            maps["irradiance.exr"] = fitted.irradiance_map(h, w).astype(np.float32)
    require_finite(maps, settings.exposure_ev, f"{src}: ")  # refused before anything is written
    doc = result.document
    digests = []
    for path, state in zip(_paths(src), states):
        found = ownership.digest(path)
        if found is None:
            raise PanoLightError(f"{path}: could not be read again to record its SHA-256 (was it moved?)")
        if file_state(path) != state:  # written to since it was read: the estimate is of another picture
            raise PanoLightError(f"{path}: was changed while it was being estimated: estimate it again")
        digests.append(found["sha256"])
    doc["source"] = {"path": str(photo), "sha256": digests[_paths(src).index(photo)],
                     "width": int(pixels.shape[1]), "height": int(pixels.shape[0]),
                     "dynamic_range": ("ldr-8bit-srgb" if pixels.dtype == np.uint8 else "raw-linear" if raw else
                                       "hdr" if bracket is None else "hdr-merged-brackets")}
    if bracket is not None:  # every frame, and how the set was merged
        doc["source"]["brackets"] = {**bracket, "sha256": digests}
    if raw is not None:  # how the sensor's data was decoded
        doc["source"]["raw"] = raw
    doc["timings"] = {"read_s": round(t_read, 6), **doc["timings"]}
    doc.setdefault("model", {}).setdefault("ringing", {})["emitter"] = {
        "negative_fraction": round(made["negative_fraction"], 6), "moment_error": made["moment_error"]}
    logger.info("units: " + units.summary(doc.get("physical")))
    note = key_light_note(doc)
    if note:
        logger.info("note: %s", note)
    logger.info("writing %s/", out_dir)
    return _write_outputs(out_dir, src, pixels, doc, result, maps, outputs, settings.exposure_ev)


def _write_outputs(out_dir, src, pixels, doc, result, maps, outputs, exposure_ev) -> dict:
    t2 = time.perf_counter()
    import shutil

    from ..io.usd import usd_available, write_usd

    # the whole set is written into a private folder and renamed into place, lighting.json last: an
    # interrupted run leaves nothing half-done, and readers never see a mix of two runs
    stage = make_stage(out_dir)
    written = []
    try:
        fitted = result.model
        for name, image in maps.items():  # RLE: the fastest lossless codec for smooth maps
            write_image(stage / name, image, compression="rle")
            written.append(name)
        if "hdr" in outputs:  # streamed by row blocks (PIZ: the fast lossless codec for photographs)
            rows = result.hdr_blocks(pixels)
            write_exr_rows(stage / "hdr.exr", pixels.shape[0], pixels.shape[1], rows, half=rows.fits_half(),
                           check=lambda block: require_finite({"hdr.exr": block}, exposure_ev, f"{src}: "))
            written.append("hdr.exr")
        if "previews" in outputs:
            from .preview import PREVIEW_HEIGHT, estimate_preview

            shown = area_downsample_rows(pixels, min(PREVIEW_HEIGHT, pixels.shape[0]), linear)
            write_srgb8(stage / "preview.png", estimate_preview(shown, maps["radiance.exr"], fitted,
                                                                sh.lmax_from_count(fitted.coeffs.shape[0]),
                                                                irradiance_map=maps["irradiance.exr"],
                                                                exposure=1.0 if pixels.dtype == np.uint8 else None,
                                                                model_gain=result.scale))
            written.append("preview.png")
            ceiling = ((doc.get("source") or {}).get("brackets") or {}).get("ceiling")
            if ceiling:  # a bracket set: what it could not capture, clipped in every frame
                write_srgb8(stage / "clipped.png", clipped_mask(pixels, ceiling))
                written.append("clipped.png")
        if usd_available():
            write_usd(stage / "lighting.usda", doc, hdri="hdr.exr" if "hdr" in outputs else None)
            written.append("lighting.usda")
        else:
            warnings.warn("lighting.usda not written: usd-core is not installed (pip install usd-core)",
                          PanoLightWarning, stacklevel=3)
        doc["timings"]["write_s"] = round(time.perf_counter() - t2, 6)
        write_lighting(stage / "lighting.json", doc)
        written.append("lighting.json")
        # the manifest proves which files are ours: while the set is renamed into place it accepts the
        # replaced files too, so an interruption between two renames never makes our own files foreign
        digests = {name: ownership.written(stage / name) for name in written}
        earlier = ownership.current(out_dir, OUTPUT_FILES)  # again, under the lock: the run may be long
        _check_destinations(out_dir, written)  # every rename can succeed before the first is made
        ownership.record(out_dir, digests, keep=earlier)
        for name in written[:-1]:
            _move(stage / name, out_dir / name)
        stale = [n for n in OUTPUT_FILES if n not in written and n in earlier]  # only ours: a user's is kept
        for name in stale:  # an earlier run's outputs this run did not write: never a mix of runs
            (out_dir / name).unlink(missing_ok=True)
        if stale:
            logger.info("removed %s: an earlier run's output(s) that this run's --outputs does not write",
                        ", ".join(stale))
        _move(stage / "lighting.json", out_dir / "lighting.json")  # last: it marks the set complete
        ownership.record(out_dir, digests)
    except PanoLightError as exc:  # a full disk, a size limit: named as the output, not the staging copy
        raise PanoLightError(str(exc).replace(str(stage), str(out_dir))) from None
    finally:
        shutil.rmtree(stage, ignore_errors=True)
    return doc


def clipped_mask(pixels: np.ndarray, ceiling: float) -> np.ndarray:
    """(H, W, 3) uint8: white where a merged bracket set's pixel is clipped in every frame (a channel at the set's
    ``ceiling``, the darkest frame's white: ``camera.brackets.merge_brackets``), black elsewhere; by row blocks."""
    h = pixels.shape[0]
    out = np.zeros(pixels.shape[:2] + (3,), np.uint8)
    level = np.float32(ceiling * (1.0 - 1e-6))
    for r in range(0, h, 256):
        out[r:r + 256] = (np.asarray(pixels[r:r + 256]).max(axis=-1) >= level)[..., None] * np.uint8(255)
    return out


def _move(src: Path, dest: Path) -> None:
    """Rename a staged file into place; a failure names the user's path, not the staging copy."""
    try:
        os.replace(src, dest)
    except OSError as exc:
        raise PanoLightError(f"{dest}: cannot replace it ({exc.strerror or exc})") from None


def _check_destinations(out_dir: Path, names) -> None:
    """Refuse, before anything is renamed into place, a destination that a file cannot replace (a folder
    of the user's named like an output): the run then leaves the folder as it was, never half of two runs."""
    for name in names:
        dest = out_dir / name
        if dest.is_dir() and not dest.is_symlink():
            raise PanoLightError(f"{dest}: is a folder, and PanoLight writes a file of that name; move it or choose "
                                 f"another output folder (-o)")


def _check_foreign_outputs(out_dir: Path, writes) -> None:
    """Refuse to replace files PanoLight did not write there: each output name this run writes must be
    absent or match the folder's manifest (io.ownership: size and SHA-256 of what the last run wrote), so
    a copied lighting.json proves nothing about its neighbours (``overwrite=True`` / --overwrite
    replaces them). Foreign files of names this run does not write are kept, and said so."""
    kept = ownership.foreign(out_dir, [n for n in OUTPUT_FILES if n not in writes])
    if kept:
        warnings.warn(f"{out_dir}: keeping {', '.join(kept)}, which PanoLight did not write (they are not part "
                      f"of this run's outputs)", PanoLightWarning, stacklevel=4)
    present = ownership.foreign(out_dir, writes)
    if present:
        raise PanoLightError(f"{out_dir}: {', '.join(present)} exist and were not written by PanoLight; "
                             f"choose another folder (-o) or pass --overwrite to replace them")
