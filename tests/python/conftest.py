"""Fixtures shared by the Python tests: `rig`, the real simulator and emulated robot (rig.py)."""
from rig import rig  # noqa: F401  (a fixture, found by name)
