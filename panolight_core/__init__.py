"""PanoLight core: SH maths, image I/O and lighting files. numpy-only at import (no bpy, no torch)."""
__version__ = "0.1.0"
