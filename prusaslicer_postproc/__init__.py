"""PrusaSlicer post-processing entry point ``loadpath-prusaslicer`` (see issue 7)."""
