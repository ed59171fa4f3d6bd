"""Image and lighting-file I/O (pure Python + numpy; OpenEXR / Pillow / pypng imported lazily)."""
from .images import HDR_FORMATS, LDR_FORMATS, is_hdr, read_image, sniff_format, write_image

__all__ = ["read_image", "write_image", "sniff_format", "is_hdr", "HDR_FORMATS", "LDR_FORMATS"]
