"""The finishing stages both path engines share, and the compiled kernels they run on.

An engine lays its paths; these stages make them print well, the same way for every engine:

- :mod:`.ends` -- :func:`~.ends.extend_ends`: each path end run on to the region's edge or the
  nearest other path, so the ends leave no unfilled strips;
- :mod:`.widths` -- :func:`~.widths.local_pitch` / :func:`~.widths.centre_points`: each point's
  bead width from the distance to its neighbours, so the beads fill the region without overlap;
- :mod:`.boundary` -- :class:`~.boundary.Domain`: the region's boundary as segment and
  point-in-polygon grids for the kernels' queries;
- :mod:`.kernel_geom`, :mod:`.kernel_widths`, :mod:`.kernel_ends` -- their compiled (numba) loops;
- :mod:`._numba` -- the one place an engine imports numba (``njit`` and the on-disk cache stamps).

Nothing here imports an engine (``loadpath.engines.swarm``, ``loadpath.engines.streamlines``); the
engines and the pipeline's staggered copy (:func:`loadpath.pipeline.paths.stagger`) import it.
"""
