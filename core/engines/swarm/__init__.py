"""Swarm engine: stress-aligned paths as the traces of a swarm of agents (Guidetti et al. 2024).

``generate(inp: EngineInput, K=5.0, **options) -> Toolpaths``; see :mod:`.engine`.
"""

from loadpath.engines.swarm.engine import SwarmParams, generate

__all__ = ["generate", "SwarmParams"]
