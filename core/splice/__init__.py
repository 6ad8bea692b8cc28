"""Write new infill into a slicer's G-code and check the result: the pipeline's last two stages.

The reader (:mod:`loadpath.gcode`) turns a file into a :class:`~loadpath.gcode.Program`; this
package writes one back.  :func:`splice` is :mod:`.splicer`'s, whose docstring shows its use and
says what is kept, rewritten and noted in the footer; :mod:`.plan`, :mod:`.beadruns`, :mod:`.flow`,
:mod:`.rewrite`, :mod:`.travel` and :mod:`.emit` make a replaced block's lines, in that order;
:func:`check_output` (:mod:`.verify`) re-reads the written bytes against the original.  Nothing in
:mod:`loadpath.gcode` imports this package; a failed check raises :class:`SpliceError`.
"""

from __future__ import annotations

from loadpath.errors import SpliceError
from loadpath.splice import splicer
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
    *splicer.__all__,
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
