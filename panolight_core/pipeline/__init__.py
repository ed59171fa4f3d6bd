"""The pipeline: panorama pixels -> estimator -> lighting model (lights + SH) -> outputs.

settings.py   Settings: every option, validated once (CLI, batch and Blender share it)
estimate.py   estimate_lighting(pixels, settings) -> Result (the lighting document and model)
job.py        run_estimate(file, folder, settings): read, estimate, write the output set atomically
hdri.py       the full-resolution HDR panorama with its clipped sources filled (hdr.exr)
preview.py    the input | SH radiance | lit sphere preview
"""
from .estimate import Result, estimate_lighting, fit_estimate, fit_pixels, fit_radiance  # noqa: F401
from .job import OUTPUT_FILES, run_estimate  # noqa: F401
from .settings import Settings  # noqa: F401
