"""Procedural HDR environment maps (equirect, linear Rec.709, Blender world frame): outdoor skies
with a sun and lit ground, and rooms with lamps and windows. Deterministic from a seed.

Physical anchors (no image data involved):
- Sky: the CIE standard general sky (CIE S 011/E:2003) with the clear-sky parameters of type 12
  (gradation a = -1, b = -0.32; indicatrix c = 10, d = -3, e = 0.45: brightening around the sun) or the
  overcast type 1 (a = 4, b = -0.7, c = 0, d = -1, e = 0).
- Sun: a disk of 0.27 degrees radius whose normal irradiance is 2..10 times the sky's horizontal
  irradiance (hazy to clear; clear days have direct normal ~ 800-900 W/m^2 against diffuse ~ 100-150).
- Ground and walls: Lambertian, albedo 0.08..0.4, radiance rho / pi times the irradiance they receive
  (sun times cosine, unless in shadow, plus sky), with smooth multiplicative texture.
- Lamps: small disks (1..6 degrees) 30..3000 times brighter than the walls; windows: rectangles 5..60
  times brighter.
Used to calibrate and test the LDR highlight recovery and the adaptive model, and as a lighting pool for
training data (training/neural/, training/synth/).
"""
from __future__ import annotations

import math

import numpy as np

from . import sh

SUN_RADIUS = math.radians(0.2666)


def _smooth_noise(rng, h, w, scale=8, amount=0.3):
    """Positive multiplicative texture: bilinear upsample of coarse log-normal noise."""
    coarse = rng.normal(0.0, amount, size=(scale + 1, 2 * scale + 1))
    ys = np.linspace(0, scale, h)
    xs = np.linspace(0, 2 * scale, w)
    y0, x0 = np.floor(ys).astype(int).clip(0, scale - 1), np.floor(xs).astype(int).clip(0, 2 * scale - 1)
    fy, fx = (ys - y0)[:, None], (xs - x0)[None, :]
    c = coarse
    v = (c[y0][:, x0] * (1 - fy) * (1 - fx) + c[y0 + 1][:, x0] * fy * (1 - fx)
         + c[y0][:, x0 + 1] * (1 - fy) * fx + c[y0 + 1][:, x0 + 1] * fy * fx)
    return np.exp(v)


def _disk(dirs, centre, radius, omega):
    """Fraction of each pixel covered by a small disk (exact enough for radius >= a pixel, and
    energy-conserving below: a sub-pixel disk deposits its solid angle in the nearest pixel)."""
    cosang = dirs @ centre
    cover = (cosang >= math.cos(radius)).astype(np.float64)
    disk_sa = 2 * math.pi * (1 - math.cos(radius))
    got = float((cover * omega).sum())
    if got < 0.5 * disk_sa:
        cover = np.zeros_like(cosang)
        iy, ix = np.unravel_index(np.argmax(cosang), cosang.shape)
        cover[iy, ix] = disk_sa / omega[iy, ix]
    return cover


def cie_sky(dirs, sun_dir, kind="clear"):
    """Relative CIE general-sky luminance for directions above the horizon (0 below)."""
    a, b, c, d, e = (-1.0, -0.32, 10.0, -3.0, 0.45) if kind == "clear" else (4.0, -0.7, 0.0, -1.0, 0.0)
    cz = np.clip(dirs[..., 2], 1e-3, 1.0)
    chi = np.arccos(np.clip(dirs @ sun_dir, -1, 1))
    grad = 1 + a * np.exp(b / cz)
    ind = 1 + c * (np.exp(d * chi) - math.exp(d * math.pi / 2)) + e * np.cos(chi) ** 2
    return np.where(dirs[..., 2] > 0, grad * ind, 0.0)


def outdoor(rng, height=256):
    """(H, 2H, 3) outdoor environment with parameters drawn from ``rng``; returns (image, params)."""
    w = 2 * height
    dirs = sh.pixel_directions(height, w)
    omega = sh.pixel_solid_angles(height, w)
    overcast = rng.random() < 0.25
    elev = math.radians(rng.uniform(3, 75))
    az = rng.uniform(0, 2 * math.pi)
    sun_dir = np.array([math.cos(elev) * math.cos(az), math.cos(elev) * math.sin(az), math.sin(elev)])
    sky = cie_sky(dirs, sun_dir, "overcast" if overcast else "clear")
    tint_zenith = np.array([0.55, 0.75, 1.0]) if not overcast else np.array([0.9, 0.95, 1.0])
    tint_horizon = np.array([1.0, 0.95, 0.9])
    t = np.clip(dirs[..., 2:3], 0, 1) ** 0.5
    sky_rgb = sky[..., None] * (t * tint_zenith + (1 - t) * tint_horizon)
    up = np.maximum(dirs[..., 2], 0) * omega
    e_sky_h = float(((sky_rgb @ [0.2126, 0.7152, 0.0722]) * up).sum())
    img = sky_rgb.copy()
    sun_color = np.array([1.0, 0.85 + 0.15 * math.sin(elev), 0.65 + 0.35 * math.sin(elev)])
    e_sun_n = 0.0
    cover = np.zeros((height, w))
    if not overcast:
        e_sun_n = rng.uniform(2, 10) * e_sky_h
        cover = _disk(dirs, sun_dir, SUN_RADIUS, omega)
        sun_sa = 2 * math.pi * (1 - math.cos(SUN_RADIUS))
        img += cover[..., None] * (e_sun_n / sun_sa) * sun_color / float(sun_color @ [0.2126, 0.7152, 0.0722])
    albedo = rng.uniform(0.08, 0.35)
    ground_tint = rng.uniform(0.7, 1.0, size=3)
    shadow = (_smooth_noise(rng, height, w, 6, 1.0) < rng.uniform(0.3, 1.5)).astype(np.float64)
    e_ground = e_sun_n * math.sin(elev) * shadow + e_sky_h
    ground = (albedo / math.pi) * e_ground[..., None] * ground_tint * _smooth_noise(rng, height, w, 12, 0.25)[..., None]
    below = dirs[..., 2] <= 0
    img[below] = ground[below]
    # occluders near the horizon (buildings, trees): lit diffuse surfaces
    occ = (dirs[..., 2] > 0) & (dirs[..., 2] < _smooth_noise(rng, height, w, 10, 0.8)[...] * rng.uniform(0.0, 0.25))
    img[occ] = ((rng.uniform(0.05, 0.3) / math.pi) * (0.5 * e_sky_h + e_sun_n * 0.3 * rng.random())
                * ground_tint)[None, :] * np.ones((int(occ.sum()), 1))
    sun_visible = bool(not overcast and not (occ & (cover > 0)).any())
    return img, {"kind": "outdoor", "overcast": overcast, "sun_direction": sun_dir.tolist(),
                 "sun_to_sky": e_sun_n / e_sky_h, "sun_visible": sun_visible}


def indoor(rng, height=256):
    """(H, 2H, 3) room with lamps and windows; returns (image, params)."""
    w = 2 * height
    dirs = sh.pixel_directions(height, w)
    omega = sh.pixel_solid_angles(height, w)
    wall = rng.uniform(0.15, 0.4) * rng.uniform(0.7, 1.0, size=3)
    shade = 0.6 + 0.4 * (dirs[..., 2:3] + 1) / 2  # ceilings and upper walls a little brighter
    img = wall * shade * _smooth_noise(rng, height, w, 10, 0.3)[..., None]
    lamps = []
    for _ in range(rng.integers(0, 4)):
        el = math.radians(rng.uniform(20, 88))
        az = rng.uniform(0, 2 * math.pi)
        d = np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])
        radius = math.radians(rng.uniform(1, 6))
        ratio = 10 ** rng.uniform(1.5, 3.5)
        cover = _disk(dirs, d, radius, omega)
        img = img * (1 - np.minimum(cover, 1)[..., None]) + cover[..., None] * ratio * np.array([1.0, 0.9, 0.75])
        lamps.append(d.tolist())
    for _ in range(rng.integers(0 if lamps else 1, 3)):
        az = rng.uniform(0, 2 * math.pi)
        half_w, el0, el1 = math.radians(rng.uniform(8, 30)), math.radians(rng.uniform(-10, 10)), math.radians(rng.uniform(20, 50))
        phi = np.arctan2(dirs[..., 1], dirs[..., 0])
        dphi = np.angle(np.exp(1j * (phi - az)))
        el = np.arcsin(np.clip(dirs[..., 2], -1, 1))
        win = (np.abs(dphi) < half_w) & (el > el0) & (el < el1)
        img[win] = 10 ** rng.uniform(0.7, 1.8) * np.array([0.85, 0.92, 1.0]) * (1 + 0.3 * dirs[win][:, 2:3])
    return img, {"kind": "indoor", "lamps": lamps}


def environment(seed: int, height: int = 256):
    """One environment from an integer seed: 60 % outdoor, 40 % indoor."""
    rng = np.random.default_rng(seed)
    return outdoor(rng, height) if rng.random() < 0.6 else indoor(rng, height)
