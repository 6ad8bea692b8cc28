"""Write new infill into a slicer's G-code and check the result: the pipeline's last two stages.

>>> from loadpath import gcode, splice
>>> program = gcode.read("examples/ohs.gcode")                                   # doctest: +SKIP
>>> result = splice.splice(program, [splice.BlockFill(block=17, paths=paths, region=region)], options)  # doctest: +SKIP
>>> splice.check_output(program, result.data, result).problems                   # doctest: +SKIP
[]

The reader (:mod:`loadpath.gcode`) turns a file into a :class:`~loadpath.gcode.Program`; this
package writes one back.  Modules, in the order a replaced block goes through them:

- :mod:`.splicer` -- :func:`splice`: which blocks are replaced, the footer's time and filament,
  :class:`SpliceOptions` (the machine and the slicer's habits), :class:`SpliceResult`;
- :mod:`.plan` -- :func:`plan_block`: paths ordered, simplified and linked into chains of moves
  with width, filament and feedrate (:class:`PlanOptions`);
- :mod:`.beadruns` -- chains cut into runs of one width (:class:`RunOptions`);
- :mod:`.flow` -- :class:`FlowModel`: filament per mm of a bead of given width and height;
- :mod:`.rewrite` -- a block's lines rewritten from its plan, entering travel to leaving wipe;
- :mod:`.travel` -- travel, retraction, wipe (:class:`Motion`, :class:`Retraction`);
- :mod:`.emit` -- number formats and line writing in the slicer's style;
- :mod:`.verify` / :mod:`.lineview` -- :func:`check_output`: the written bytes re-read and checked
  against the original (every line outside the replaced ranges unchanged, volumes, layer features).

Nothing in :mod:`loadpath.gcode` imports this package.  A failed check raises
:class:`SpliceError` (from :mod:`loadpath.errors`, exported here too).
"""

from __future__ import annotations

from loadpath.errors import SpliceError
from loadpath.splice.beadruns import RunOptions
from loadpath.splice.flow import FlowModel
from loadpath.splice.plan import PlanOptions
from loadpath.splice.splicer import (
    BlockFill,
    BlockReport,
    SpliceOptions,
    SpliceResult,
    block_feedrate,
    block_height,
    kinematic_time,
    splice,
)
from loadpath.splice.travel import Motion, Retraction
from loadpath.splice.verify import SpliceCheck, check_output, check_splice, layer_features

__all__ = [
    "SpliceOptions",
    "BlockFill",
    "BlockReport",
    "SpliceResult",
    "splice",
    "block_feedrate",
    "block_height",
    "kinematic_time",
    "Motion",
    "Retraction",
    "PlanOptions",
    "RunOptions",
    "FlowModel",
    "SpliceCheck",
    "check_splice",
    "check_output",
    "layer_features",
    "SpliceError",
]
