"""Mitsuba 3 evaluation renders: the paper's bunny / armadillo figure under estimated lighting.

Scene frame = Blender's world frame (Z up). The camera sits at the panorama's centre, EYE_HEIGHT above a
ground plane; the meshes (given +Y up, as the Stanford files are) are turned to Z up, scaled to
OBJECT_HEIGHT and stood on the ground DISTANCE in front of the view, side by side.

Lighting (``scene_emitters``): the SH part is an ``envmap`` whose bitmap is the SH radiance sampled at
Mitsuba's texel directions (rows theta = pi y / (H - 1), columns at our pixel centres; checked against
``emitter.eval``) with the CONVENTIONS.md ``to_world``; explicit sun lights are ``directional`` emitters;
area lights are painted into the envmap as disks of their angular size (importance sampling finds them).

Compositing (differential rendering): per view two passes under the estimated light, objects + ground
(A) and ground only (B), with the same random seed, plus emitter-free object and ground masks (C, G):
    C * A + (1 - C) * background * (G * A / B + 1 - G),
so objects appear with their shading, shadows darken the panorama, and nothing else changes.
Views: a perspective camera (yaw, pitch, fov inside the panorama) over the panorama resampled to it, and
the full sphere (six 90-degree faces resampled to equirect) over the panorama itself.
"""
from __future__ import annotations

import math
import os
import subprocess
import sys
import time
from pathlib import Path
from typing import NamedTuple

import numpy as np

from panolight_core import sh
from panolight_core.camera.resample import sample_equirect
from panolight_core.errors import PanoLightError

EYE_HEIGHT = 1.0
DISTANCE = 3.0
OBJECT_HEIGHT = 0.9
GROUND_ALBEDO = 0.5
MAX_RENDER_ORDER = 30  # lighting files above this order are refused (lmax 100 needed over 24 GB)
MATERIALS = {
    "mirror": {"type": "conductor", "material": "none"},
    "plastic": {"type": "roughplastic", "int_ior": 1.9, "ext_ior": 1.0, "alpha": 0.1,
                "diffuse_reflectance": {"type": "rgb", "value": [0.5, 0.5, 0.5]}},
    "gold": {"type": "conductor", "material": "Au"},
}
ENV_TO_WORLD = np.array([[0, 0, 1, 0], [1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 0, 1]], dtype=np.float64)
_MI = None


# ----------------------------------------------------------------------------------------- variant
def _llvm_library() -> str | None:
    env = os.environ.get("DRJIT_LIBLLVM_PATH")
    if env and Path(env).is_file():
        return env
    for pattern in ("/usr/lib/*/libLLVM-19.so", "/usr/lib/*/libLLVM.so.19*", "/usr/lib/llvm-19/lib/libLLVM*.so*"):
        hits = sorted(Path("/").glob(pattern.lstrip("/")))
        if hits:
            return str(hits[0])
    return None


def _llvm_works(lib: str) -> bool:
    """Render a tiny scene with llvm_ad_rgb in a child process (a crash there cannot take us down)."""
    code = ("import mitsuba as mi; mi.set_variant('llvm_ad_rgb'); "
            "s = mi.load_dict({'type': 'scene', 'e': {'type': 'constant'}, 'i': {'type': 'path'}, "
            "'c': {'type': 'perspective', 'film': {'type': 'hdrfilm', 'width': 4, 'height': 4}}}); "
            "import numpy as np; assert np.isfinite(np.array(mi.render(s, spp=1))).all(); print('ok')")
    try:
        r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120,
                           env={**os.environ, "DRJIT_LIBLLVM_PATH": lib})
    except (OSError, subprocess.TimeoutExpired):
        return False
    return r.returncode == 0 and "ok" in r.stdout


def mitsuba(variant: str = "auto"):
    """Import mitsuba with a variant: llvm_ad_rgb when LLVM 19 is installed and works, else scalar_rgb.

    The environment variable PANOLIGHT_MITSUBA_VARIANT overrides "auto" (e.g. scalar_rgb).
    """
    global _MI
    if _MI is not None:
        return _MI
    if variant == "auto":
        variant = os.environ.get("PANOLIGHT_MITSUBA_VARIANT", "auto")
    chosen = variant
    if variant == "auto":
        lib = _llvm_library()
        chosen = "llvm_ad_rgb" if lib and _llvm_works(lib) else "scalar_rgb"
        if chosen == "llvm_ad_rgb":
            os.environ["DRJIT_LIBLLVM_PATH"] = lib
    elif variant == "llvm_ad_rgb" and _llvm_library():
        os.environ.setdefault("DRJIT_LIBLLVM_PATH", _llvm_library())
    try:
        import mitsuba as mi
    except ImportError:
        raise PanoLightError("mitsuba is not installed (pip install 'panolight[mitsuba]' or scripts/setup.sh)") from None
    mi.set_variant(chosen)
    _MI = mi
    return mi


# ---------------------------------------------------------------------------------------- lighting
def _disk_cover(dirs: np.ndarray, direction, angle: float) -> np.ndarray:
    return (dirs @ np.asarray(direction, dtype=np.float64)) >= math.cos(max(angle / 2.0, 1e-6))


def envmap_bitmap(coeffs: np.ndarray, lights=(), height: int = 256) -> np.ndarray:
    """(height, 2 height, 3) float32 Mitsuba envmap texels: the SH radiance at Mitsuba's texel
    directions (rows theta = pi y / (H - 1), columns u = (x + 0.5) / W, our frame), with area lights
    painted in as disks carrying their irradiance. Where the SH radiance rings below zero the texels are its
    nearest non-negative map with the same bands 0-2 (sh.nonnegative: no light added or removed)."""
    w = 2 * height
    theta = np.pi * np.arange(height) / (height - 1)
    u = (np.arange(w) + 0.5) / w
    st = np.sin(theta)[:, None]
    dirs = np.stack(np.broadcast_arrays(-st * np.cos(2 * np.pi * u), st * np.sin(2 * np.pi * u),
                                        np.cos(theta)[:, None]), axis=-1)
    img = sh.basis(dirs.reshape(-1, 3), sh.lmax_from_count(coeffs.shape[0]), check_unit=False) @ coeffs
    omega = (2 * np.pi / w) * (np.pi / (height - 1)) * np.maximum(st, np.sin(np.pi / (2 * (height - 1))))
    # no negative light, nothing clipped: the nearest non-negative texels with the same bands 0-2
    img = sh.nonnegative(img.reshape(height, w, 3), dirs, np.broadcast_to(omega, (height, w)))[0]
    for light in lights:
        if light["type"] == "sun":
            continue
        cover = _disk_cover(dirs, light["direction"], light["angle"])
        if not cover.any():  # smaller than a texel: the nearest texel carries it
            cover = np.zeros(cover.shape, bool)
            cover[np.unravel_index(np.argmax(dirs @ np.asarray(light["direction"])), cover.shape)] = True
        sa = float((omega[:, 0][:, None] * cover).sum() if omega.ndim == 2 else (omega * cover).sum())
        img[cover] += (light["intensity"] / sa) * np.asarray(light["color"])
    return img.astype(np.float32)


def scene_emitters(coeffs: np.ndarray, lights=(), env_height: int = 256, scale: float = 1.0) -> dict:
    """Mitsuba emitter dicts for a lighting model (SH + lights), in the Blender world frame."""
    mi = mitsuba()
    emitters = {"env": {"type": "envmap", "bitmap": mi.Bitmap(envmap_bitmap(coeffs * scale, lights_scaled(lights, scale),
                                                                          env_height)),
                        "to_world": mi.ScalarTransform4f(ENV_TO_WORLD)}}
    for i, light in enumerate(lights):
        if light["type"] == "sun":
            rgb = (np.asarray(light["color"]) * light["intensity"] * scale).tolist()
            emitters[f"sun{i}"] = {"type": "directional", "direction": (-np.asarray(light["direction"])).tolist(),
                                   "irradiance": {"type": "rgb", "value": rgb}}
    return emitters


def lights_scaled(lights, scale):
    return [dict(l, intensity=l["intensity"] * scale) for l in lights]


def hdr_emitter(image: np.ndarray) -> dict:
    """An envmap emitter of an equirect HDR panorama (for ground-truth comparisons)."""
    mi = mitsuba()
    h = image.shape[0]
    theta = np.pi * np.arange(h) / (h - 1)
    rows = np.clip(theta / np.pi * h - 0.5, 0, h - 1)  # resample rows to Mitsuba's pole-to-pole texels
    y0 = np.floor(rows).astype(int)
    y1 = np.minimum(y0 + 1, h - 1)
    f = (rows - y0)[:, None, None]
    bitmap = (image[y0] * (1 - f) + image[y1] * f).astype(np.float32)
    return {"env": {"type": "envmap", "bitmap": mi.Bitmap(bitmap), "to_world": mi.ScalarTransform4f(ENV_TO_WORLD)}}


# ------------------------------------------------------------------------------------------ camera
def view_basis(yaw_deg: float, pitch_deg: float):
    """Camera forward, right and up vectors for a view at yaw (counter-clockwise from +X, seen from
    above: yaw 0 is the panorama's centre, yaw 90 is +Y, a quarter width left) and pitch (up > 0)."""
    yaw, pitch = math.radians(yaw_deg), math.radians(pitch_deg)
    fwd = np.array([math.cos(yaw) * math.cos(pitch), math.sin(yaw) * math.cos(pitch), math.sin(pitch)])
    right = np.cross(fwd, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, fwd)
    return fwd, right, up


def perspective_rays(width: int, height: int, fov_deg: float, yaw_deg: float, pitch_deg: float) -> np.ndarray:
    """(H, W, 3) unit world ray directions of Mitsuba's perspective camera (horizontal fov, pixel
    centres, image x to the right, y down) for the view; used to resample panoramas into the view."""
    fwd, right, up = view_basis(yaw_deg, pitch_deg)
    t = math.tan(math.radians(fov_deg) / 2.0)
    xs = ((np.arange(width) + 0.5) / width * 2 - 1) * t
    ys = ((np.arange(height) + 0.5) / height * 2 - 1) * t * height / width
    d = fwd[None, None, :] + xs[None, :, None] * right[None, None, :] - ys[:, None, None] * up[None, None, :]
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def _sensor(width, height, fov, yaw, pitch, spp):
    mi = mitsuba()
    fwd, _, up = view_basis(yaw, pitch)
    return {"type": "perspective", "fov": fov, "fov_axis": "x",
            "to_world": mi.ScalarTransform4f().look_at(origin=[0, 0, 0], target=fwd.tolist(), up=up.tolist()),
            "sampler": {"type": "independent", "sample_count": spp},
            "film": {"type": "hdrfilm", "width": width, "height": height, "pixel_format": "rgba",
                     "rfilter": {"type": "box"}}}


# ------------------------------------------------------------------------------------------ shapes
def mesh_shapes(mesh_paths, material: str, yaw_deg: float) -> dict:
    """Meshes (+Y up files) turned to Z up, scaled to OBJECT_HEIGHT and stood side by side on the
    ground, DISTANCE in front of the view direction at ``yaw_deg``."""
    mi = mitsuba()
    if material not in MATERIALS:
        raise PanoLightError(f"unknown material {material!r}; choose from {', '.join(MATERIALS)}")
    fwd, right, _ = view_basis(yaw_deg, 0.0)
    shapes = {}
    n = len(mesh_paths)
    for i, path in enumerate(mesh_paths):
        p = Path(path)
        kind = {".ply": "ply", ".obj": "obj"}.get(p.suffix.lower())
        if kind is None or not p.is_file():
            raise PanoLightError(f"{p}: {'not found' if not p.is_file() else 'meshes must be .ply or .obj'}")
        probe = mi.load_dict({"type": kind, "filename": str(p)})
        bbox = probe.bbox()
        lo, hi = np.array(bbox.min), np.array(bbox.max)
        size_y = float(hi[1] - lo[1])
        if not size_y > 0:
            raise PanoLightError(f"{p}: the mesh has no height along +Y")
        s = OBJECT_HEIGHT / size_y
        centre = (lo + hi) / 2
        offset = (i - (n - 1) / 2) * 0.8
        pos = DISTANCE * fwd + offset * right + np.array([0, 0, -EYE_HEIGHT])
        # file (x, y, z) with +Y up -> world: x_w = x, y_w = -z, z_w = y (a +90 degree turn about X)
        m = np.array([[1, 0, 0], [0, 0, -1], [0, 1, 0]], dtype=np.float64) * s
        t = pos - m @ np.array([centre[0], lo[1], centre[2]])
        mat = np.eye(4)
        mat[:3, :3] = m
        mat[:3, 3] = t
        # two-sided: scanned meshes may wind some faces inward (the zippered bunny does), which a
        # one-sided BSDF would show as black
        shapes[f"object{i}"] = {"type": kind, "filename": str(p), "to_world": mi.ScalarTransform4f(mat),
                                "bsdf": {"type": "twosided", "material": dict(MATERIALS[material])}}
    return shapes


def ground_shape() -> dict:
    mi = mitsuba()
    return {"type": "rectangle",
            "to_world": mi.ScalarTransform4f().translate([0, 0, -EYE_HEIGHT]).scale([20.0, 20.0, 1.0]),
            "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": [GROUND_ALBEDO] * 3}}}


def _render(emitters: dict, shapes: dict, sensor: dict, spp: int, seed: int = 0) -> np.ndarray:
    mi = mitsuba()
    scene = mi.load_dict({"type": "scene", "integrator": {"type": "path", "max_depth": 8}, "sensor": sensor,
                          **emitters, **shapes})
    return np.array(mi.render(scene, spp=spp, seed=seed), dtype=np.float64)


def composite_view(emitters, objects: dict, background: np.ndarray, sensor_args: tuple, spp: int) -> dict:
    """Differential rendering of ``objects`` over ``background`` (the panorama resampled to the view)."""
    ground = {"ground": ground_shape()}
    # A and B share a seed: where only the ground is seen their samples match, so the ratio's noise cancels
    a = _render(emitters, {**objects, **ground}, _sensor(*sensor_args, spp), spp, seed=0)
    b = _render(emitters, ground, _sensor(*sensor_args, spp), spp, seed=0)
    mask_spp = max(4, min(spp, 16))
    # geometry masks come from renders without emitters (with an envmap every pixel has alpha 1)
    c = _render({}, objects, _sensor(*sensor_args, mask_spp), mask_spp, seed=2)[..., 3:4]
    g = _render({}, ground, _sensor(*sensor_args, mask_spp), mask_spp, seed=3)[..., 3:4]
    ratio = np.where(b[..., :3] > 1e-8, a[..., :3] / np.maximum(b[..., :3], 1e-8), 1.0)
    ratio = g * np.clip(ratio, 0.0, 1.5) + (1 - g)
    final = c * a[..., :3] + (1 - c) * background * ratio
    return {"composite": final, "objects_and_ground": a[..., :3], "ground": b[..., :3], "mask": c[..., 0],
            "ground_mask": g[..., 0], "ratio": ratio}


CUBE_FACES = ((0, 0), (90, 0), (180, 0), (270, 0), (0, 90), (0, -90))


def faces_to_equirect(faces, height: int, width: int) -> np.ndarray:
    """Nearest-resample the six 90-degree CUBE_FACES renders (each (F, F, C)) to an (H, W, C) equirect
    image in the CONVENTIONS.md frame (each direction takes the face it points into most)."""
    face = faces[0].shape[0]
    dirs = sh.pixel_directions(height, width)
    out = np.zeros((height, width, faces[0].shape[-1]))
    best = np.full((height, width), -np.inf)
    for (yaw, pitch), img in zip(CUBE_FACES, faces):
        fwd, right, up = view_basis(yaw, pitch)
        z = dirs @ fwd
        x = (dirs @ right) / np.maximum(z, 1e-9)
        y = -(dirs @ up) / np.maximum(z, 1e-9)
        sel = (z > best) & (np.abs(x) <= 1) & (np.abs(y) <= 1) & (z > 0)
        px = np.clip(((x + 1) / 2 * face).astype(int), 0, face - 1)[sel]
        py = np.clip(((y + 1) / 2 * face).astype(int), 0, face - 1)[sel]
        out[sel] = img[py, px]
        best = np.where(sel, z, best)
    return out


def panorama_view(emitters, objects: dict, panorama: np.ndarray, face: int, spp: int) -> dict:
    """The objects placed in the panorama itself: six 90-degree faces are rendered, their object shading,
    object mask and shadow ratio resampled to equirect, and composited over the full-resolution panorama."""
    h, w = panorama.shape[:2]
    dummy = np.ones((face, face, 3))
    faces = []
    for yaw, pitch in CUBE_FACES:
        v = composite_view(emitters, objects, dummy, (face, face, 90.0, yaw, pitch), spp)
        faces.append(np.concatenate([v["objects_and_ground"], v["mask"][..., None], v["ratio"]], axis=-1))
    eq = faces_to_equirect(faces, h, w)
    shade, mask, ratio = eq[..., :3], eq[..., 3:4], eq[..., 4:7]
    return {"composite": mask * shade + (1 - mask) * panorama * ratio, "mask": mask[..., 0]}


# ------------------------------------------------------------------------------------------ figure
def default_meshes() -> list[Path]:
    """bunny.ply and armadillo.obj from ../shared/data/meshes (beside the repository, or the cwd)."""
    roots = [Path(__file__).resolve().parents[3] / "shared/data/meshes", Path.cwd().parent / "shared/data/meshes",
             Path.cwd() / "../shared/data/meshes"]
    for root in roots:
        files = [root / "bunny.ply", root / "armadillo.obj"]
        if all(f.is_file() for f in files):
            return files
    raise PanoLightError("no meshes given and ../shared/data/meshes/{bunny.ply,armadillo.obj} not found; "
                         "pass --meshes PATH [PATH ...] (.ply or .obj, +Y up)")


def _verified_source(lighting_path: Path, source: dict) -> Path | None:
    """The panorama a lighting file was estimated from, as its background: only when ``source.path``
    is a file whose SHA-256 is ``source.sha256`` (a lighting file cannot make the renderer read any
    other file); otherwise a warning and None (a neutral background)."""
    import warnings

    from panolight_core.errors import PanoLightWarning
    from panolight_core.io.ownership import digest as file_digest

    path, digest = source.get("path"), source.get("sha256")
    if not path:
        return None
    p = Path(path)
    found = file_digest(p) if digest and p.is_file() else None  # None: unreadable
    ok = found is not None and found["sha256"] == digest
    if not ok:
        warnings.warn(PanoLightWarning(f"{lighting_path}: its source panorama {path} is missing or not the file "
                                       f"it was estimated from (SHA-256 differs); rendering over a grey background"), stacklevel=2)
        return None
    return p


class RenderInput(NamedTuple):
    """One row of the figure. coeffs (K, 3) and lights: the lighting; panorama: (H, W, 3) linear background in the
    same units, or None; label; truth: the HDR truth in those units (--from-ldr), or None; white: the photo's white
    (a linear 1 in its own relative units) in these units, so 1 / white is the exposure that shows the plate as shot;
    units: "cd/m^2" where the photo's scale is known (its EXIF, or lighting.json's physical block), else "relative"."""

    coeffs: np.ndarray
    lights: list
    panorama: np.ndarray | None
    label: str
    truth: np.ndarray | None
    white: float = 1.0
    units: str = "relative"


def load_input(path, lmax="auto", from_ldr=None) -> RenderInput:
    """The RenderInput of a panorama (estimated here with the default adaptive model) or a lighting.json (its
    source panorama is used as background when it exists). Every part is in the lighting's units: a lighting.json's
    background is its photo's linear pixels times ``camera.units.document_gain`` (cd/m^2 where its values carry the
    absolute scale), and a photo whose EXIF records its exposure is rendered in cd/m^2 (docs/units.md). from_ldr: an
    ev; an HDR input is first turned into the JPEG an auto-exposing camera takes (EVALUATION.md, q90), which is
    estimated and shown, and ``truth`` is the HDR in that JPEG's units (k x HDR), for the ground-truth row; the
    figure then estimates from a photograph, as the paper's."""
    from panolight_core.camera import ldr_to_linear, units
    from panolight_core.estimators import estimate
    from panolight_core.estimators.highlights import CLIP_LEVEL
    from panolight_core.io import read_image
    from panolight_core.io.capture import read_exposure
    from panolight_core.io.lighting import read_lighting
    from panolight_core.lighting.adaptive import fit_model

    p = Path(path)
    if p.suffix.lower() == ".json":
        coeffs, doc = read_lighting(p)
        order = sh.lmax_from_count(coeffs.shape[0])
        if order > MAX_RENDER_ORDER:  # the envmap is the SH sampled per texel: memory grows as lmax^2
            raise PanoLightError(f"{p}: SH order {order} is above the {MAX_RENDER_ORDER} render-mitsuba renders; "
                                 f"re-estimate with a lower --lmax")
        try:
            gain = units.document_gain(doc)
        except ValueError as exc:
            raise PanoLightError(f"{p}: {exc}") from None
        applied = bool((doc.get("physical") or {}).get("applied"))
        pano = None
        src = _verified_source(p, doc.get("source") or {})
        if src is not None:
            px = read_image(src, ldr_as_uint8=True)
            pano = (ldr_to_linear(px) if px.dtype == np.uint8 else np.asarray(px, dtype=np.float64)) * gain
        return RenderInput(coeffs, doc.get("lights", []), pano, p.parent.name or p.stem, None, gain,
                           "cd/m^2" if applied else "relative")
    px = read_image(p, ldr_as_uint8=True)
    hdr = px.dtype != np.uint8
    truth = None
    if hdr and from_ldr is not None:
        from panolight_core.camera import auto_exposure, hdr_to_ldr

        truth = np.maximum(np.asarray(px, dtype=np.float64), 0.0)
        k = auto_exposure(truth, from_ldr, robust=True)
        px, truth, hdr = hdr_to_ldr(truth, from_ldr, 90, scale=k), truth * k, False
    est = estimate(px, 8, "auto")
    model = fit_model(est.radiance, lmax=lmax, light_threshold=None if hdr else CLIP_LEVEL, known_lights=est.lights,
                      exclude=est.light_exclusions)
    pano = np.asarray(px if hdr else ldr_to_linear(px), dtype=np.float64)
    label = p.stem if truth is None else f"{p.stem} JPEG ev {from_ldr:+g}"
    scale = units.from_exposure(read_exposure(p)) if truth is None else units.RELATIVE
    if not scale.absolute:
        return RenderInput(model.coeffs, model.lights, pano, label, truth)
    white = scale.cd_m2  # the photo's own exposure: everything in cd/m^2
    lights = [dict(light, intensity=light["intensity"] * white) for light in model.lights]
    return RenderInput(model.coeffs * white, lights, pano * white, label, None, white, "cd/m^2")


def render_figure(inputs, out_dir, meshes=None, spp: int = 512, resolution=(320, 240), yaw: float = 0.0,
                  pitch: float = -12.0, fov: float = 50.0, materials=("mirror", "plastic", "gold"),
                  in_panorama: bool = True, compare_hdr: bool = False, env_height: int = 256,
                  from_ldr: float | None = None, log=print) -> dict:
    """Render every input x material (perspective view, and optionally the in-panorama view), write an
    EXR per render and figure.png (rows: inputs, columns: materials). from_ldr: estimate HDR inputs
    from their camera JPEG at that ev (see load_input). Each row is shown at its photo's exposure (1 / white) where
    it is in cd/m^2, else with its median at 0.18. Returns the paths, timings and each row's display exposure."""
    from panolight_core.io import read_image, write_image
    from panolight_core.pipeline.preview import exposure_for, tonemap

    mi = mitsuba()
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    meshes = [Path(m) for m in (meshes or default_meshes())]
    w, h = resolution
    rows, files, t0 = [], [], time.perf_counter()
    is_hdr = [Path(i).suffix.lower() in (".exr", ".hdr") for i in inputs]
    total = len(materials) * sum(1 + int(compare_hdr and hdr) for hdr in is_hdr)
    done = 0
    for inp in inputs:
        coeffs, lights, pano, label, truth, white, in_units = load_input(inp, from_ldr=from_ldr)
        if pano is None:
            pano = np.full((64, 128, 3), 0.5 * white)
        bg = sample_equirect(pano, perspective_rays(w, h, fov, yaw, pitch))
        # shown as shot where the photo's scale is known (its white at white), else median grey at 0.18
        shown = 1.0 / white if in_units == "cd/m^2" else exposure_for(bg)
        if in_units == "cd/m^2":
            log(f"{label}: rendered in cd/m^2 (the photo's white {white:.4g} cd/m^2), shown at the photo's exposure")
        variants = [("estimated", scene_emitters(coeffs, lights, env_height))]
        if compare_hdr and truth is not None:
            variants.append(("ground truth", hdr_emitter(truth)))
        elif compare_hdr and Path(inp).suffix.lower() in (".exr", ".hdr"):
            variants.append(("ground truth", hdr_emitter(np.asarray(read_image(inp), dtype=np.float64))))
        elif compare_hdr:
            log(f"{inp}: not an HDR file, so no ground-truth row for it")
        for vname, emitters in variants:
            row = []
            for mat in materials:
                objects = mesh_shapes(meshes, mat, yaw)
                t = time.perf_counter()
                res = composite_view(emitters, objects, bg, (w, h, fov, yaw, pitch), spp)
                stem = f"{label}-{vname.replace(' ', '_')}-{mat}"
                files.append(write_image(out / f"{stem}.exr", res["composite"].astype(np.float32)))
                if in_panorama and vname == "estimated":
                    pv = panorama_view(emitters, objects, pano, max(32, h // 2), spp)
                    files.append(write_image(out / f"{stem}-panorama.exr", pv["composite"].astype(np.float32)))
                done += 1
                log(f"[{done}/{total}] {label} {vname} {mat}: {time.perf_counter() - t:.1f} s")
                row.append((mat, res["composite"]))
            rows.append((f"{label} ({vname})", row, shown))
    grid = _grid_png(rows, tonemap)
    from panolight_core.io import write_srgb8

    write_srgb8(out / "figure.png", grid)
    return {"figure": str(out / "figure.png"), "renders": [str(f) for f in files], "variant": mi.variant(),
            "seconds": time.perf_counter() - t0, "spp": spp, "resolution": list(resolution),
            "exposures": {label: exposure for label, _, exposure in rows}}


def _grid_png(rows, tonemap) -> np.ndarray:
    from PIL import Image, ImageDraw

    tiles = []
    for label, row, exposure in rows:
        imgs = []
        for mat, img in row:
            tile = Image.fromarray(tonemap(img, exposure))
            d = ImageDraw.Draw(tile)
            text = f"{label}: {mat}"
            d.rectangle((0, 0, 8 + 6 * len(text), 14), fill=(0, 0, 0))
            d.text((3, 1), text, fill=(255, 255, 255))
            imgs.append(np.asarray(tile))
        gap = np.full((imgs[0].shape[0], 3, 3), 255, np.uint8)
        line = [imgs[0]]
        for im in imgs[1:]:
            line += [gap, im]
        tiles.append(np.concatenate(line, axis=1))
    hgap = np.full((3, tiles[0].shape[1], 3), 255, np.uint8)
    out = [tiles[0]]
    for t in tiles[1:]:
        out += [hgap, t]
    return np.concatenate(out, axis=0)
