"""lighting.usda: an estimate as a USD stage (UsdLux), for Houdini, Nuke, Omniverse and Blender's USD import.

The stage is Z up (the Blender world frame of lighting.json), metersPerUnit 1, default prim /PanoLight.
Its variant set "lighting" holds two rigs over the same folder's maps; they never add the same energy
twice:
- "lights" (default): the model of lighting.json. A DomeLight textured with radiance.exr (the SH part)
  and one DistantLight per explicit light (direction, angular size, colour, intensity).
- "hdri": a DomeLight textured with hdr.exr, whose pixels already hold the sun, lamps and windows at
  their estimated energy (so no DistantLights).

Orientation. UsdLux lat-long domes follow the OpenEXR convention with the pole along the dome's local
+Y: longitude +pi..-pi left to right, longitude 0 along local +Z, pi/2 along +X. lighting.json's
equirect maps (CONVENTIONS.md) look along world (sin t cos l, sin t sin l, cos t) at that longitude l,
so the dome gets the rotation DOME_TO_WORLD (local Z -> world X, X -> Y, Y -> Z). A DistantLight shines
along its local -Z; its transform points local +Z at the light's direction. It is normalised, so its
intensity is the irradiance on a surface facing the light (lighting.json's intensity times its largest
colour channel); colour is normalised to a largest channel of 1, angle is the angular diameter in
degrees (the UsdLux specification; Blender 5.0's importer reads 4x the strength and twice the angle).
Units (UsdLux's "Quantities and Units"): a light emits intensity x 2^exposure nits (cd/m^2), and a normalised
DistantLight's intensity x 2^exposure is the illuminance it gives, in lux. Where the absolute scale is known
(lighting.json's ``physical``) the stage emits those units: values already in cd/m^2 and lux (``applied``) get
exposure 0; relative ones (``--relative``) keep their intensities and textures and get exposure = log2 of the
camera's white in cd/m^2, so the stage renders the same either way. Where no scale is known, exposure stays 0 and
1 is the camera's white. The root says which (``panolight:physicalScale``: whether the values are in cd/m^2 and lux,
the camera's white in cd/m^2, EV100, the lights' exposure, and renderExposureEV: the camera exposure at which the
plate renders as shot).
Needs usd-core (``pip install usd-core``, the official Pixar bindings), imported only here.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..camera import units
from ..errors import PanoLightError
from ..threads import optional_module, signals_held
from .atomic import atomic_path

DOME_TO_WORLD = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])  # world = R @ dome-local
VARIANTS = ("lights", "hdri")


def _pxr():
    """usd-core's modules, imported with Ctrl-C and SIGTERM held until the import ends (``threads.signals_held``:
    interrupted in its plugin registration, usd-core printed tracebacks and swallowed the interrupt)."""
    try:
        if optional_module("pxr") is None:
            raise ImportError
        with signals_held():
            from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux
    except ImportError:
        raise PanoLightError("writing lighting.usda needs usd-core (pip install usd-core)") from None
    return Gf, Sdf, Usd, UsdGeom, UsdLux


def usd_available() -> bool:
    try:
        _pxr()
    except PanoLightError:
        return False
    return True


def light_frame(direction) -> np.ndarray:
    """(3, 3) rotation whose third column is the unit ``direction`` (a DistantLight's local +Z)."""
    z = np.asarray(direction, dtype=np.float64)
    z = z / np.linalg.norm(z)
    helper = np.array([0.0, 0.0, 1.0]) if abs(z[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    x = np.cross(helper, z)
    x /= np.linalg.norm(x)
    return np.stack([x, np.cross(z, x), z], axis=1)


def _transform(Gf, rotation: np.ndarray):
    """Gf.Matrix4d of a rotation (USD matrices are row-vector: row i is the image of local axis i)."""
    m = Gf.Matrix4d(1.0)
    for i in range(3):
        m.SetRow(i, Gf.Vec4d(*(float(v) for v in rotation[:, i]), 0.0))
    return m


def light_exposure(doc: dict) -> float:
    """UsdLux ``inputs:exposure`` of every light of the stage of ``doc``: log2 of the camera's white in cd/m^2 where a
    scale is known and the values are relative, so the stage emits nits and lux (module docstring); else 0."""
    physical = doc.get("physical") or {}
    if not physical.get("absolute") or physical.get("applied"):
        return 0.0
    return math.log2(float(physical["white_cd_m2"]))


def write_usd(path, doc: dict, *, hdri: str | None = "hdr.exr") -> Path:
    """Write the lighting document ``doc`` (io.lighting) as a USD stage at ``path`` (.usda or .usd).
    The dome textures, relative to the stage's folder: radiance.exr, and ``hdri`` (None: no "hdri" variant).
    Written atomically. Returns the path."""
    Gf, Sdf, Usd, UsdGeom, UsdLux = _pxr()
    p = Path(path)
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    root = UsdGeom.Xform.Define(stage, "/PanoLight")
    stage.SetDefaultPrim(root.GetPrim())
    root.GetPrim().SetCustomDataByKey("panolight:units", doc.get("units", ""))
    root.GetPrim().SetCustomDataByKey("panolight:frame", doc.get("frame", ""))
    exposure = light_exposure(doc)
    physical = doc.get("physical") or {}
    if physical.get("absolute"):  # the absolute scale (docs/units.md): what the stage emits, and what gave it
        root.GetPrim().SetCustomDataByKey("panolight:physicalScale", {
            "applied": bool(physical.get("applied")), "whiteCdM2": float(physical["white_cd_m2"]),
            "ev100": float(physical.get("ev100") or 0.0), "from": str(physical.get("from", "")),
            "lumensPerWatt": 683.0, "emits": "nits (cd/m^2); DistantLight: lux", "lightExposure": exposure,
            "renderExposureEV": -math.log2(units.document_gain(doc)) - exposure})
    stage.SetMetadata("comment", "PanoLight lighting estimate (lighting.json beside it holds the full record)")
    rigs = root.GetPrim().GetVariantSets().AddVariantSet("lighting")
    for name in VARIANTS if hdri else VARIANTS[:1]:
        rigs.AddVariant(name)
        rigs.SetVariantSelection(name)
        with rigs.GetVariantEditContext():
            dome = UsdLux.DomeLight.Define(stage, "/PanoLight/Environment")
            dome.CreateTextureFileAttr(Sdf.AssetPath(f"./{'radiance.exr' if name == 'lights' else hdri}"))
            dome.CreateTextureFormatAttr(UsdLux.Tokens.latlong)
            dome.CreateIntensityAttr(1.0)
            dome.CreateExposureAttr(exposure)
            UsdGeom.Xformable(dome).AddTransformOp().Set(_transform(Gf, DOME_TO_WORLD))
            if name == "lights":
                for i, light in enumerate(doc.get("lights", [])):
                    _distant_light(stage, Gf, UsdGeom, UsdLux, f"/PanoLight/Light_{i}", light, exposure)
    rigs.SetVariantSelection("lights")
    with atomic_path(p, p.suffix) as tmp:
        stage.GetRootLayer().Export(str(tmp))
    return p


def _distant_light(stage, Gf, UsdGeom, UsdLux, prim_path: str, light: dict, exposure: float = 0.0) -> None:
    color = np.asarray(light["color"], dtype=np.float64)
    peak = float(color.max())
    sun = UsdLux.DistantLight.Define(stage, prim_path)
    sun.CreateNormalizeAttr(True)  # a normalised distant light's intensity is the illuminance it gives
    sun.CreateIntensityAttr(float(light["intensity"]) * peak)
    sun.CreateExposureAttr(exposure)
    sun.CreateColorAttr(Gf.Vec3f(*(float(c / peak) if peak > 0 else 1.0 for c in color)))
    sun.CreateAngleAttr(math.degrees(float(light.get("angle", 0.0))))
    UsdGeom.Xformable(sun).AddTransformOp().Set(_transform(Gf, light_frame(light["direction"])))
    prim = sun.GetPrim()
    prim.SetCustomDataByKey("panolight:type", light.get("type", "sun"))
    if light.get("source"):  # a key light: how it was found and how sure it is (lighting.json's fields)
        prim.SetCustomDataByKey("panolight:source", str(light["source"]))
        if light.get("energy_68"):  # the source's 68 % energy range, in this light's intensity units
            prim.SetCustomDataByKey("panolight:intensity68", Gf.Vec2d(*(float(v) * peak for v in light["energy_68"])))
        if "direction_68_deg" in light:
            prim.SetCustomDataByKey("panolight:direction68Deg", float(light["direction_68_deg"]))


def read_usd(path, variant: str = "lights") -> dict:
    """A PanoLight stage back as {"up_axis", "meters_per_unit", "dome": {"texture", "rotation" (3, 3):
    world = R @ local, "exposure"}, "lights": [{"direction", "angle" (radians), "color" (RGB irradiance per unit
    intensity), "intensity", "exposure" (it gives intensity x 2^exposure)}]} for the chosen variant (tests and
    tools that check what was written)."""
    Gf, Sdf, Usd, UsdGeom, UsdLux = _pxr()
    stage = Usd.Stage.Open(str(path))
    if stage is None:
        raise PanoLightError(f"{path}: not a USD stage")
    root = stage.GetDefaultPrim()
    root.GetVariantSets().GetVariantSet("lighting").SetVariantSelection(variant)
    out = {"up_axis": UsdGeom.GetStageUpAxis(stage), "meters_per_unit": UsdGeom.GetStageMetersPerUnit(stage),
           "dome": None, "lights": []}
    cache = UsdGeom.XformCache()
    for prim in stage.Traverse():
        rot = np.array(cache.GetLocalToWorldTransform(prim).ExtractRotationMatrix(), dtype=np.float64).T
        if prim.IsA(UsdLux.DomeLight):
            tex = UsdLux.DomeLight(prim).GetTextureFileAttr().Get()
            out["dome"] = {"texture": tex.path, "rotation": rot,
                           "exposure": float(UsdLux.DomeLight(prim).GetExposureAttr().Get())}
        elif prim.IsA(UsdLux.DistantLight):
            lux = UsdLux.DistantLight(prim)
            out["lights"].append({"direction": rot[:, 2], "angle": math.radians(lux.GetAngleAttr().Get()),
                                  "color": np.array(lux.GetColorAttr().Get(), dtype=np.float64),
                                  "intensity": float(lux.GetIntensityAttr().Get()),
                                  "exposure": float(lux.GetExposureAttr().Get())})
    return out
