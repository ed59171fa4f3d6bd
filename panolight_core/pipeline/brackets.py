"""Reading a bracket set: several exposures of one scene, merged into one HDR panorama (``camera.brackets``) that
the estimate then takes as an HDR file whose ceiling is the darkest frame's white."""
from __future__ import annotations

import json
import math
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import threads
from ..camera.agreement import frame_agreement, one_scene, same_picture
from ..camera.brackets import check_exposures, exposure, merge_brackets, one_exposure, told_apart
from ..errors import PanoLightError, PanoLightWarning, naming
from ..io.capture import read_exposure
from ..io.images import RAW_FORMAT, read_image, sniff_format
from ..io.metadata import json_object, number, text


@dataclass(frozen=True)
class BracketSet:
    """A bracket set to estimate (``pipeline.run_estimate`` takes it in place of one file): its frames' paths,
    their exposures in stops (None: from each file's EXIF), and whether its frames are aligned (False: a tripod set,
    ``--no-align``)."""

    paths: tuple
    evs: tuple | None = None
    align: bool = True

    def __post_init__(self):
        object.__setattr__(self, "paths", tuple(Path(p) for p in self.paths))

    def __str__(self) -> str:
        return " + ".join(str(p) for p in self.paths)

    def record(self) -> str:
        """The set as JSON text (what Blender keeps on its merged image): ``from_record`` reads it back."""
        return json.dumps({"files": [str(p) for p in self.paths], "evs": list(self.evs) if self.evs else None,
                           "align": self.align})

    @classmethod
    def from_record(cls, raw) -> "BracketSet":
        """The set a ``record`` holds, validated (``io.metadata``): two or more file paths, and None or one
        exposure in stops (within +-30) per file. PanoLightError when ``raw`` is not such a record (an edited
        or damaged one), saying to load the set again."""
        doc = json_object(raw, 1 << 20) or {}
        files, evs = doc.get("files"), doc.get("evs")
        paths = [text(p, 4096) for p in files] if isinstance(files, list) else []
        stops = None if evs is None else [number(v, -30.0, 30.0) for v in evs] if isinstance(evs, list) else [None]
        if len(paths) < 2 or None in paths or (stops is not None and (None in stops or len(stops) != len(paths))):
            raise PanoLightError("the stored bracket set is not a valid record (files, and one exposure in stops "
                                 "per file or none): load the set again")
        return cls(paths, None if stops is None else tuple(stops), doc.get("align") is not False)

    @property
    def stem(self) -> str:
        """The first frame's stem: the set's name (``batch``'s output folder)."""
        return self.paths[0].stem


def group_brackets(files, size: int, evs=None, align: bool = True) -> list[BracketSet]:
    """Sorted ``files`` in consecutive sets of ``size`` frames (a camera's bracket sequence, IMG_0001-0003 ...),
    each with ``evs`` (or None: the files' EXIF). PanoLightError when the files do not divide into whole sets."""
    files = sorted((Path(f) for f in files), key=str)
    if size < 2 or len(files) % size:
        raise PanoLightError(f"--brackets {size}: {len(files)} file(s) do not make whole sets of {size} frames "
                             f"(sorted by name, each set its consecutive files)")
    if evs is not None and len(evs) != size:
        raise PanoLightError(f"--evs gives {len(evs)} exposure(s) for sets of {size} frames: one per frame")
    return [BracketSet(files[i:i + size], evs, align) for i in range(0, len(files), size)]


def exif_exposure(path: Path, remedy: str) -> float:
    """A frame's relative exposure from its EXIF (``camera.brackets.exposure``). PanoLightError naming the file,
    followed by ``remedy``, where it records none; naming it too where its values are not an exposure."""
    return exif_shot(path, remedy)[0]


def exif_shot(path: Path, remedy: str) -> tuple[float, float, float | None, bool]:
    """(relative exposure, exposure time s, when it was taken: s on the camera's clock or None, whether it was exposed
    by hand) of a frame from its EXIF; PanoLightError as ``exif_exposure``."""
    exif = read_exposure(path)
    if exif is None:
        sep = "" if remedy.startswith(";") else ", "
        raise PanoLightError(f"{path}: records no exposure (EXIF ExposureTime and FNumber){sep}{remedy}")
    try:
        return (exposure(exif["time_s"], exif["f_number"], exif["iso"]), exif["time_s"], exif.get("taken_s"),
                bool(exif.get("manual")))
    except PanoLightError as exc:
        raise naming(path, exc) from None


BRACKET_GAP_S = 5.0  # a frame taken more than this after the previous one ended begins a new set: a camera's
# bracket sequence follows on at once (a second or two between frames), shots of other scenes minutes later ...
SLOW_BRACKET_GAP_S = 120.0  # ... unless both were exposed by hand (``slow_bracket``), the later within this: a set shot
# one setting at a time (a real iPhone set, a stop apart, 7-27 s between frames, had become nine single shots)


def group_by_exposure(files, align: bool = True) -> list:
    """``files`` grouped by each file's EXIF (``--brackets auto``), in the order they were taken (DateTimeOriginal and
    SubSecTimeOriginal, where every file records it: a set renamed by its exposures, 1_125.jpg, still comes in order;
    else by name, as a camera numbers its files): consecutive frames make one set until a frame's exposure repeats one
    the set holds (within MIN_EXPOSURE_STEP: the camera's bracket sequence began again) or it was taken more than
    BRACKET_GAP_S after the previous frame ended (shots of other scenes) and is no ``slow_bracket`` step, so sets of
    any size share a folder. A set of one frame is that file alone (a single shot: estimated as it is). PanoLightError
    naming a file that records no exposure."""
    remedy = "which --brackets auto groups the files by; give --brackets N and --evs instead"
    shots = [(path, *exif_shot(path, remedy)) for path in sorted((Path(f) for f in files), key=str)]
    if all(shot[3] is not None for shot in shots):
        shots.sort(key=lambda shot: shot[3])  # stable: a burst's frames of one second keep their names' order
    sets, current, seen, ended, by_hand = [], [], [], None, False
    pictures = {}  # the last two frames read: a slow set's chain reads each frame once

    def picture(p: Path) -> np.ndarray:
        if p not in pictures:
            pictures[p] = read_image(p, ldr_as_uint8=True)
            while len(pictures) > 2:
                del pictures[next(iter(pictures))]
        return pictures[p]

    for path, e, time_s, taken, manual in shots:
        gap = None if taken is None or ended is None else taken - ended
        later = gap is not None and gap > BRACKET_GAP_S and not (
            gap <= SLOW_BRACKET_GAP_S and by_hand and manual and slow_bracket(current[-1], path, seen, e, picture))
        if later or any(one_exposure(e, v) for v in seen):
            sets.append(current)
            current, seen = [], []
        current.append(path)
        seen.append(e)
        ended, by_hand = (None if taken is None else taken + time_s), manual
    sets.append(current)
    return [BracketSet(s, None, align) if len(s) > 1 else s[0] for s in sets if s]


def slow_bracket(previous: Path, path: Path, exposures: list, e: float, read) -> bool:
    """Whether ``path`` (exposure ``e``), shot by hand a while after ``previous`` (the last frame of a set exposed
    ``exposures`` so far), is the set's next step: its exposure goes on the way the set's do, and its picture is
    shown to be the previous frame's scene (``camera.agreement.one_scene``, as shot: a tripod set). A frame that cannot
    be read as an 8-bit picture of the previous one's size is no step (each is estimated alone, as before). ``read``:
    a path's pixels (``io.read_image`` as 8 bits, kept for the next step)."""
    if len(exposures) >= 2 and (e > exposures[-1]) != (exposures[-1] > exposures[-2]):
        return False
    try:
        a, b = read(previous), read(path)
    except PanoLightError:
        return False
    if a.dtype != np.uint8 or b.dtype != np.uint8 or a.shape != b.shape:
        return False
    return one_scene(frame_agreement(a, b, e / exposures[-1]))


def parse_evs(text: str) -> tuple[float, ...]:
    """'-2,0,2' -> (-2.0, 0.0, 2.0): each frame's exposure in stops, in the order of the files."""
    try:
        evs = tuple(float(v) for v in str(text).split(","))
    except ValueError:
        raise PanoLightError(f"--evs takes the frames' exposures in stops, comma-separated (e.g. -2,0,2), got "
                             f"{text!r}") from None
    if not all(math.isfinite(v) and abs(v) <= 30 for v in evs):
        raise PanoLightError(f"--evs: each exposure is a number of stops within +-30, got {text!r}")
    return evs


def bracket_exposures(paths, evs=None) -> tuple[list[float], str]:
    """(relative exposures, where they came from) of the frames ``paths``: 2^ev of ``evs`` (one per file), else
    each file's EXIF (ExposureTime x ISO / FNumber^2; where those repeat, the exposure bias, ``_by_bias``).
    PanoLightError naming the file that records none, or when the count of ``evs`` is not the count of files, or the
    exposures cannot be told apart."""
    paths = [Path(p) for p in paths]
    if evs is not None:
        if len(evs) != len(paths):
            raise PanoLightError(f"--evs gives {len(evs)} exposure(s) for {len(paths)} file(s): one per file")
        found, origin = [2.0 ** v for v in evs], "--evs"
    else:
        found = [exif_exposure(p, "; give every frame's exposure with --evs (e.g. --evs -2,0,2)") for p in paths]
        origin = "EXIF (ExposureTime x ISO / FNumber^2)"
        biased = None if told_apart(found) else _by_bias(paths, found)
        if biased is not None:
            found, origin = biased, BIAS_ORIGIN
    check_exposures(found)
    return found, origin


BIAS_ORIGIN = "EXIF exposure bias (ExposureBiasValue; its ExposureTime x ISO / FNumber^2 repeat)"


def _by_bias(paths, exposures) -> list[float] | None:
    """2^bias of each frame where the frames' recorded exposures repeat but every one records an exposure bias and
    the biases tell them apart: a phone compensating past its shortest shutter and lowest ISO records one exposure
    for frames its bias set apart (a gain it does not record). Said in a warning naming two such files; None where
    the biases cannot stand in (one missing, or two alike: the set is refused as it was)."""
    biases = [(read_exposure(p) or {}).get("bias_ev") for p in paths]
    if any(b is None for b in biases) or not told_apart([2.0 ** b for b in biases]):
        return None
    i, j = next((i, j) for i in range(len(paths)) for j in range(i + 1, len(paths))
                if one_exposure(exposures[i], exposures[j]))
    warnings.warn(PanoLightWarning(f"{paths[j]}: records the exposure of {paths[i].name} though its exposure bias is "
                                   f"{biases[j]:+.3g} EV and that one's {biases[i]:+.3g} EV (a phone compensating past "
                                   f"its shutter and ISO): the set is timed by its exposure bias (--evs sets it "
                                   f"otherwise)"), stacklevel=3)
    return [2.0 ** b for b in biases]


def read_brackets(paths, evs=None, align: bool = True, **read_options) -> tuple[np.ndarray, dict]:
    """The merged float32 HDR (H, W, 3) of the frames ``paths``, all 8-bit pictures or all camera RAWs
    (``io.read_image`` with ``read_options`` each), at their exposures (``bracket_exposures``), and the record
    lighting.json keeps (``source.brackets``). PanoLightError, naming the file, for an HDR frame, a set that mixes
    RAWs and pictures, or a frame not the first frame's size."""
    paths = [Path(p) for p in paths]
    if len(paths) < 2:
        raise PanoLightError(f"{paths[0] if paths else 'no file'}: a bracket set is two or more files; --evs is for "
                             f"a set, one file is estimated as it is")
    exposures, origin = bracket_exposures(paths, evs)
    raws = [sniff_format(p) == RAW_FORMAT for p in paths]
    for p, raw in zip(paths, raws):
        if raw != raws[0]:
            raise PanoLightError(f"{p}: {'a camera RAW' if raw else 'not a camera RAW'}, but {paths[0].name} "
                                 f"{'is not' if raw else 'is'}: a bracket set's frames are all RAWs or all 8-bit "
                                 f"pictures")
    decoded = threads.map_ordered(lambda p: read_image(p, ldr_as_uint8=True, **read_options), paths)  # the JPEG
    # decoder lets go of the GIL: three 2K frames in 32 ms instead of 39
    frames = []
    for p, raw, frame in zip(paths, raws, decoded):
        if frame.dtype != np.uint8 and not raw:
            raise PanoLightError(f"{p}: a bracket frame must be an 8-bit picture (JPEG, PNG) or a camera RAW; an "
                                 f"HDR file is estimated on its own")
        if frames and frame.shape != frames[0].shape:
            raise PanoLightError(f"{p}: {frame.shape[1]}x{frame.shape[0]}, but {paths[0].name} is "
                                 f"{frames[0].shape[1]}x{frames[0].shape[0]}: a bracket set's frames have one size")
        frames.append(frame)
    kept, frames, kept_exposures, dropped = _distinct(paths, frames, exposures)
    merged, info = merge_brackets(frames, kept_exposures, align=align, names=[p.name for p in kept])
    if "left_out" in info:  # frames that contradicted their set, by file
        info["left_out"] = [{"file": str(kept[d["frame"]]), "why": d["why"]} for d in info["left_out"]]
    if dropped:  # the record speaks of every file given: the reference's index and each one's stops among them
        ref = paths.index(kept[info["reference"]])
        info.update(reference=ref, stops=[round(math.log2(e / exposures[ref]), 4) for e in exposures])
    return merged, {"files": [str(p) for p in paths], "exposures_from": origin, "aligned": bool(align),
                    **({"dropped": dropped} if dropped else {}), **info}


def _distinct(paths, frames, exposures):
    """(paths, frames, exposures, dropped) with each frame that is the same picture as the one before it in exposure
    order (``camera.agreement.same_picture``: one frame listed under two exposures) left out, said in a warning
    naming both; PanoLightError when fewer than two distinct frames are left."""
    order = sorted(range(len(paths)), key=lambda i: exposures[i])
    keep, dropped = [order[0]], []
    for i in order[1:]:
        j = keep[-1]
        if frames[i].dtype == np.uint8 and same_picture(frames[j], frames[i]):
            stops = math.log2(exposures[i] / exposures[j])
            dropped.append({"file": str(paths[i]), "same_as": str(paths[j]), "stops_apart": round(stops, 3)})
            warnings.warn(PanoLightWarning(f"{paths[i]}: the same picture as {paths[j].name} though its exposure says "
                                           f"{stops:.3g} stops more: left out of the merge (check the set's EXIF or "
                                           f"--evs)"), stacklevel=3)
        else:
            keep.append(i)
    if len(keep) < 2:
        raise PanoLightError(f"{paths[0]}: every frame of the set is the same picture under other exposures: "
                             f"nothing to merge (estimate one frame alone)")
    keep.sort()
    return [paths[i] for i in keep], [frames[i] for i in keep], [exposures[i] for i in keep], dropped
