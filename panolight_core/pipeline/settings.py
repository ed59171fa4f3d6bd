"""Estimation settings: one validated record for the CLI, ``batch`` and the Blender add-on.

The option names, ranges, choices and help texts live here once; ``add_arguments`` puts them on any
argparse parser (``panolight estimate`` and Blender's headless batch.py), and the add-on builds its
menus from the same tables.
"""
from __future__ import annotations

import argparse
import math
import re
from dataclasses import dataclass

from ..errors import PanoLightError
from ..lighting.order import DEFAULT_MAX_ORDER, DEFAULT_TOLERANCE
from ..sh.window import FAMILIES

MODELS = {  # name -> (label, one line)
    "auto": ("Lights + SH", "explicit lights for compact bright sources (sun, lamps, windows) plus the SH order "
                            "the rest needs, deringed only if ringing would show"),
    "sh": ("SH only", "SH only, at --lmax (default 2)"),
}
_FAMILY_LABELS = {"sinc4": "sinc^4", "lanczos": "Lanczos", "hanning": "Hanning"}
WINDOWS = {  # deringing: name -> (label, one line); the fixed families are sh.window's
    "none": ("Model's choice", "leave deringing to --model (lights + SH dering only where ringing would show)"),
    "auto": ("Auto sinc^4", "the weakest sinc^4 window that leaves the radiance non-negative"),
    **{f: (_FAMILY_LABELS.get(f, f), f"a fixed {_FAMILY_LABELS.get(f, f)} window of --window-width")
       for f in FAMILIES},
}
RESTORES = {  # an HDR file that clips its own source: name -> (label, one line)
    "auto": ("Restore", "an HDR file that clips its own sun or lamp (a plateau at its ceiling) gets the plateau's "
                        "energy weighed as a photo's clipped sun is; every other pixel is kept as it is"),
    "none": ("As it is", "take an HDR file as it is, clipped or not (its exact projection)"),
}
MAX_LMAX = 100  # a fixed order beyond the adaptive range; render-mitsuba caps what it renders lower
MAX_EXPOSURE_EV = 60.0  # 2^60 keeps any clip-level radiance finite in float32 outputs
MAX_SUN_STRENGTH = 1000.0
RANGES = {"tolerance": (0.0, 1.0), "window_width": (1e-6, 1e6), "exposure_ev": (-MAX_EXPOSURE_EV, MAX_EXPOSURE_EV),
          "sun_strength": (0.0, MAX_SUN_STRENGTH)}


@dataclass(frozen=True)
class Settings:
    """What to estimate. lmax: None (auto with model "auto", 2 with "sh"), "auto", or an order 0..100
    (int or digits). tolerance: allowed diffuse relighting error of the auto order, relative to order 8.
    window: deringing (WINDOWS); window_width: of a fixed window (default 2 (lmax + 1)). exposure_ev:
    the lighting is scaled by 2^exposure_ev. sun_strength: the key lights (the suns and lamps the estimate
    weighed) times this, in every output alike; a raised light takes over its own region's fill first, nothing
    else changes. sun_direction: the artist's sun (x, y, z; CONVENTIONS.md frame, made unit), in place of any sun
    the estimate found; sun_contrast: weigh it by the photo's lit / shadow ground contrast (> 1) instead of its sky
    (``keylight.with_pointed_sun``). sun_metadata: where no direction is given, a photo whose metadata holds its
    GPS position, UTC time and heading gets the sun's direction from them (``estimate.capture_sun``) where the photo
    does not place a sun itself. restore: RESTORES (an HDR file that clips its own source). sky_sun: a sun the photo
    does not show and only its sky's gradient suggests is put back there (``estimators.with_sky_sun``; by default
    the run's note says where, as a hazy sky suggests suns that are not there). ev100, lux: the absolute scale where
    the EXIF does not give it (``camera.units``: EV100, or a light meter's upward illuminance, which wins); absolute:
    the outputs in cd/m^2 and lux instead of relative units where a scale is known (False: ``--relative``). Invalid values raise
    PanoLightError naming the setting."""

    estimator: str = "auto"
    model: str = "auto"
    lmax: str | int | None = None
    tolerance: float = DEFAULT_TOLERANCE
    window: str = "none"
    window_width: float | None = None
    exposure_ev: float = 0.0
    sun_strength: float = 1.0
    sun_direction: tuple | None = None  # the artist's sun: a direction (CONVENTIONS.md frame); made unit here
    sun_contrast: float | None = None  # ... weighed by the photo's lit/shadow ground contrast instead of its sky
    sun_metadata: bool = True  # the sun from the photo's GPS position, UTC time and heading, where it hides it
    restore: str = "auto"  # RESTORES
    sky_sun: bool = False  # a sun only the sky's gradient suggests is put back (the bolder rule; default: noted)
    ev100: float | None = None  # the exposure's EV100 where the file's EXIF lost it (camera/units.py)
    lux: float | None = None  # a light meter's upward illuminance at the camera, lux: the whole model scaled to it
    absolute: bool = True  # the outputs in cd/m^2 and lux where the scale is known (else relative, and said)

    def __post_init__(self):
        from ..estimators import resolve

        resolve(self.estimator)  # unknown or unavailable names fail here, before any reading
        check_choice("model", self.model, MODELS)
        check_choice("window", self.window, WINDOWS)
        check_choice("restore", self.restore, RESTORES)
        if self.lmax is not None:
            object.__setattr__(self, "lmax", parse_lmax(str(self.lmax), "lmax"))
        for name, (lo, hi) in RANGES.items():
            value = getattr(self, name)
            if value is not None and not (isinstance(value, (int, float)) and math.isfinite(value)
                                          and lo <= value <= hi):
                raise PanoLightError(f"{name} must be a number between {lo:g} and {hi:g}, got {value!r}")
        from ..camera.units import EV100_RANGE, MAX_LUX

        for name, (lo, hi), low_open in (("ev100", EV100_RANGE, False), ("lux", (0.0, MAX_LUX), True)):
            value = getattr(self, name)
            if value is not None and not (isinstance(value, (int, float)) and math.isfinite(value)
                                          and (lo < value if low_open else lo <= value) and value <= hi):
                raise PanoLightError(f"{name} must be a number {'above' if low_open else 'from'} {lo:g} up to {hi:g}, "
                                     f"got {value!r}")
        if self.sun_direction is not None:
            object.__setattr__(self, "sun_direction", unit_direction(self.sun_direction))
        if self.sun_contrast is not None:
            if self.sun_direction is None:
                raise PanoLightError("sun_contrast weighs the sun the artist points at: give sun_direction too "
                                     "(--sun AZ,EL or --sun-direction X,Y,Z)")
            lo, hi = SUN_CONTRAST_RANGE
            if not (isinstance(self.sun_contrast, (int, float)) and math.isfinite(self.sun_contrast)
                    and lo < self.sun_contrast <= hi):
                raise PanoLightError(f"sun_contrast must be a number above {lo:g} and at most {hi:g} (lit / shadow), "
                                     f"got {self.sun_contrast!r}")

    @property
    def order(self) -> str:
        """The SH order to fit: "auto" or an integer as digits (lmax None resolved by the model)."""
        if self.lmax is None:
            return "auto" if self.model == "auto" else "2"
        return self.lmax


MAX_MAP_COST = 4_000_000  # (lmax + 1)^2 x map height: the SH maps' reconstruction stays within ~1.5 GB


def check_map_cost(order, height: int) -> None:
    """PanoLightError, before anything is read, when an SH order and an output map height together would
    cost more than MAX_MAP_COST (memory grows with both: --lmax 100 at 4096 x 2048 took 6.7 GB and 50 s).
    ``order``: Settings.order ("auto" stays within the adaptive range and always fits)."""
    if order == "auto" or order is None:
        return
    lmax = int(order)
    if (lmax + 1) ** 2 * height <= MAX_MAP_COST:
        return
    fit_height = max(h for h in (2 ** k for k in range(12)) if h * (lmax + 1) ** 2 <= MAX_MAP_COST or h == 1)
    fit_lmax = int(math.isqrt(MAX_MAP_COST // height)) - 1
    raise PanoLightError(f"SH order {lmax} with --resolution {2 * height}x{height} would take several GB of memory to "
                         f"reconstruct; lower --resolution to {2 * fit_height}x{fit_height} or below, or the order to "
                         f"{max(0, fit_lmax)} or below")


SUN_CONTRAST_RANGE = (1.0, 1000.0)  # lit / shadow of a white surface: above 1 (a shadow at all)


def unit_direction(value, option: str = "sun_direction") -> tuple:
    """(x, y, z) finite and not zero -> the unit direction (CONVENTIONS.md frame), else PanoLightError."""
    try:
        v = [float(x) for x in value]
    except (TypeError, ValueError):
        raise PanoLightError(f"{option} must be three numbers X,Y,Z, got {value!r}") from None
    n = math.hypot(*v) if len(v) == 3 and all(math.isfinite(x) for x in v) else 0.0  # hypot: 1e200 squares to inf
    if not n > 0:
        raise PanoLightError(f"{option} must be three finite numbers X,Y,Z, not all zero, got {value!r}")
    return tuple(x / n for x in v)


def direction_from_az_el(az_deg: float, el_deg: float) -> tuple:
    """The unit direction (CONVENTIONS.md frame) of azimuth ``az_deg`` (0 at the panorama's centre, +X; positive to
    the right in the image, clockwise seen from above, as a compass bearing turns) and elevation ``el_deg`` above
    the horizon."""
    a, e = math.radians(az_deg), math.radians(el_deg)
    return (math.cos(e) * math.cos(a), -math.cos(e) * math.sin(a), math.sin(e))


def _xyz(text: str) -> tuple:
    try:
        return unit_direction([float(v) for v in text.split(",")], "--sun-direction")
    except (ValueError, PanoLightError):
        raise PanoLightError(f"--sun-direction must be three finite numbers X,Y,Z, not all zero, got {text!r}") from None


def parse_sun(text: str) -> tuple:
    try:
        az, el = (float(v) for v in text.split(","))
    except ValueError:
        raise PanoLightError(f"--sun must be two numbers AZ,EL in degrees, got {text!r}") from None
    if not (math.isfinite(az) and math.isfinite(el) and -90.0 <= el <= 90.0):
        raise PanoLightError(f"--sun AZ,EL needs finite degrees with -90 <= EL <= 90, got {text!r}")
    return direction_from_az_el(az, el)


def check_choice(name: str, value, table: dict) -> None:
    """PanoLightError unless value is a key of table (MODELS, WINDOWS)."""
    if value not in table:
        raise PanoLightError(f"{name} must be one of {', '.join(table)}, got {value!r}")


def parse_lmax(text: str, option: str = "--lmax") -> str:
    """'auto' or an integer 0..MAX_LMAX as digits, else PanoLightError."""
    if text == "auto":
        return text
    try:
        value = int(text)
    except ValueError:
        raise PanoLightError(f"{option} must be an integer 0..{MAX_LMAX} or 'auto', got {text!r}") from None
    if not 0 <= value <= MAX_LMAX:
        raise PanoLightError(f"{option} must be in 0..{MAX_LMAX}, got {value}")
    return str(value)


def number(option: str, lo: float, hi: float, integer: bool = False):
    """An argparse type: a finite number in [lo, hi] (NaN, Inf and out-of-range values get one line)."""
    def parse(text: str):
        try:
            v = int(text) if integer else float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{option} must be {'an integer' if integer else 'a number'}, "
                                             f"got {text!r}") from None
        if not (math.isfinite(v) and lo <= v <= hi):
            raise argparse.ArgumentTypeError(f"{option} must be between {lo:g} and {hi:g}, got {text!r}")
        return v
    return parse


def argparse_type(check, *args):
    """An argparse type from a checker that raises PanoLightError (its message becomes argparse's)."""
    def parse(text: str):
        try:
            return check(text, *args)
        except PanoLightError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None
    return parse


def _window(text: str) -> str:
    check_choice("--window", text, WINDOWS)
    return text


def add_arguments(parser, default_estimator: str = "auto", sun_strength: bool = True) -> None:
    """Add --model --lmax --tolerance --estimator --exposure --window --window-width and, with ``sun_strength``,
    --sun-strength (``from_args`` reads them back; Blender's batch scales its sun lamps with its own)."""
    from ..estimators import AUTO, BUILTIN, DESCRIPTIONS

    parser.add_argument("--model", choices=tuple(MODELS), default="auto",
                        help="; ".join(f"{n}{' (default)' if n == 'auto' else ''}: {text}"
                                       for n, (_, text) in MODELS.items()))
    parser.add_argument("--lmax", type=argparse_type(parse_lmax), default=None,
                        help=f"SH order 0..{MAX_LMAX}, or 'auto': the smallest order 0..{DEFAULT_MAX_ORDER} within "
                             f"--tolerance (default: auto with --model auto, 2 with --model sh)")
    parser.add_argument("--tolerance", type=number("--tolerance", *RANGES["tolerance"]), default=DEFAULT_TOLERANCE,
                        help=f"with --lmax auto: allowed diffuse relighting error relative to order "
                             f"{DEFAULT_MAX_ORDER} (default {DEFAULT_TOLERANCE})")
    parser.add_argument("--estimator", default=default_estimator, choices=BUILTIN + ("auto",), metavar="NAME",
                        help="; ".join(f"{n}: {text[:1].lower()}{text[1:]}" for n, (_, text) in DESCRIPTIONS.items())
                        + f"; auto{' (default)' if default_estimator == 'auto' else ''}: {AUTO}, the best measured")
    parser.add_argument("--exposure", type=number("--exposure", *RANGES["exposure_ev"]), default=0.0, metavar="EV",
                        help="scale the estimated lighting by 2^EV (default 0)")
    if sun_strength:
        parser.add_argument("--sun-strength", type=number("--sun-strength", *RANGES["sun_strength"]), default=1.0,
                            metavar="X",
                            help="scale the key lights (the suns and lamps the estimate weighed in a clipped photo, "
                                 "and a sun put back from its sky) by X in lighting.json, lighting.usda and hdr.exr "
                                 "alike; a raised light takes over its own region's fill first, and nothing else "
                                 "changes (default 1: the strength the "
                                 "estimate is sure of). When a key light's own evidence says it is stronger, the "
                                 "estimate prints a note with its 68 %% range: raise X toward that if the photo's "
                                 "shadows are harder than a render's")
        where = parser.add_mutually_exclusive_group()
        where.add_argument("--sun", type=argparse_type(parse_sun), default=None, metavar="AZ,EL",
                           help="the sun is there (degrees: azimuth 0 at the panorama's centre, positive to the right "
                                "in the image; elevation above the horizon): for a sun the photo hides (trees, a "
                                "retouched sky) or shows only by its shadows. It replaces the sun the estimate found, "
                                "weighed by the clear sky's fit with the sun fixed there, or by --sun-contrast. On "
                                "an HDR file whose clipped sun lost its exact plateau (resized after its merge), the "
                                "bright patch within 10 degrees of it is restored there (--sun -40,5 for a "
                                "negative azimuth)")
        where.add_argument("--sun-direction", type=argparse_type(_xyz), default=None, metavar="X,Y,Z",
                           help="the same as --sun, as a direction in the world frame (Z up, the panorama's centre "
                                "+X; docs/CONVENTIONS.md)")
        parser.add_argument("--sun-contrast", type=number("--sun-contrast", SUN_CONTRAST_RANGE[0] + 1e-9,
                                                          SUN_CONTRAST_RANGE[1]), default=None, metavar="R",
                            help="with --sun: weigh the sun so that a white surface facing it is R times as bright "
                                 "lit as in its shadow (the photo's own sunlit / shadowed ground, e.g. 3.3), instead "
                                 "of by the sky; the energy is taken out of the fill, so the total stays honest")
        parser.add_argument("--no-sun-metadata", dest="sun_metadata", action="store_false",
                            help="ignore the photo's capture metadata. By default a 360 photo that records its GPS "
                                 "position, UTC time and heading (XMP GPano:PoseHeadingDegrees; Theta, Insta360 and "
                                 "Photo Sphere write it) gets its sun's direction from them wherever the photo does not "
                                 "place a sun itself (hidden, veiled, or inside a wide clipped patch); --sun overrides "
                                 "it, and lighting.json says which was used")
    parser.add_argument("--sky-sun", action="store_true",
                        help="put back a sun the photo does not show wherever its sky's gradient alone places one "
                             "(a sun retouched out of a clear sky). By default such a sun is not added, since a "
                             "hazy sky suggests suns that are not there: the run's note says where the sky puts "
                             "it and how sure that is, and --sun AZ,EL places it")
    units = parser.add_argument_group("physical units (docs/units.md)")
    written = units.add_mutually_exclusive_group()
    written.add_argument("--absolute", dest="absolute", action="store_true", default=True,
                         help="(default) where the scale is known, write radiance in cd/m^2 and each light's intensity "
                              "in lux (the illuminance on a surface facing it): from the photo's EXIF (exposure time, "
                              "f-number, ISO: white = 1.2 x 2^EV100 cd/m^2), --ev100 or --lux. Where nothing gives it "
                              "the files stay relative (1 = the camera's white) and the run says so")
    written.add_argument("--relative", dest="absolute", action="store_false",
                         help="keep the files relative (1 = the camera's white) even where the scale is known; "
                              "lighting.json's 'physical' still says the scale and each light in lux and W/m^2")
    units.add_argument("--ev100", type=number("--ev100", -20.0, 40.0), default=None, metavar="X",
                       help="the photo's exposure as EV100 = log2(N^2/t) - log2(ISO/100), for a file whose EXIF "
                            "lost it (f/8, 1/250 s, ISO 100: 13.97)")
    units.add_argument("--lux", type=number("--lux", 1e-9, 1e7), default=None, metavar="E",
                       help="a light meter's reading at the camera on an upward surface, in lux: the whole model "
                            "(lights and SH) is scaled so its upward illuminance is E (wins over EXIF and --ev100)")
    parser.add_argument("--restore", choices=tuple(RESTORES), default="auto",
                        help="; ".join(f"{n}{' (default)' if n == 'auto' else ''}: {text}"
                                       for n, (_, text) in RESTORES.items())
                        + "; lighting.json's estimator.restoration says what was found and done")
    parser.add_argument("--window", type=argparse_type(_window), default="none", metavar="KIND",
                        help="deringing: " + "; ".join(f"{n}{' (default)' if n == 'none' else ''}: {text}"
                                                       for n, (_, text) in WINDOWS.items()))
    parser.add_argument("--window-width", type=number("--window-width", *RANGES["window_width"]), default=None,
                        help="width of a fixed window (default 2 (lmax+1))")


def from_args(args) -> Settings:
    """The Settings of parsed ``add_arguments`` options."""
    return Settings(estimator=args.estimator, model=args.model, lmax=args.lmax, tolerance=args.tolerance,
                    window=args.window, window_width=args.window_width, exposure_ev=args.exposure,
                    sun_strength=getattr(args, "sun_strength", 1.0),
                    sun_direction=getattr(args, "sun", None) or getattr(args, "sun_direction", None),
                    sun_contrast=getattr(args, "sun_contrast", None), sun_metadata=getattr(args, "sun_metadata", True),
                    restore=getattr(args, "restore", "auto"), sky_sun=getattr(args, "sky_sun", False),
                    ev100=getattr(args, "ev100", None), lux=getattr(args, "lux", None),
                    absolute=getattr(args, "absolute", True))


_NEGATIVE_VALUE = re.compile(r"^-(\d|\.\d)[\d.,eE+-]*$")  # -2,0,2 / -40,5 / -1 / -.5 / -1e-3,0,1: never an option


def attach_negative_values(parser: argparse.ArgumentParser, argv: list[str]) -> list[str]:
    """``argv`` with each option that takes one value joined to a following value that starts with a minus sign
    (``--evs -2,0,2`` -> ``--evs=-2,0,2``), as people type them: argparse takes "-2,0,2" for an option of its
    own. The options are those of ``parser`` and its sub-commands; nothing else changes."""
    takes_value = set()
    parsers = [parser]
    while parsers:
        p = parsers.pop()
        for action in p._actions:
            if isinstance(action, argparse._SubParsersAction):
                parsers.extend(action.choices.values())
            elif action.option_strings and action.nargs is None:
                takes_value.update(action.option_strings)
    out, i = [], 0
    while i < len(argv):
        if argv[i] in takes_value and i + 1 < len(argv) and _NEGATIVE_VALUE.match(argv[i + 1]):
            out.append(f"{argv[i]}={argv[i + 1]}")
            i += 2
        else:
            out.append(argv[i])
            i += 1
    return out
