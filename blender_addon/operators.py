"""Operators (idnames are public, for scripts): gather settings, call the core, hand results to the datablock
modules (store, images, world, lights).

panolight.load_panorama(filepath)        the panorama becomes the PanoLight world's background
panolight.estimate_lighting()            estimate with the panel's settings (scene.panolight: estimator,
                                          model, order, deringing, exposure); a worker thread + modal timer,
                                          synchronous in background mode or from a script with execute
panolight.build_environment()            SH radiance map + Light Path split + sun lamps
panolight.export_lighting(filepath)      lighting.json and the radiance map as EXR beside it
panolight.pick_sun()                     click the sun (or where a shadow points from) on the panorama in a 3D
                                          viewport: the panel's Sun is here takes that direction, then the
                                          estimate and the environment are made again
"""

import functools
import math
import threading
import warnings
from pathlib import Path

import bpy
import numpy as np
from bpy.props import BoolProperty, CollectionProperty, StringProperty
from bpy_extras.io_utils import ExportHelper

from . import images, store
from .core import (
    brackets,
    capture,
    checks,
    core_images,
    errors,
    hdri,
    keylight,
    lighting_file,
    ownership,
    pipeline,
    sh,
    threads,
    units,
)
from .lights import LIGHTS_COLLECTION, set_lights
from .world import build_world

Error = errors.PanoLightError
REPORTED = (Error, OSError, MemoryError)  # what an operator reports; anything else is a bug and raises


def reports_errors(method):
    """The add-on's one error policy: the core (and this layer) raise PanoLightError for bad input and
    state; an operator reports it (or an OSError / MemoryError) in one line and cancels."""
    def guarded(self, context, *event):
        try:
            return method(self, context, *event)
        except REPORTED as exc:
            self.report({"ERROR"}, f"PanoLight: {_message(exc)}")
            return {"CANCELLED"}

    # Blender checks a callback's argument count (execute: self, context; invoke/modal: + event)
    if method.__code__.co_argcount == 2:
        return functools.wraps(method)(lambda self, context: guarded(self, context))
    return functools.wraps(method)(lambda self, context, event: guarded(self, context, event))


def _message(exc) -> str:
    if isinstance(exc, MemoryError):
        return "out of memory (the panorama is too large for this machine)"
    if isinstance(exc, OSError) and exc.filename:
        return f"{exc.filename}: {exc.strerror or exc}"
    return str(exc)


def _settings(context):
    return context.scene.panolight


FINITE_SETTINGS = ("background_strength", "lighting_strength", "sun_strength", "background_rotation",
                   "lighting_rotation", "sun_azimuth", "sun_elevation", "sun_contrast")  # panel properties a script or a typed expression can set to NaN / inf


def _checked(context):
    """The panel's settings, refused (naming the setting) when one that scales or turns light is NaN or
    infinite: Blender's min/max do not stop those, and they would make NaN lamps and backgrounds."""
    s = _settings(context)
    for name in FINITE_SETTINGS:
        value = float(getattr(s, name))
        if not np.isfinite(value):
            label = type(s).bl_rna.properties[name].name
            raise Error(f"{label} is {value}: it must be a finite number; set it again in the PanoLight panel")
    return s


def _fit(pixels, settings, found=(None, None)):
    """Runs in a worker thread: numpy only, never bpy. ``found``: the photo's (capture, exposure) (``_photo``).
    Returns the core's pipeline.Result."""
    return pipeline.estimate_lighting(pixels, settings, *found)


def _photo(image, settings):
    """(capture, exposure) of the panorama's file: its capture metadata (GPS, UTC time, heading: io.capture) when
    the panel asks for the sun from it and points at none, and its EXIF exposure (the absolute scale,
    ``camera.units``); each None where there is none, or for an image without a file."""
    path = Path(bpy.path.abspath(image.filepath)) if image.filepath else None
    if path is None or not path.is_file():
        return None, None
    wanted = settings.sun_direction is None and settings.sun_metadata
    return (capture.read_capture(path) if wanted else None), capture.read_exposure(path)


def _read_panorama(image):
    """The panorama's pixels for the core: read from its file by scanlines where Blender's OpenImageIO
    can, else one pixel read of the image; validated like a file (NaN refused, negative radiance clamped)."""
    pixels = images.file_pixels(image)
    if pixels is None:
        pixels = images.image_pixels(image)
    if pixels.dtype != np.uint8:
        pixels = core_images.sanitise_pixels(image.name, pixels)
    return pixels


def _make_hdri(world, pixels, result):
    """The reconstructed HDRI as PanoLight's float image, filled by row blocks (the CLI's hdr.exr: its key lights
    at the estimate's sun strength), and marked with the estimate and the strength it belongs to (made only when a
    world is lit with it: at 16K it is 2 GB in Blender)."""
    blocks = result.hdr_blocks(pixels)
    key = _brightest_light(result.document.get("lights", []))
    if key is not None:  # its brightest luminance beside that light, found as the blocks go by (_eevee_sun)
        blocks = hdri.PeakBeside(blocks, pixels.shape[:2], key["direction"],
                                 max(float(key.get("angle", 0.0)), EEVEE_KEY_CONE))
    image = images.radiance_image(blocks, images.HDRI_IMAGE_NAME, shape=pixels.shape[:2])
    if key is not None:
        image[store.PEAK_BESIDE_KEY] = blocks.peak
    elif store.PEAK_BESIDE_KEY in image:
        del image[store.PEAK_BESIDE_KEY]
    image[store.ESTIMATE_KEY] = world.get(store.ESTIMATE_KEY, "")
    image[store.SUN_STRENGTH_KEY] = float(result.document.get("sun_strength", 1.0))
    return image


class PANOLIGHT_OT_load_panorama(bpy.types.Operator):
    """Load an equirectangular panorama (LDR, HDR or a camera RAW) as the background of the PanoLight world"""

    bl_idname = "panolight.load_panorama"
    bl_label = "Load panorama"
    bl_options = {"REGISTER", "UNDO"}

    filepath: StringProperty(subtype="FILE_PATH")
    filter_glob: StringProperty(default="*.jpg;*.jpeg;*.png;*.exr;*.hdr;" + ";".join(
        f"*{e}" for e in checks.TIFF_EXTENSIONS + checks.RAW_EXTENSIONS), options={"HIDDEN"})
    files: CollectionProperty(type=bpy.types.OperatorFileListElement, options={"HIDDEN", "SKIP_SAVE"})
    directory: StringProperty(subtype="DIR_PATH", options={"HIDDEN", "SKIP_SAVE"})
    evs: StringProperty(name="Bracket EVs", default="",
                        description="Several files selected: a bracket set of one scene, merged into one HDR. Its "
                                    "exposures in stops, one per file in name order (e.g. -2,0,2); empty: from "
                                    "each file's EXIF (ExposureTime x ISO / FNumber^2)")
    align: BoolProperty(name="Align brackets", default=True,
                        description="A hand-held set: each frame moved onto the middle one where that makes them "
                                    "agree better. Off: a tripod set, merged as shot (--no-align)")

    def invoke(self, context, event):
        context.window_manager.fileselect_add(self)
        return {"RUNNING_MODAL"}

    @reports_errors
    def execute(self, context):
        chosen = sorted(Path(bpy.path.abspath(self.directory)) / f.name for f in self.files if f.name)
        if len(chosen) > 1:  # a bracket set, merged by the core as the CLI merges it
            evs = brackets.parse_evs(self.evs) if self.evs.strip() else None
            with warnings.catch_warnings(record=True) as said:  # a frame left out, a set timed by its bias: said
                warnings.simplefilter("always", errors.PanoLightWarning)
                image, info = images.bracket_panorama(chosen, evs, self.align)
            for w in said:
                if issubclass(w.category, errors.PanoLightWarning):
                    self.report({"WARNING"}, f"PanoLight: {w.message}")
            used = len(chosen) - len(info.get("left_out", ()))
            count = f"{used} of {len(chosen)}" if used < len(chosen) else f"{len(chosen)}"
            return self._show(context, image, f" merged from {count} frames "
                                              f"({', '.join(f'{v:+g}' for v in info['stops'])} stops)")
        path = Path(bpy.path.abspath(self.filepath))
        if not path.is_file():
            raise Error(f"{path}: file not found")
        if core_images.sniff_format(path) == checks.RAW_FORMAT:  # Blender reads no camera RAW: the core
            # decodes it (rawpy, where it is installed into Blender's Python; else refused in one line)
            return self._show(context, images.upright_panorama(str(path), core_images.read_image(path)),
                              label=path)
        # what Blender would read wrong, crash on, or decode past the budget (it has none of its own)
        upright = core_images.preflight(path)
        if upright is not None and upright[2] != 1:  # Blender ignores EXIF orientation and +Y .hdr files
            image = images.upright_panorama(str(path), core_images.read_image(path))
        else:
            try:
                image = images.load_panorama(str(path))
            except RuntimeError as exc:  # bpy's own "cannot read" error
                raise Error(f"{path}: {str(exc).strip()}") from None
        w, h = image.size
        if w == 0 or h == 0:
            raise Error(f"{path}: Blender could not read this image")
        return self._show(context, image, label=path)

    def _show(self, context, image, how: str = "", label=None):
        """Make ``image`` (PanoLight's, 2:1 checked here: errors name ``label``, else the image) the background of
        the PanoLight world."""
        w, h = image.size
        if w != 2 * h:
            raise Error(f"{label or image.name}: equirectangular panoramas must be 2:1, got {w} x {h}")
        world = build_world(image, **_world_kwargs(context))
        world[store.PANORAMA_KEY] = image  # the image itself, not its name: a rename keeps it
        store.store_lighting(world, None)  # a new panorama needs a new estimate
        if store.ours(bpy.data.collections, LIGHTS_COLLECTION) is not None:
            set_lights([], context.scene)  # the previous panorama's suns no longer apply
        context.scene.world = world
        self.report({"INFO"}, f"PanoLight: {image.name} ({w} x {h}){how} is the world background")
        return {"FINISHED"}


class PANOLIGHT_OT_estimate_lighting(bpy.types.Operator):
    """Estimate the lighting of the loaded panorama with the panel's settings (runs in the background; Esc
    cancels)"""

    bl_idname = "panolight.estimate_lighting"
    bl_label = "Estimate lighting"
    bl_options = {"REGISTER", "UNDO"}

    _thread = None
    _timer = None
    _result = None
    _used = None  # the Settings of the estimate being made
    _error = None
    _stop = None
    _world_name = ""

    def _inputs(self, context):
        world = context.scene.world
        settings = _checked(context).estimate_settings()  # invalid settings fail before any pixel is read
        panorama = store.stored_panorama(world)
        self._pixels, self._used = _read_panorama(panorama), settings
        return world, self._pixels, settings, _photo(panorama, settings)

    def _store(self, context, world, result):
        doc = result.document
        store.store_lighting(world, doc, self._used)
        s = _settings(context)
        if s.lighting_source == "HDRI":
            _make_hdri(world, self._pixels, result)
        self._pixels = None
        n = len(doc.get("lights", []))
        for problem in result.warnings:  # an all-black, absurdly bright or clipped-white panorama
            self.report({"WARNING"}, f"PanoLight: {store.stored_panorama(world).filepath or 'the panorama'}: {problem}")
        self.report({"INFO"}, f"PanoLight: lighting estimated (SH order {doc['lmax']}, {n} light(s)); "
                              f"use Build environment")
        note = keylight.key_light_note(doc, light="lamp", raise_with="Sun lamp strength",
                                       as_is="Restore a clipped sun unticked",
                                       place_with="Sun is here at azimuth {az}, elevation {el}")
        if note:
            self.report({"INFO"}, f"PanoLight: {note}")

    @reports_errors
    def execute(self, context):
        world, pixels, settings, found = self._inputs(context)
        self._store(context, world, _fit(pixels, settings, found))
        return {"FINISHED"}

    @reports_errors
    def invoke(self, context, event):
        if bpy.app.background:
            return self.execute(context)
        world, pixels, settings, found = self._inputs(context)
        # the world's name, looked up again at the end: an undo while the estimate runs frees the datablock
        self._world_name = world.name
        self._stop = threading.Event()
        stop = self._stop

        def work():
            try:
                with threads.cancellable(stop):  # Esc stops it at its next block, not only the modal
                    self._result = _fit(pixels, settings, found)
            except Exception as exc:  # handed to modal, which reports it (or raises it, if it is a bug)
                self._error = exc

        self._thread = threading.Thread(target=work, daemon=True)
        self._thread.start()
        wm = context.window_manager
        self._timer = wm.event_timer_add(0.1, window=context.window)
        wm.progress_begin(0, 100)
        self._ticks = 0
        wm.modal_handler_add(self)
        context.workspace.status_text_set("PanoLight: estimating lighting... (Esc to cancel)")
        return {"RUNNING_MODAL"}

    def _finish(self, context):
        wm = context.window_manager
        wm.event_timer_remove(self._timer)
        wm.progress_end()
        context.workspace.status_text_set(None)

    @reports_errors
    def modal(self, context, event):
        if event.type == "ESC":
            self._stop.set()  # the worker stops at its next block; its result, if any, is dropped
            self._finish(context)
            self.report({"WARNING"}, "PanoLight: estimation cancelled")
            return {"CANCELLED"}
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        self._ticks += 1
        context.window_manager.progress_update(min(95, self._ticks * 5))
        if self._thread.is_alive():
            return {"RUNNING_MODAL"}
        self._finish(context)
        if self._error is not None:
            raise self._error
        world = bpy.data.worlds.get(self._world_name)
        if world is None:
            raise Error(f"the world {self._world_name!r} was removed or renamed while estimating; nothing was "
                        f"stored: run Estimate lighting again")
        self._store(context, world, self._result)
        return {"FINISHED"}


def _world_kwargs(context):
    s = _checked(context)
    return {"background_strength": s.background_strength, "lighting_strength": s.lighting_strength,
            "background_rotation": s.background_rotation, "lighting_rotation": s.lighting_rotation,
            "glossy_panorama": s.glossy_panorama}


class PANOLIGHT_OT_build_environment(bpy.types.Operator):
    """Light the scene with the estimated SH radiance map (and sun lamps); cameras still see the panorama"""

    bl_idname = "panolight.build_environment"
    bl_label = "Build environment"
    bl_options = {"REGISTER", "UNDO"}

    @reports_errors
    def execute(self, context):
        world = context.scene.world
        doc = store.stored_lighting(world)
        panorama = store.stored_panorama(world)
        s = _checked(context)
        fresh = None
        if float(doc.get("sun_strength", 1.0)) != float(s.sun_strength):  # the slider moved since Estimate
            fresh = self._at_new_strength(context, world, panorama)
            doc = fresh[1].document
        if s.lighting_source == "HDRI":
            image = images.own_image(images.HDRI_IMAGE_NAME)
            if image is None or image.get(store.ESTIMATE_KEY) != world.get(store.ESTIMATE_KEY):
                image = _make_hdri(world, *fresh) if fresh else self._hdri_now(context, world, panorama, doc)
            lights = []  # the sun and lamps are in the HDRI itself, at Sun lamp strength
        else:
            coeffs = np.asarray(doc["coefficients"], dtype=np.float64)
            h = max(64, min(1024, s.radiance_height))
            # no negative light, nothing clipped: the nearest non-negative map with the same bands 0-2
            radiance = sh.emitter_map(coeffs, h, 2 * h)[0].astype(np.float32)
            image = images.radiance_image(radiance)
            lights = doc.get("lights", []) if s.create_lights else []
        factor = self._physical_factor(context, doc)  # W/m^2/sr per unit of the estimate, or 1 (relative)
        kwargs = _world_kwargs(context)
        kwargs["background_strength"] *= factor
        kwargs["lighting_strength"] *= factor
        build_world(panorama, image, **kwargs)
        # the key lights at Sun lamp strength, in W/m^2 where the units are physical
        set_lights(lights, context.scene, s.lighting_strength * factor, s.lighting_rotation)
        beside = image.get(store.PEAK_BESIDE_KEY) if s.lighting_source == "HDRI" else None
        _eevee_sun(world, bool(lights), kwargs["lighting_strength"], beside)
        context.scene.world = world
        what = "the reconstructed HDRI" if s.lighting_source == "HDRI" else \
            f"SH order {doc['lmax']}, {len(lights)} sun lamp(s)"
        if factor != 1.0:
            what += (f"; physical units: {factor:.4g} W/m^2/sr per unit of the estimate, film exposure "
                     f"{context.scene.view_settings.exposure:+.2f} EV")
        self.report({"INFO"}, f"PanoLight: environment built ({what})")
        return {"FINISHED"}

    def _physical_factor(self, context, doc) -> float:
        """With Physical units ticked and a scale the estimate knows (``camera.units.blender_factor``): W/m^2/sr per
        unit of its values, and the film's exposure set to -log2 of it, so the plate's white renders white; else 1
        (and a warning where the estimate knows no scale), the exposure untouched."""
        if not _checked(context).physical_units:
            return 1.0
        factor = units.blender_factor(doc.get("physical"))
        if factor is None:  # the photo records no exposure (on by default: no warning for the common case)
            self.report({"INFO"}, "PanoLight: the estimate knows no absolute scale (the photo records no exposure): "
                                  "relative units, 1 = the camera's white")
            return 1.0
        context.scene.view_settings.exposure = -math.log2(factor)
        return factor

    def _at_new_strength(self, context, world, panorama):
        """(pixels, the core's Result) of the stored estimate at the panel's Sun lamp strength, stored in its place:
        what ``panolight estimate --sun-strength`` gives (the core's one operation on the key lights, and the
        fill they leave). Refused when other settings changed too: that would be another estimate."""
        settings = _checked(context).estimate_settings()
        if not store.same_settings_but_strength(world, settings):
            raise Error("the panel's settings changed since Estimate lighting (not only Sun lamp strength): run "
                        "Estimate lighting again")
        pixels, result = _estimate_again(panorama, settings)
        store.store_lighting(world, result.document, settings)
        for problem in result.warnings:  # "sun strength 2 changes nothing: the estimate has no key light"
            self.report({"WARNING"}, f"PanoLight: {problem}")
        return pixels, result

    def _hdri_now(self, context, world, panorama, doc):
        """The HDRI of the stored estimate, made now (it is not kept in the .blend): the panorama is read
        and estimated again (the estimators are deterministic). If the panel's settings have changed since
        Estimate lighting, that would be another estimate: refused, so the stored lighting is never
        replaced behind the user's back."""
        pixels, result = _estimate_again(panorama, _checked(context).estimate_settings())
        if not same_lighting(result.document, doc):
            raise Error("the panel's settings changed since Estimate lighting, so the HDRI would belong to "
                        "another estimate: run Estimate lighting again (or restore the settings)")
        return _make_hdri(world, pixels, result)


EEVEE_SUN_THRESHOLD = 10.0  # EEVEE's default: world radiance above it (relative units here) becomes EEVEE's own sun
EEVEE_KEY_CONE = math.radians(5.0)  # the brightest light's pixels: a restored sun's fill and glare lie within it
EEVEE_ABOVE_BESIDE = 1.05  # the threshold's margin over the brightest pixel beside that light


def _brightest_light(lights):
    """The light of a lighting document that is brightest on a surface facing it (intensity x its colour's largest
    channel), or None."""
    return max(lights, key=lambda light: float(light["intensity"]) * max(light["color"]), default=None)


def _eevee_sun(world, lamps: bool, strength: float, beside: float | None = None) -> None:
    """No light counted twice or moved in EEVEE (4.2+), which takes world radiance above ``World.sun_threshold`` out
    of its light probe into one sun of its own, at the excess's mean direction: where PanoLight's Sun lamps carry the
    key lights (SH lighting + sun lamps), none (0: the whole world goes to the light probe); where the world's HDRI
    carries them (no lamps), a threshold above everything beside the brightest light (``beside``: the HDRI's
    brightest luminance outside EEVEE_KEY_CONE round it, in the image's units), and at least EEVEE's default 10, so
    that light alone becomes EEVEE's sun. (With EEVEE's default alone, a street's row of lamps at the horizon was
    merged with the lamp overhead into one sun from above: an upward plane got 1.33x its light;
    docs/studies/eevee_units.md.) ``strength``: W/m^2/sr of the world per unit of the image (the Background strength,
    with Physical units the factor)."""
    if hasattr(world, "sun_threshold"):
        level = max(EEVEE_SUN_THRESHOLD, EEVEE_ABOVE_BESIDE * beside) if beside is not None else EEVEE_SUN_THRESHOLD
        world.sun_threshold = 0.0 if lamps else level * strength


def _estimate_again(panorama, settings):
    """(pixels, the core's Result) of the panorama estimated now with ``settings``, its photo's metadata sun
    included as Estimate lighting had it (the estimators are deterministic)."""
    pixels = _read_panorama(panorama)
    return pixels, _fit(pixels, settings, _photo(panorama, settings))


def same_lighting(a: dict, b: dict) -> bool:
    """Whether two lighting documents describe the same lighting: the coefficients, and every light's
    type, direction, intensity, colour and size (to 1e-9 relative)."""
    def close(x, y):
        return np.shape(x) == np.shape(y) and np.allclose(x, y, rtol=1e-9, atol=1e-12)

    la, lb = a.get("lights", []), b.get("lights", [])
    return close(a["coefficients"], b["coefficients"]) and len(la) == len(lb) and all(
        x.get("type") == y.get("type") and all(close(x.get(k, 0.0), y.get(k, 0.0))
                                              for k in ("direction", "intensity", "color", "angle"))
        for x, y in zip(la, lb))


class PANOLIGHT_OT_export_lighting(bpy.types.Operator, ExportHelper):
    """Write the estimated lighting (lighting.json) and its SH radiance map (EXR) to files"""

    bl_idname = "panolight.export_lighting"
    bl_label = "Export lighting"
    bl_options = {"REGISTER"}

    # ExportHelper: the file browser adds .json and shows Blender's overwrite warning (check_existing)
    filename_ext = ".json"
    filter_glob: StringProperty(default="*.json", options={"HIDDEN"})

    @reports_errors
    def execute(self, context):
        doc = store.stored_lighting(context.scene.world)
        path = _export_path(self.filepath, self.filename_ext)
        exr = path.with_name(path.stem + "_radiance.exr")
        image = images.own_image(images.SH_IMAGE_NAME)
        owners = ownership
        # the browser warned about the .json only: a radiance map beside it that PanoLight did not write
        # there (its folder's manifest) is the user's, and is never replaced
        if image is not None and owners.foreign(path.parent, [exr.name]):
            raise Error(f"{exr}: exists and was not written by PanoLight; choose another name (the radiance map "
                        f"is written beside the .json as NAME_radiance.exr) or move that file")
        lighting_file.write_lighting(path, doc)
        if image is not None:
            _save_exr(context.scene, image, exr)
        written = [path] + ([exr] if image is not None else [])
        owners.record(path.parent, {p.name: owners.written(p) for p in written})
        self.report({"INFO"}, f"PanoLight: wrote {path}" + (f" and {exr.name}" if image else ""))
        return {"FINISHED"}


def _export_path(filepath: str, ext: str) -> Path:
    """Where an export goes, or PanoLightError: a '//' path needs a saved .blend (it is relative to it), a
    folder is not a file name, and another extension is not silently replaced (a bare name gets ext)."""
    if not filepath:
        raise Error("no file name given")
    if filepath.startswith("//") and not bpy.data.filepath:
        raise Error(f"{filepath}: a '//' path is relative to the .blend file; save it first or choose "
                           f"an absolute path")
    path = Path(bpy.path.abspath(filepath))
    if filepath.endswith(("/", "\\")) or path.is_dir():
        raise Error(f"{path}: is a folder; choose a file name such as {path / ('lighting' + ext)}")
    if path.suffix == "":
        path = path.with_name(path.name + ext)
    elif path.suffix.lower() != ext:
        raise Error(f"{path}: the lighting file must end in {ext}")
    if not path.parent.is_dir():
        raise Error(f"{path.parent}: folder does not exist")
    return path


def _save_exr(scene, image, path):
    """Save a float image as a linear EXR (save_render with the Standard view transform round-trips)."""
    vs, settings = scene.view_settings, scene.render.image_settings
    saved = (vs.view_transform, vs.look, vs.exposure, vs.gamma, settings.file_format, settings.color_depth)
    try:
        vs.view_transform, vs.look, vs.exposure, vs.gamma = "Standard", "None", 0.0, 1.0
        settings.file_format, settings.color_depth = "OPEN_EXR", "32"
        image.save_render(str(path), scene=scene)
    finally:
        vs.view_transform, vs.look, vs.exposure, vs.gamma, settings.file_format, settings.color_depth = saved


def panorama_angles(view_direction, background_rotation: float) -> tuple[float, float]:
    """(azimuth, elevation) in radians, as the panel's Sun is here keeps them (azimuth 0 at the panorama's centre,
    positive to the right in the image), of the panorama pixel a viewport shows in world ``view_direction``: the
    world's Mapping node turns the lookup by ``background_rotation`` about Z (world.build_world)."""
    x, y, z = (float(v) for v in view_direction)
    c, s = np.cos(background_rotation), np.sin(background_rotation)
    px, py = c * x - s * y, s * x + c * y
    n = float(np.sqrt(px * px + py * py + z * z))
    if not n > 0:
        raise Error("no direction was picked")
    return float(np.arctan2(-py, px)), float(np.arcsin(max(-1.0, min(1.0, z / n))))


def point_sun(context, view_direction) -> None:
    """The panel's Sun is here at the panorama pixel seen in world ``view_direction``, then Estimate lighting and
    Build environment again (the lamp and the world follow); what Pick sun does with a click."""
    s = _checked(context)
    before = (s.sun_azimuth, s.sun_elevation, s.sun_pointed)
    s.sun_azimuth, s.sun_elevation = panorama_angles(view_direction, s.background_rotation)
    s.sun_pointed = True
    try:  # bpy.ops raises an operator's error report (a click the sky cannot weigh) as a RuntimeError
        done = bpy.ops.panolight.estimate_lighting("EXEC_DEFAULT") == {"FINISHED"}
    except RuntimeError as exc:
        done, error = False, Error(_report_text(exc))
    else:
        error = None
    if not done:
        s.sun_azimuth, s.sun_elevation, s.sun_pointed = before  # the click changed nothing
        if error is not None:
            raise error
        return
    try:
        bpy.ops.panolight.build_environment("EXEC_DEFAULT")
    except RuntimeError as exc:
        raise Error(_report_text(exc)) from None


def _report_text(exc: RuntimeError) -> str:
    """The message of an operator's error report that bpy.ops raised ("Error: PanoLight: ...\n")."""
    text = str(exc).strip()
    for prefix in ("Error:", "PanoLight:"):
        text = text.removeprefix(prefix).strip()
    return text


class PANOLIGHT_OT_pick_sun(bpy.types.Operator):
    """Click the sun on the panorama in a 3D viewport (or the point of the sky a shadow points away from): the
    sun is put there and the lighting estimated again. Right-click or Esc cancels"""

    bl_idname = "panolight.pick_sun"
    bl_label = "Pick sun"
    bl_options = {"REGISTER", "UNDO"}

    @reports_errors
    def invoke(self, context, event):
        store.stored_panorama(context.scene.world)  # "no panorama loaded: use Load panorama first"
        _checked(context)
        context.window_manager.modal_handler_add(self)
        context.window.cursor_modal_set("EYEDROPPER")
        self.report({"INFO"}, "PanoLight: click the sun on the panorama in a 3D viewport (right-click or Esc cancels)")
        return {"RUNNING_MODAL"}

    @reports_errors
    def modal(self, context, event):
        if event.type in ("RIGHTMOUSE", "ESC"):
            context.window.cursor_modal_restore()
            return {"CANCELLED"}
        if event.type != "LEFTMOUSE" or event.value != "PRESS":
            return {"PASS_THROUGH"}  # the view can still be turned and zoomed
        found = _viewport_ray(context, event.mouse_x, event.mouse_y)
        if found is None:
            return {"PASS_THROUGH"}  # a click outside every 3D viewport (the panel, a menu)
        context.window.cursor_modal_restore()
        point_sun(context, found)
        return {"FINISHED"}


def _viewport_ray(context, mouse_x: int, mouse_y: int):
    """The world direction under the mouse in the 3D viewport it is over (its main region), or None."""
    from bpy_extras import view3d_utils

    for area in context.screen.areas:
        if area.type != "VIEW_3D":
            continue
        for region in area.regions:
            if region.type == "WINDOW" and region.x <= mouse_x < region.x + region.width and \
                    region.y <= mouse_y < region.y + region.height:
                rv3d = area.spaces.active.region_3d
                return view3d_utils.region_2d_to_vector_3d(region, rv3d, (mouse_x - region.x, mouse_y - region.y))
    return None


CLASSES = (PANOLIGHT_OT_load_panorama, PANOLIGHT_OT_estimate_lighting, PANOLIGHT_OT_build_environment,
           PANOLIGHT_OT_export_lighting, PANOLIGHT_OT_pick_sun)
