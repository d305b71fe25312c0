"""Physical constants in SI units, shared by the readers, the filters and the simulator (no imports: the bottom
of the package)."""

GRAVITY = 9.80665
"""Standard gravity, m/s^2 (CGPM 1901)."""
