"""Load cases (interface.md TOML) used by tests in several folders and by the benchmarks.

Tests import this module by name (``tests/`` is on the path, as for ``slicing``); the benchmarks put
``tests/`` on ``sys.path`` first.
"""

from __future__ import annotations

__all__ = ["GRIP_PULL", "END_PULL"]

GRIP_PULL = """version = 1
[[supports]]
name = "clamp"
where = { side = "x_min", within = 10.0 }
fix = ["x", "y", "z"]
[[loads]]
name = "pull"
where = { side = "x_max", within = 10.0 }
force = [1000.0, 0.0, 0.0]
"""
"""Clamped within 10 mm of x_min, 1000 N pulled within 10 mm of x_max (a grip at each end)."""

END_PULL = """
version = 1
[[supports]]
name = "clamp"
where = { side = "x_min", within = 10.0 }
fix = ["x", "y", "z"]
[[loads]]
name = "pull"
where = { side = "x_max", within = 0.5 }
force = [1000.0, 0.0, 0.0]
"""
"""The swarm paper's specimen: clamped within 10 mm of x_min, 1000 N through the end face at x_max
(a pull spread over 10 mm of the long sides as well shears the grip zone and turns the max-|sigma|
direction across the specimen there)."""
