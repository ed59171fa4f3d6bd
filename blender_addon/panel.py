"""The PanoLight panel (World properties, and a PanoLight tab in the 3D viewport sidebar) and its settings.

Every setting lives in the scene's PanoLightSettings and is shown on the panel; the operators read them
from there. Menus are built from the core's tables (estimators, models, deringing windows), so they
offer exactly what ``panolight estimate`` does.
"""

import bpy
from bpy.props import BoolProperty, EnumProperty, FloatProperty, IntProperty

from . import store
from .core import estimators, order, pipeline_settings

_settings = pipeline_settings
ESTIMATORS = [("auto", "Auto", f"The best estimator measured ({estimators.AUTO})")] + \
    [(name, label, text) for name, (label, text) in estimators.DESCRIPTIONS.items()]
MODELS = [(name, label, text) for name, (label, text) in _settings.MODELS.items()]
ORDERS = [("auto", "Auto", "The smallest SH order the scene needs")] + \
    [(str(i), str(i), f"SH order {i}: {(i + 1) ** 2} coefficients")
     for i in range(order.DEFAULT_MAX_ORDER + 1)]
WINDOWS = [(name, label, text) for name, (label, text) in _settings.WINDOWS.items()]
_EV = _settings.MAX_EXPOSURE_EV


class PanoLightSettings(bpy.types.PropertyGroup):
    # estimation (pipeline.Settings)
    estimator: EnumProperty(name="Estimator", items=ESTIMATORS, default="auto")
    model: EnumProperty(name="Model", items=MODELS, default="auto")
    lmax: EnumProperty(name="SH order", items=ORDERS, default="auto")
    tolerance: FloatProperty(name="Tolerance", default=order.DEFAULT_TOLERANCE, min=0.0, max=1.0,
                             precision=3, description="Auto order: allowed diffuse relighting error, relative to "
                                                      "order 8")
    window: EnumProperty(name="Deringing", items=WINDOWS, default="none")
    window_width: FloatProperty(name="Window width", default=0.0, min=0.0, soft_max=40.0,
                                description="Width of a fixed window (0: 2 (order + 1))")
    exposure: FloatProperty(name="Exposure (EV)", default=0.0, min=-_EV, max=_EV, soft_min=-10.0, soft_max=10.0,
                            description="Scale the estimated lighting by 2^EV")
    sun_pointed: BoolProperty(name="Sun is here", default=False,
                              description="Put the sun where you say (azimuth, elevation), in place of any sun the "
                                          "estimate found: for a sun the photo hides or shows only by its shadows "
                                          "(panolight estimate --sun)")
    sun_azimuth: FloatProperty(name="Sun azimuth", subtype="ANGLE", default=0.0,
                               description="0 at the panorama's centre, positive to the right in the image")
    sun_elevation: FloatProperty(name="Sun elevation", subtype="ANGLE", default=0.7854, min=-1.5708, max=1.5708,
                                 description="Above the horizon")
    sun_contrast: FloatProperty(name="Lit / shadow", default=0.0, min=0.0, max=_settings.SUN_CONTRAST_RANGE[1],
                                description="0: weigh the sun by the clear sky. Else the photo's lit / shadowed ground "
                                            "contrast (e.g. 3): a white surface facing the sun is that many times as "
                                            "bright lit as in its shadow (--sun-contrast)")
    sun_metadata: BoolProperty(name="Sun from the photo's metadata", default=True,
                               description="A 360 photo that records its GPS position, UTC time and heading "
                                           "(Theta, Insta360, Photo Sphere) gets its sun's direction from them where "
                                           "the photo does not place a sun itself (hidden, veiled, a wide clipped "
                                           "patch). 'Sun is here' overrides it")
    sky_sun: BoolProperty(name="Sun from the sky alone", default=False,
                          description="Put back a sun the photo does not show wherever its sky's gradient alone "
                                      "places one (a sun retouched out of a clear sky). Off: such a sun is only "
                                      "reported, with where the sky puts it, since a hazy sky suggests suns that are "
                                      "not there; Sun is here places it (panolight estimate --sky-sun)")
    restore_clipped: BoolProperty(name="Restore a clipped sun", default=True,
                                  description="An HDR file that clips its own sun or lamp (a plateau at its "
                                              "ceiling, as most HDRIs shot without an ND filter do) gets the "
                                              "plateau's energy weighed as a photo's clipped sun is; every other "
                                              "pixel is kept (--restore auto). Off: the file as it is")
    # the world built from the estimate
    # hard maxima: an "inf" typed in is clamped to them, not to float32's largest value (a lamp of inf energy)
    background_strength: FloatProperty(name="Background strength", default=1.0, min=0.0, soft_max=10.0,
                                       max=_settings.MAX_SUN_STRENGTH)
    lighting_strength: FloatProperty(name="Lighting strength", default=1.0, min=0.0, soft_max=10.0,
                                     max=_settings.MAX_SUN_STRENGTH)
    sun_strength: FloatProperty(
        name="Sun lamp strength", default=1.0, min=0.0, soft_max=10.0, max=_settings.MAX_SUN_STRENGTH,
        description="Scales the key lights, the suns and lamps the estimate weighed (panolight estimate "
                    "--sun-strength: the same lamps, the same HDRI); other lights and the SH lighting keep theirs. "
                    "Build environment estimates again at a new strength. The estimate gives a sun the strength it "
                    "is sure of: if the photo's shadows are harder than the render's, raise it within the range the "
                    "panel shows")
    background_rotation: FloatProperty(name="Background rotation", subtype="ANGLE", default=0.0)
    lighting_rotation: FloatProperty(name="Lighting rotation", subtype="ANGLE", default=0.0,
                                     description="Turns the SH lighting and the sun lamps together")
    glossy_panorama: BoolProperty(name="Panorama in reflections", default=False,
                                  description="Glossy rays see the panorama instead of the smooth SH lighting")
    create_lights: BoolProperty(name="Sun lamps for explicit lights", default=True)
    physical_units: BoolProperty(
        name="Physical units", default=True,
        description="Where the estimate knows its absolute scale (the photo's EXIF, or the panel's EV100 or light "
                    "meter): the world's strengths in W/m^2/sr and the sun lamps' in W/m^2 (683 lm/W), and the film's "
                    "exposure set so the plate's white renders white. Off, or where nothing gives the scale: the "
                    "relative setup (1 = the camera's white), the exposure untouched")
    ev100_given: BoolProperty(
        name="Exposure (EV100)", default=False,
        description="The photo's exposure as EV100 = log2(N^2/t) - log2(ISO/100), for a photo whose EXIF lost it "
                    "(f/8, 1/250 s, ISO 100: 13.97); it wins over the EXIF")
    ev100: FloatProperty(name="EV100", default=10.0, min=-20.0, max=40.0,
                         description="The photo's EV100 (f/8, 1/250 s, ISO 100: 13.97)")
    meter_lux: FloatProperty(
        name="Light meter (lux)", default=0.0, min=0.0, max=1e7,
        description="A light meter's reading at the camera on an upward surface: the whole estimate is scaled so its "
                    "upward illuminance is this (wins over the EXIF and EV100); 0: no reading")
    radiance_height: IntProperty(name="SH map height", default=256, min=64, max=1024)
    lighting_source: EnumProperty(
        name="Light with", default="SH",
        items=[("SH", "SH lighting + sun lamps", "A smooth SH radiance map plus sun lamps for compact sources"),
               ("HDRI", "Reconstructed HDRI", "Lighting and reflections from the full-resolution HDR panorama, "
                "its clipped sun and lamps filled with their estimated energy")])

    def estimate_settings(self):
        """The core's pipeline.Settings of these properties (PanoLightError if invalid)."""
        lmax = None if self.lmax == "auto" and self.model == "auto" else self.lmax
        import math

        sun = None
        if self.sun_pointed:
            sun = _settings.direction_from_az_el(math.degrees(self.sun_azimuth), math.degrees(self.sun_elevation))
        return _settings.Settings(estimator=self.estimator, model=self.model, lmax=lmax, tolerance=self.tolerance,
                                  window=self.window, window_width=self.window_width or None,
                                  exposure_ev=self.exposure, sun_direction=sun,
                                  sun_contrast=(self.sun_contrast or None) if self.sun_pointed else None,
                                  sun_metadata=self.sun_metadata, sun_strength=self.sun_strength,
                                  restore="auto" if self.restore_clipped else "none", sky_sun=self.sky_sun,
                                  ev100=self.ev100 if self.ev100_given else None, lux=self.meter_lux or None,
                                  absolute=False)  # relative values: the build converts to Blender's W/m^2/sr
        # itself (Physical units), so the relative setup stays what it was


def draw_panel(layout, context):
    s = context.scene.panolight
    world = context.scene.world
    col = layout.column(align=True)
    col.operator("panolight.load_panorama", icon="IMAGE_DATA")
    panorama = world.get(store.PANORAMA_KEY) if world is not None else None
    if isinstance(panorama, bpy.types.Image):
        col.label(text=f"Panorama: {panorama.name}")
    box = layout.box()
    for prop in ("estimator", "model", "lmax", "tolerance", "window"):
        box.prop(s, prop)
    if s.window not in ("none", "auto"):
        box.prop(s, "window_width")
    box.prop(s, "exposure")
    row = box.row(align=True)
    row.prop(s, "sun_pointed")
    row.operator("panolight.pick_sun", icon="EYEDROPPER")
    if s.sun_pointed:
        for prop in ("sun_azimuth", "sun_elevation", "sun_contrast"):
            box.prop(s, prop)
    else:
        box.prop(s, "sun_metadata")
        box.prop(s, "sky_sun")
    box.prop(s, "restore_clipped")
    row = box.row(align=True)  # the absolute scale where the EXIF does not give it (docs/units.md)
    row.prop(s, "ev100_given")
    if s.ev100_given:
        row.prop(s, "ev100", text="")
    box.prop(s, "meter_lux")
    box.operator("panolight.estimate_lighting", icon="LIGHT_SUN")
    box.label(text="Estimated" if store.has_lighting(world) else "Not estimated yet")
    said = store.units_line(world)
    if said is not None:  # which units the estimate holds, and what one unit is (the photo's EXIF: cd/m^2, lux)
        box.label(text=f"Units: {said}", icon="LIGHT_DATA")
    box = layout.box()
    for prop in ("lighting_source", "background_strength", "lighting_strength", "background_rotation",
                 "lighting_rotation", "glossy_panorama", "create_lights", "radiance_height", "physical_units"):
        box.prop(s, prop)
    if s.lighting_source == "HDRI" or s.create_lights:
        box.prop(s, "sun_strength")
        key = store.key_light_range(world)
        if key is not None:
            box.label(text=f"Key light: 68 % range {key['low']:.2g}-{key['high']:.2g} x its estimate", icon="INFO")
    box.operator("panolight.build_environment", icon="WORLD")
    layout.operator("panolight.export_lighting", icon="EXPORT")


def _panel(space: str, region: str, **extra):
    """A Panel class drawing the PanoLight panel in one editor (the same panel in several places)."""
    attrs = {"bl_label": "PanoLight", "bl_space_type": space, "bl_region_type": region, **extra,
             "draw": lambda self, context: draw_panel(self.layout, context)}
    return type(f"{'WORLD' if space == 'PROPERTIES' else 'VIEW3D'}_PT_panolight", (bpy.types.Panel,), attrs)


WORLD_PT_panolight = _panel("PROPERTIES", "WINDOW", bl_context="world")
VIEW3D_PT_panolight = _panel("VIEW_3D", "UI", bl_category="PanoLight")

CLASSES = (PanoLightSettings, WORLD_PT_panolight, VIEW3D_PT_panolight)
