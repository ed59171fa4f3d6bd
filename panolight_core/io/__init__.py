"""Image and lighting-file I/O (pure Python + numpy; OpenEXR / Pillow / pypng imported lazily)."""
from .images import HDR_FORMATS, LDR_FORMATS, is_hdr, read_image, sniff_format, write_image, write_srgb8

__all__ = ["read_image", "write_image", "write_srgb8", "sniff_format", "is_hdr", "HDR_FORMATS", "LDR_FORMATS"]
