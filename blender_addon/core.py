"""Access to the bpy-free core: bundled inside the extension zip, or importable in a checkout.

Only numpy is needed at import time (image files are read by Blender itself, not by the core's I/O).
"""
try:  # the extension zip carries panolight_core inside the add-on package
    from . import panolight_core as core
    from .panolight_core import errors, estimators, hdri, lighting, pipeline, sh  # noqa: F401  (load the submodules)
    from .panolight_core.io import images  # noqa: F401  (core.io.images)
except ImportError:  # a development checkout or a pip install
    import panolight_core as core
    import panolight_core.errors  # noqa: F401
    import panolight_core.estimators  # noqa: F401
    import panolight_core.hdri  # noqa: F401
    import panolight_core.io.images  # noqa: F401
    import panolight_core.lighting  # noqa: F401
    import panolight_core.pipeline  # noqa: F401
    import panolight_core.sh  # noqa: F401
