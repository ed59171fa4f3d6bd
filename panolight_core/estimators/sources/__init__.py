"""Per-source energy: how much light each clipped region of an LDR panorama really holds.

An 8-bit panorama keeps nothing above its clip level, so the energy of a sun or a lamp has to be
predicted from what the picture does show. One module per job:

- ``regions``: the clipped regions of the work maps (``highlights.work_maps``, 128 rows): connected sets of cells holding pixels
  at 254/255 in all three channels, seam- and pole-aware; how each region's excess spreads over its cells.
- ``features``: what the LDR shows of each region (FEATURES, by name): its size, its glare, the scene.
- ``trees``: the learned model (``models/sources.safetensors``: gradient-boosted trees as arrays, trained
  on real HDR panoramas by ``training/source_energy/fit.py``): features -> log of the region's energy ratio
  r = true energy / energy its cells hold, as a mean mu and a spread sigma.
- ``decision``: which ratio to report, the one of least expected error under the metric itself.
- ``fill``: the excess put back into the work map and the full-resolution pixels.
- ``recovery``: all of it in one call, ``recover`` (``assemble``: from a prediction of any origin; ``recover_hdr``:
  an HDR file's clipped plateau, ``restore``).
- ``restore``: an HDR file that clips its own source (``camera.ceiling``), read in clip units, and the restored
  panorama, only its plateau's pixels changed.

Work maps: radiance (h, 2h, 3) linear in clip units (1 = white), Blender world frame (CONVENTIONS.md).
"""
from ..highlights import WORK_HEIGHT, work_maps
from .decision import (
                       DECISION_CORRELATION,
                       DECISION_SAMPLES,
                       DECISION_TOLERANCE,
                       MIN_MEDIAN_RATIO,
                       SHRINK_CANDIDATES,
                       _weighted_errors,
                       choose_shrink,
)
from .features import FEATURES, RING_EDGES_DEG, region_features
from .fill import FullResolutionFill, cap_log_ratios, fill_full_resolution, fill_regions
from .recovery import Recovery, assemble, decide, recover, recover_hdr
from .regions import MAX_REGIONS, SHAPE_MAX_EXTENT_DEG, WIDE_CONCENTRATION, Regions
from .trees import (
                    HDR_MODEL_PATH,
                    MODEL_PATH,
                    TRAINED_MIN_WIDTH,
                    SourceModel,
                    TreeEnsemble,
                    ensemble_arrays,
                    load_source_model,
)

__all__ = [
    "DECISION_CORRELATION", "DECISION_SAMPLES", "DECISION_TOLERANCE", "FEATURES", "MAX_REGIONS", "MIN_MEDIAN_RATIO",
    "HDR_MODEL_PATH", "MODEL_PATH", "RING_EDGES_DEG", "SHAPE_MAX_EXTENT_DEG", "SHRINK_CANDIDATES", "TRAINED_MIN_WIDTH",
    "WIDE_CONCENTRATION", "WORK_HEIGHT",
    "FullResolutionFill", "Recovery", "Regions", "SourceModel", "TreeEnsemble", "_weighted_errors", "assemble",
    "decide",
    "cap_log_ratios", "choose_shrink", "ensemble_arrays", "fill_full_resolution", "fill_regions", "load_source_model",
    "recover", "recover_hdr",
    "region_features", "work_maps",
]
