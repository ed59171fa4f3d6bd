"""Access to the bpy-free core: bundled inside the extension zip, or importable in a checkout."""
try:  # the extension zip carries panolight_core inside the add-on package
    from . import panolight_core as core  # noqa: F401
except ImportError:  # a development checkout or a pip install
    import panolight_core as core  # noqa: F401
