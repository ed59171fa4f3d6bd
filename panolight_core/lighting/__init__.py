"""The lighting model: explicit lights for compact sources, SH order selection, the adaptive fit, relighting."""
