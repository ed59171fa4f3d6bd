"""Random Mitsuba 3 scenes rendered into 360-degree panoramas with normals and albedo.

Rooms: a box (2.5-4 m high, 3-9 m wide) made L-shaped half the time by a solid block in one corner,
walls split around 1-2 window openings through which a procedural sky with its sun (training/synth/
environments.py, an envmap outside) lights the room, 1-3 ceiling lamps (area emitters) and sometimes a
floor lamp (an emissive sphere), 2-6 furniture boxes and spheres, checkerboard or noise albedo textures.
Outdoor: a textured ground, box buildings and sphere trees around the camera, under the sky.
The camera stands at a random free point (1.2-1.7 m high). Six 90-degree faces rendered with Mitsuba's
``aov`` integrator (radiance, shading normal, albedo) are resampled (nearest) to an equirect panorama in
the CONVENTIONS.md frame; normals are turned to face the camera, pixels without a surface get normal 0
and mask 0. Everything is deterministic from the seed.
"""
from __future__ import annotations

import math

import numpy as np

from panolight_core import sh
from panolight_core.synthetic import outdoor as outdoor_sky
from training.render import mitsuba as mr

FACE_YAW_PITCH = mr.CUBE_FACES


def _frame(center, u, v, n, hu, hv):
    m = np.eye(4)
    m[:3, 0] = np.asarray(u, float) * hu
    m[:3, 1] = np.asarray(v, float) * hv
    m[:3, 2] = np.asarray(n, float)
    m[:3, 3] = center
    return m


def _diffuse(rgb=None, texture=None):
    refl = texture if texture is not None else {"type": "rgb", "value": list(map(float, rgb))}
    return {"type": "twosided", "material": {"type": "diffuse", "reflectance": refl}}


def _texture(rng, mi):
    """A random albedo texture: a checkerboard or smooth noise (linear albedo 0.05-0.85)."""
    base = rng.uniform(0.15, 0.75, size=3)
    if rng.random() < 0.5:
        other = np.clip(base * rng.uniform(0.4, 1.3, size=3), 0.05, 0.85)
        k = float(rng.uniform(2, 12))
        return {"type": "checkerboard", "color0": {"type": "rgb", "value": base.tolist()},
                "color1": {"type": "rgb", "value": other.tolist()}, "to_uv": mi.ScalarTransform4f().scale([k, k, 1])}
    n = 16
    noise = np.exp(rng.normal(0, 0.25, size=(n, n, 1))) * base[None, None, :]
    return {"type": "bitmap", "bitmap": mi.Bitmap(np.clip(noise, 0.05, 0.85).astype(np.float32)), "raw": True}


def _wall_with_windows(mi, center, u, v, n, hu, hv, windows, bsdf):
    """Rectangles covering a wall (half sizes hu x hv) except the window openings (in wall uv metres,
    each (cu, cv, wu, wv) centre and half size). Returns a dict of shapes."""
    shapes = {}
    if not windows:
        shapes["w"] = {"type": "rectangle", "to_world": mi.ScalarTransform4f(_frame(center, u, v, n, hu, hv)),
                       "bsdf": bsdf}
        return shapes
    cu, cv, wu, wv = windows[0]
    pieces = [(-hu, cu - wu, -hv, hv), (cu + wu, hu, -hv, hv), (cu - wu, cu + wu, -hv, cv - wv),
              (cu - wu, cu + wu, cv + wv, hv)]
    for i, (u0, u1, v0, v1) in enumerate(pieces):
        if u1 - u0 < 1e-3 or v1 - v0 < 1e-3:
            continue
        c = np.asarray(center) + np.asarray(u) * (u0 + u1) / 2 + np.asarray(v) * (v0 + v1) / 2
        shapes[f"p{i}"] = {"type": "rectangle", "bsdf": bsdf,
                           "to_world": mi.ScalarTransform4f(_frame(c, u, v, n, (u1 - u0) / 2, (v1 - v0) / 2))}
    return shapes


def room(rng, mi):
    """(shapes and emitters dict, camera position, parameters) of a random room."""
    w, d, h = rng.uniform(3, 9), rng.uniform(3, 9), rng.uniform(2.5, 4.0)
    sky, sky_params = outdoor_sky(rng, 128)
    items = dict(mr.hdr_emitter(sky))
    walls = [  # centre, u, v, inward normal, half sizes
        ((w / 2, 0, h / 2), (0, 1, 0), (0, 0, 1), (-1, 0, 0), d / 2, h / 2),
        ((-w / 2, 0, h / 2), (0, 1, 0), (0, 0, 1), (1, 0, 0), d / 2, h / 2),
        ((0, d / 2, h / 2), (1, 0, 0), (0, 0, 1), (0, -1, 0), w / 2, h / 2),
        ((0, -d / 2, h / 2), (1, 0, 0), (0, 0, 1), (0, 1, 0), w / 2, h / 2),
    ]
    n_windows = int(rng.integers(1, 3))
    with_window = set(rng.choice(4, size=n_windows, replace=False).tolist())
    for i, (c, u, v, n, hu, hv) in enumerate(walls):
        win = []
        if i in with_window:
            wu, wv = rng.uniform(0.3, min(1.2, hu * 0.6)), rng.uniform(0.4, min(1.0, hv * 0.6))
            win = [(rng.uniform(-hu + wu + 0.1, hu - wu - 0.1), rng.uniform(-hv + wv + 0.6, hv - wv - 0.1) * 0.5,
                    wu, wv)]
        for k, s in _wall_with_windows(mi, c, u, v, n, hu, hv, win, _diffuse(texture=_texture(rng, mi))).items():
            items[f"wall{i}_{k}"] = s
    items["floor"] = {"type": "rectangle", "to_world": mi.ScalarTransform4f(
        _frame((0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1), w / 2, d / 2)), "bsdf": _diffuse(texture=_texture(rng, mi))}
    items["ceiling"] = {"type": "rectangle", "to_world": mi.ScalarTransform4f(
        _frame((0, 0, h), (1, 0, 0), (0, 1, 0), (0, 0, -1), w / 2, d / 2)),
        "bsdf": _diffuse(rgb=rng.uniform(0.6, 0.85, size=3))}
    blocked = []  # (x, y, radius) footprints the camera must avoid
    l_shaped = rng.random() < 0.5
    if l_shaped:  # a solid block fills one corner: an L-shaped floor plan
        sx, sy = rng.choice([-1, 1], size=2)
        bw, bd = rng.uniform(0.25, 0.45) * w, rng.uniform(0.25, 0.45) * d
        cx, cy = sx * (w / 2 - bw / 2), sy * (d / 2 - bd / 2)
        items["corner_block"] = {"type": "cube", "bsdf": _diffuse(texture=_texture(rng, mi)),
                                 "to_world": mi.ScalarTransform4f().translate([cx, cy, h / 2]).scale([bw / 2, bd / 2, h / 2])}
        blocked.append((cx, cy, math.hypot(bw, bd) / 2 + 0.4))
    lamps = []
    for i in range(int(rng.integers(1, 4))):
        lx, ly = rng.uniform(-w / 2 + 0.5, w / 2 - 0.5), rng.uniform(-d / 2 + 0.5, d / 2 - 0.5)
        s = rng.uniform(0.1, 0.3)
        radiance = (rng.uniform(5, 40) * np.array([1.0, 0.9, 0.75])).tolist()
        items[f"lamp{i}"] = {"type": "rectangle", "to_world": mi.ScalarTransform4f(
            _frame((lx, ly, h - 0.01), (1, 0, 0), (0, 1, 0), (0, 0, -1), s, s)),
            "emitter": {"type": "area", "radiance": {"type": "rgb", "value": radiance}}}
        lamps.append([lx, ly, h - 0.01])
    if rng.random() < 0.4:
        lx, ly = rng.uniform(-w / 2 + 0.4, w / 2 - 0.4), rng.uniform(-d / 2 + 0.4, d / 2 - 0.4)
        items["floor_lamp"] = {"type": "sphere", "center": [lx, ly, 1.5], "radius": 0.12,
                               "emitter": {"type": "area", "radiance": {"type": "rgb", "value": [20.0, 17.0, 12.0]}}}
        blocked.append((lx, ly, 0.5))
    for i in range(int(rng.integers(2, 7))):
        fx, fy = rng.uniform(-w / 2 + 0.4, w / 2 - 0.4), rng.uniform(-d / 2 + 0.4, d / 2 - 0.4)
        if rng.random() < 0.6:
            sx, sy, sz = rng.uniform(0.2, 0.8), rng.uniform(0.2, 0.8), rng.uniform(0.2, 0.6)
            items[f"furniture{i}"] = {"type": "cube", "bsdf": _diffuse(texture=_texture(rng, mi)),
                                      "to_world": mi.ScalarTransform4f().translate([fx, fy, sz]).scale([sx, sy, sz])}
            blocked.append((fx, fy, math.hypot(sx, sy) + 0.3))
        else:
            r = rng.uniform(0.15, 0.5)
            items[f"furniture{i}"] = {"type": "sphere", "center": [fx, fy, r], "radius": r,
                                      "bsdf": _diffuse(rgb=rng.uniform(0.1, 0.8, size=3))}
            blocked.append((fx, fy, r + 0.3))
    cam = _free_point(rng, w, d, blocked, rng.uniform(1.2, 1.7))
    return items, cam, {"kind": "room", "size": [w, d, h], "l_shaped": bool(l_shaped), "windows": n_windows,
                        "lamps": lamps, "sky": sky_params}


def _free_point(rng, w, d, blocked, height):
    for _ in range(200):
        x, y = rng.uniform(-w / 2 + 0.5, w / 2 - 0.5), rng.uniform(-d / 2 + 0.5, d / 2 - 0.5)
        if all(math.hypot(x - bx, y - by) > br for bx, by, br in blocked):
            return np.array([x, y, height])
    return np.array([0.0, 0.0, height])


def outdoor(rng, mi):
    """(items, camera position, parameters) of a random outdoor scene."""
    sky, sky_params = outdoor_sky(rng, 128)
    items = dict(mr.hdr_emitter(sky))
    items["ground"] = {"type": "rectangle", "bsdf": _diffuse(texture=_texture(rng, mi)),
                       "to_world": mi.ScalarTransform4f().scale([60.0, 60.0, 1.0])}
    for i in range(int(rng.integers(2, 9))):
        ang, dist = rng.uniform(0, 2 * math.pi), rng.uniform(5, 30)
        x, y = dist * math.cos(ang), dist * math.sin(ang)
        if rng.random() < 0.6:
            sx, sy, sz = rng.uniform(1, 5), rng.uniform(1, 5), rng.uniform(2, 12)
            items[f"building{i}"] = {"type": "cube", "bsdf": _diffuse(texture=_texture(rng, mi)),
                                     "to_world": mi.ScalarTransform4f().translate([x, y, sz]).scale([sx, sy, sz])}
        else:
            r = rng.uniform(1, 3)
            items[f"tree{i}"] = {"type": "sphere", "center": [x, y, r + rng.uniform(1, 3)], "radius": r,
                                 "bsdf": _diffuse(rgb=[0.05, rng.uniform(0.1, 0.3), 0.05])}
    return items, np.array([0.0, 0.0, rng.uniform(1.2, 1.7)]), {"kind": "outdoor", "sky": sky_params}


def render_panorama(items: dict, camera, height: int = 128, spp: int = 32, seed: int = 0, max_depth: int = 5):
    """Render a scene from ``camera`` into (radiance, normals, albedo, mask), each (H, 2H, ...) in the
    CONVENTIONS.md frame: six 90-degree faces (aov integrator), nearest-resampled to equirect."""
    mi = mr.mitsuba()
    w = 2 * height
    face = max(8, w // 4)
    cam = np.asarray(camera, dtype=np.float64)
    sensors = {}
    for k, (yaw, pitch) in enumerate(FACE_YAW_PITCH):
        fwd, _, up = mr.view_basis(yaw, pitch)
        sensors[f"sensor{k}"] = {
            "type": "perspective", "fov": 90.0, "fov_axis": "x",
            "to_world": mi.ScalarTransform4f().look_at(origin=cam.tolist(), target=(cam + fwd).tolist(), up=up.tolist()),
            "sampler": {"type": "independent", "sample_count": spp},
            "film": {"type": "hdrfilm", "width": face, "height": face, "pixel_format": "rgb", "rfilter": {"type": "box"}}}
    scene = mi.load_dict({"type": "scene", **sensors,
                          "integrator": {"type": "aov", "aovs": "nn:sh_normal,alb:albedo",
                                         "img": {"type": "path", "max_depth": max_depth}}, **items})
    faces = [np.array(mi.render(scene, sensor=k, spp=spp, seed=seed), dtype=np.float64)
             for k in range(len(FACE_YAW_PITCH))]
    out = mr.faces_to_equirect(faces, height, w)
    dirs = sh.pixel_directions(height, w)
    radiance, normals, albedo = out[..., :3], out[..., 3:6], out[..., 6:9]
    length = np.linalg.norm(normals, axis=-1, keepdims=True)
    mask = length[..., 0] > 0.5
    normals = np.where(mask[..., None], normals / np.maximum(length, 1e-12), 0.0)
    flip = (np.sum(normals * dirs, axis=-1, keepdims=True) > 0)  # face the camera: n . view_dir < 0
    normals = np.where(flip, -normals, normals)
    return {"radiance": np.maximum(radiance, 0.0), "normals": normals, "albedo": albedo, "mask": mask}


def sample(seed: int, height: int = 128, spp: int = 32) -> dict:
    """One training sample from a seed: 75 % rooms, 25 % outdoor."""
    mi = mr.mitsuba()
    rng = np.random.default_rng(seed)
    items, cam, params = room(rng, mi) if rng.random() < 0.75 else outdoor(rng, mi)
    out = render_panorama(items, cam, height, spp, seed=seed % (2 ** 31))
    out["params"] = {**params, "seed": seed, "camera": cam.tolist(), "spp": spp}
    return out
