"""Images in and out of Blender: a panorama's pixels for the core, PanoLight's own panorama image, and the
float images it makes (the SH radiance map, the reconstructed HDRI). Rows are top first on the core's side
(Blender's Image.pixels are bottom-up RGBA).
"""
from __future__ import annotations

from pathlib import Path

import bpy
import numpy as np

from .core import brackets, core_images, errors, resample
from .store import BRACKETS_KEY, SOURCE_KEY, TAG

SH_IMAGE_NAME = "PanoLight SH Radiance"
HDRI_IMAGE_NAME = "PanoLight HDRI"


def image_pixels(image) -> np.ndarray:
    """(H, W, 3) pixels of a Blender image, top row first: uint8 sRGB for 8-bit images, float32 linear
    for float images (Image.pixels is bottom-up RGBA; 8-bit images come back as sRGB-encoded floats).
    One pixel read; the conversion runs by row blocks, so the only full-size temporary is that read."""
    w, h = image.size
    if w == 0 or h == 0:
        raise errors.PanoLightError(f"image {image.name!r} has no pixels (is the file missing?)")
    c = image.channels
    buf = np.empty(w * h * c, dtype=np.float32)
    image.pixels.foreach_get(buf)
    px = buf.reshape(h, w, c)
    out = np.empty((h, w, 3), np.float32 if image.is_float else np.uint8)
    for r0, r1 in resample.row_blocks(h, w):  # output rows r0..r1 are input rows h-r1..h-r0
        block = px[h - r1:h - r0, :, :3][::-1]
        if image.is_float:
            out[r0:r1] = block
        else:  # byte images read back as exact k / 255 in [0, 1]: +0.5 and truncation round them
            out[r0:r1] = np.minimum(block * np.float32(255.0) + np.float32(0.5), np.float32(255.0))
    return out


def file_pixels(image):
    """``image_pixels`` read from the image's file by the core's reader (io.images.read_image, on the
    OpenImageIO module Blender ships): the CLI's pixels exactly, with its decode budget, by row blocks
    (a 16K JPEG costs its 0.4 GB of uint8 pixels, not a 2.1 GB RGBA float read). None for a packed,
    generated or edited image, or a missing file: Blender's own pixels are then read."""
    record = image.get(BRACKETS_KEY)  # a merged bracket set: merged again from its files, if they are all there
    if record is not None:
        saved = brackets.BracketSet.from_record(record)  # validated: an edited one is refused
        if not all(p.is_file() for p in saved.paths):
            return None
        return brackets.read_brackets(saved.paths, saved.evs, saved.align)[0]
    source = image.get(SOURCE_KEY)  # PanoLight's upright copy of a turned file: read the file itself
    if source is None:
        if image.source != "FILE" or image.packed_file is not None or image.is_dirty:
            return None
        source = bpy.path.abspath(image.filepath)
    path = Path(source)
    if not path.is_file():
        return None
    return core_images.read_image(path, ldr_as_uint8=True)


def upright_panorama(filepath: str, pixels: np.ndarray, name: str | None = None):
    """PanoLight's own packed float image of a file Blender would show turned (an EXIF orientation, a
    Radiance ``+Y`` file: Blender ignores both): the core's upright linear pixels (H, W, 3), so the
    background and the estimate agree. The file's path is kept (``file_pixels`` reads it again)."""
    h, w = pixels.shape[:2]
    image = bpy.data.images.new(name or Path(filepath).name, w, h, alpha=False, float_buffer=True)
    image[TAG] = "panorama"
    image[SOURCE_KEY] = str(filepath)
    image.colorspace_settings.name = "Linear Rec.709"
    rgba = np.ones((h, w, 4), np.float32)
    rgba[..., :3] = pixels[::-1]  # Blender's rows are bottom-up
    image.pixels.foreach_set(rgba.ravel())
    image.pack()
    return image


def bracket_panorama(paths, evs=None, align: bool = True):
    """PanoLight's own packed float image of a bracket set merged by the core (``pipeline.brackets.read_brackets``:
    exposures from the files' EXIF, or ``evs`` in stops; ``align`` False: a tripod set, frames as they are), named
    after its reference frame; the set is kept (``file_pixels`` merges it again, to the CLI's numbers). Returns
    (image, the merge's record)."""
    merged, info = brackets.read_brackets(paths, evs, align)
    reference = Path(info["files"][info["reference"]])
    image = upright_panorama(str(reference), merged, f"{reference.stem} ({len(paths)} brackets)")
    image[BRACKETS_KEY] = brackets.BracketSet(paths, tuple(evs) if evs else None, align).record()
    return image, info


def load_panorama(filepath: str):
    """PanoLight's own image of ``filepath``, with the right colour space: Linear Rec.709 for HDR files
    (EXR, Radiance, float TIFF), sRGB for the rest (8-bit and 16-bit PNG/JPEG/TIFF: Blender keeps 16-bit PNGs in
    float buffers, but they are sRGB-encoded). An image of the same file the user already has is left as it
    is (its colour space is theirs): PanoLight loads its own copy, tagged, and reuses it next time.

    The colour space is chosen from the file's first bytes and set before Blender decodes the pixels
    (``image.file_format`` decodes them, and a colour space change drops them again: an 8K JPEG was
    decoded twice)."""
    target = bpy.path.abspath(filepath)
    space = "Linear Rec.709" if core_images.is_hdr(target) else "sRGB"
    for image in bpy.data.images:
        if image.get(TAG) == "panorama" and bpy.path.abspath(image.filepath) == target:
            image.reload()
            break
    else:
        image = bpy.data.images.load(filepath, check_existing=False)
        image[TAG] = "panorama"
    if image.colorspace_settings.name != space:
        image.colorspace_settings.name = space
    return image


def own_image(name: str):
    """PanoLight's float image made under ``name`` (SH_IMAGE_NAME or HDRI_IMAGE_NAME), even if renamed."""
    return next((im for im in bpy.data.images if im.get(TAG) == name), None)


def radiance_image(radiance, name: str = SH_IMAGE_NAME, shape=None):
    """Create or update a packed float image (the SH radiance map, or the reconstructed HDRI with
    ``name=HDRI_IMAGE_NAME``) from (H, W, 3) linear pixels, top row first, or from row blocks
    (first row, (n, W, 3)) of an image of ``shape`` (H, W): the HDRI is filled block by block."""
    if shape is None:
        radiance = np.asarray(radiance)
        h, w = radiance.shape[:2]
        blocks = [(0, radiance)]
    else:
        (h, w), blocks = shape, radiance
    image = own_image(name)
    if image is not None and tuple(image.size) != (w, h):
        bpy.data.images.remove(image)
        image = None
    if image is None:  # a user's image that has the name keeps it; ours becomes "name.001"
        image = bpy.data.images.new(name, w, h, alpha=False, float_buffer=True)
        image[TAG] = name
    image.colorspace_settings.name = "Linear Rec.709"
    rgba = np.ones((h, w, 4), dtype=np.float32)
    for r0, block in blocks:  # Blender's rows go bottom-up
        n = block.shape[0]
        rgba[h - r0 - n:h - r0, :, :3] = block[::-1]
    image.pixels.foreach_set(rgba.ravel())
    del rgba
    image.pack()
    return image
