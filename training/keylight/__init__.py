"""The key light: its cross-validation (cv), the energy rules compared (rules) and the clear-sky table (sky_table)."""
