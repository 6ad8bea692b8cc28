"""One iteration of the swarm (paper Algorithm 1, lines 2-9), and the loop of iterations.

The stages run compiled (numba) in :mod:`.kernel_step`; this module holds the settings, the
swarm's state and the Python entry points (:func:`run`, :func:`step`).  The stages:

1. **Step** (Eq. 2): every agent moves ``h`` along the local principal direction, oriented by its
   momentum (``mu = sign(s . last displacement)``).  Where the field has no direction (validity
   mask false) it follows the mean heading of itself and its chain neighbours, so it neither stalls
   nor zig-zags.
2. **Blocked agents**: an agent whose ideal location leaves the domain (closer than the margin to
   the boundary: the far end, a hole, a concave corner, or beads laid by an earlier swarm) or
   enters a cell of another path is removed; its path ends.  If it was inside a chain, the chain
   splits there: the two new chain ends get *internal boundary agents* on that boundary
   (paper Fig. 3).
3. **Boundary agents** (Sec. III-B4): each chain end casts a ray along the radial direction; the
   first boundary point within ``ray_reach`` pitches is its boundary agent, which slides along the
   boundary tangent in the QP and is projected back onto the boundary.  A chain end with no
   boundary in reach is free; a new agent is spawned one pitch beyond it (if there is room), so
   the front widens where the region does.
4. **Kill / spawn** (Sec. III-B6): the chains are cut into windows of ``window`` agents.  In each
   window the pair with the smallest normalised radial gap (below ``kill_below``) proposes a
   kill of its more compressed agent and the pair with the largest gap (above ``spawn_above``)
   proposes a spawn in between.  The QP (Eq. 12) is solved for three swarms — X0, X-1 (every
   proposed kill) and X+1 (every proposed spawn) — as one banded system, and each window keeps
   the variant with the lowest potential per agent over its own pairs and agents (Eq. 13 applied
   window by window).  This allows one kill or spawn per window per step, i.e. several where the
   front is wide.  If windows chose differently the combined swarm is solved once more.
5. **Safety**: after the QP, agents that left the domain or came closer than ``min_gap`` pitches
   to their neighbour are removed, so paths never cross and never come closer than half a pitch.
6. **Merge**: two chains whose facing ends are within ``merge_reach`` pitches with no boundary
   between them are joined: their internal boundary agents met (Fig. 3) and are removed.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from loadpath._typing import Bools, Floats, Ints, Points2
from loadpath.engines.swarm import kernel_step as ks
from loadpath.engines.finish.boundary import Domain
from loadpath.engines.swarm.grid import Occupancy
from loadpath.engines.swarm.raster import FieldRaster

__all__ = ["SwarmParams", "SwarmState", "Context", "run", "step"]

_QP_TOL = 1e-10
"""KKT tolerance of the exact QP solver, in units of the step (as :mod:`.qp`)."""


@dataclass(frozen=True)
class SwarmParams:
    """Tuning of the swarm (defaults reproduce the paper's method; see the module docstring).

    Attributes
    ----------
    K : float
        Weight of the environment potential (Eq. 12: ``P = P_a + K P_e``).
    window : int
        Agents per kill/spawn window.
    kill_below, spawn_above : float
        Normalised radial gaps that propose a kill / a spawn (the paper's "too close" / "too far").
    min_gap : float
        Neighbours closer than this many pitches after the QP: the more compressed one is removed.
    margin : float
        Moving agents keep this many pitches inside the domain.
    ray_reach : float
        Boundary agents are searched this many pitches from a chain end.
    merge_reach : float
        Chains whose facing ends are closer than this many pitches are joined.
    grow_free_ends : bool
        Spawn a new agent beyond a chain end that has no boundary in reach (off by default: the
        fill swarms cover what a front does not reach, more evenly than a front growing sideways).
    field_cell : float
        Node spacing of the stress-field raster the steps sample (:mod:`.raster`), in pitches (one
        pitch gives the same beta and spacing on the specimen's FE field for a quarter of the
        raster's cost, but loses coverage at small holes: 94.9 against 95.5 % on the small bracket).
    edge_gap : float
        A path that runs into the layer's edge ends this many pitches from it (across the edge).
    qp_max_iter : int
        Iteration limit of the exact QP solver; a QP it does not finish goes to OSQP (0 sends
        every QP to OSQP: how the tests check the fallback inside the compiled step).
    max_turn : float
        A path ends where the followed stress turns more than this many degrees from the agent's
        heading within one step (0: never); the region beyond is left to fill swarms.  Where the
        principal stresses cross (a bent bar's neutral axis) the max-|sigma| direction jumps by
        about 90 degrees, and a path that follows it kinks into a V that bunches its neighbours.
        Stiffness benchmark bracket, share of the ceiling gain at equal mass: off 0.54; 45, 55,
        60, 65, 70, 75 degrees: 0.56, 0.65, 0.67, 0.58, 0.59, 0.51 (coverage 0.947 -> 0.954-0.959
        and beta 0.975 -> 0.978-0.982 at every angle); the specimen, whose field does not jump,
        is unchanged (0.79).
    """

    K: float = 5.0
    window: int = 16
    kill_below: float = 0.85
    spawn_above: float = 1.3
    min_gap: float = 0.5
    margin: float = 0.25
    ray_reach: float = 2.5
    merge_reach: float = 5.0
    grow_free_ends: bool = False
    field_cell: float = 0.5
    edge_gap: float = 0.25
    qp_max_iter: int = 100
    max_turn: float = 60.0


@dataclass
class SwarmState:
    """The moving agents of one swarm, in chain order.

    Attributes
    ----------
    pos : (n, 2) float, mm
        Current locations ``x(k)``.
    head : (n, 2) float
        Unit direction of the last displacement ``x(k) - x(k-1)`` (the momentum).
    pid : (n,) int
        Path id each agent draws.
    start : (n,) bool
        Whether each agent starts a chain (agents of a chain are contiguous).
    """

    pos: Points2
    head: Points2
    pid: Ints
    start: Bools

    @property
    def n(self) -> int:
        """Number of moving agents."""
        return int(len(self.pos))


@dataclass
class Context:
    """What a swarm run shares across its steps."""

    raster: FieldRaster
    domain: Domain
    grid: Occupancy
    params: SwarmParams
    pitch: float
    next_pid: int
    stats: dict = field(default_factory=dict)

    def new_pids(self, k: int) -> Ints:
        """``k`` fresh path ids."""
        out = np.arange(self.next_pid, self.next_pid + k, dtype=np.int64)
        self.next_pid += k
        return out

    def count(self, key: str, value: float = 1) -> None:
        """Add to a statistic."""
        self.stats[key] = self.stats.get(key, 0) + value


def _kernel_params(p: SwarmParams) -> ks.StepParams:
    return ks.StepParams(
        K=float(p.K),
        window=int(p.window),
        kill_below=float(p.kill_below),
        spawn_above=float(p.spawn_above),
        min_gap=float(p.min_gap),
        ray_reach=float(p.ray_reach),
        merge_reach=float(p.merge_reach),
        grow_free_ends=bool(p.grow_free_ends),
        edge_gap=float(p.edge_gap),
        qp_max_iter=int(p.qp_max_iter),
        qp_tol=_QP_TOL,
        cos_turn=float(np.cos(np.radians(p.max_turn))) if p.max_turn > 0 else -1.0,
    )


def _state_arrays(st: SwarmState) -> tuple[np.ndarray, ...]:
    c = np.ascontiguousarray
    return (
        c(st.pos, dtype=float),
        c(st.head, dtype=float),
        c(st.pid, dtype=np.int64),
        c(st.start, dtype=np.bool_),
    )


def _add_counts(ctx: Context, counts: np.ndarray) -> None:
    for name, v in zip(ks.COUNTERS, counts.tolist(), strict=True):
        ctx.count(name, v)


def run(
    st: SwarmState, ctx: Context, max_steps: int, direction: int = 1
) -> tuple[Points2, Ints, Floats, Ints]:
    """Advance a swarm until it dies (or ``max_steps``), in one compiled call.

    Parameters
    ----------
    st : SwarmState
    ctx : Context
        ``ctx.next_pid`` is advanced; statistics are added to ``ctx.stats``.
    max_steps : int
    direction : int
        +1, or -1 for the backward twin of a fill swarm (sign of the recorded step numbers).

    Returns
    -------
    points : (k, 2) float, mm
        Every point laid, step by step.
    pid : (k,) int
        Path id of each point.
    pitch : (k,) float, mm
        Local pitch at each point, negative where uncertain (measured on the finished layer).
    k : (k,) int
        ``direction`` times the step that laid each point.
    """
    counts = np.zeros(len(ks.COUNTERS), dtype=np.int64)
    pts, pid, pitch, k, nxt = ks.run_swarm(
        ctx.raster.data,
        ctx.domain.data,
        ctx.grid.data,
        _kernel_params(ctx.params),
        float(ctx.pitch),
        *_state_arrays(st),
        int(ctx.next_pid),
        int(max_steps),
        int(direction),
        counts,
    )
    ctx.next_pid = int(nxt)
    _add_counts(ctx, counts)
    return pts, pid, pitch, k


def step(st: SwarmState, ctx: Context) -> tuple[SwarmState, Points2, Ints, Floats]:
    """Advance the swarm by one step (for inspection; :func:`run` runs the loop compiled).

    Returns
    -------
    state : SwarmState
        The next state (possibly empty).
    points : (m, 2) float, mm
        New locations of the surviving agents, then the last points of the paths ended this step.
    pid : (m,) int
    pitch : (m,) float, mm
        Local pitch, negative where uncertain.
    """
    counts = np.zeros(len(ks.COUNTERS), dtype=np.int64)
    pos, head, pid, start, pts, ppid, pitch, nxt = ks.step(
        ctx.raster.data,
        ctx.domain.data,
        ctx.grid.data,
        _kernel_params(ctx.params),
        float(ctx.pitch),
        *_state_arrays(st),
        int(ctx.next_pid),
        counts,
    )
    ctx.next_pid = int(nxt)
    _add_counts(ctx, counts)
    return SwarmState(pos=pos, head=head, pid=pid, start=start), pts, ppid, pitch
