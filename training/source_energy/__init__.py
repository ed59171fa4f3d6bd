"""The per-source energy model: its training (fit), cross-validation (cv) and report."""
