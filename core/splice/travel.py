"""Travels between new paths the way the slicer makes them: retraction, wipe, z-hop.

No travel leaves the replace region primed.

Rules (PrusaSlicer's ``GCode::needs_retraction`` and ``Wipe``, Cura's combing/min-travel, as far as
a post-processor can apply them; ``slicer-conventions.md`` §5):

- with ``avoid_crossing_perimeters`` (PrusaSlicer) or combing (Cura, and wherever
  ``only_retract_when_crossing_perimeters`` / ``reduce_infill_retraction`` is on), a travel whose
  straight segment leaves the region is routed inside it: along the region's edge around each
  piece it would cross (:func:`route`), from the slicer's walls by a step over them inside the
  island's outline (``comb``); a travel that cannot be routed (another island) stays straight;
- a travel that leaves the region (not routed) retracts, unless it is shorter than
  ``retract_before_travel`` and stays within :data:`SHORT_REACH` of the region (over the innermost
  perimeter): PrusaSlicer retracts no travel shorter than that (``GCode::needs_retraction``,
  ``src/libslic3r/GCode.cpp``: the length test comes first), and a travel that far out crosses no
  perimeter; any other travel leaving the region retracts, however short;
- inside the region, a travel retracts when it is longer than ``retract_before_travel``, unless
  ``only_retract_when_crossing_perimeters`` (Cura: combing; Orca / Bambu:
  ``reduce_infill_retraction``) is on;
- a retraction wipes first when ``wipe`` is on: it moves back along the path just printed, at
  0.8 x travel speed, for as long as the retraction takes at ``retract_speed``, pulling 95 % of the
  length (what is left, and the ``retract_before_wipe`` part, are E-only moves) -- verified on
  PrusaSlicer 2.5 output (3.29 mm wipe, E -0.76 then -0.04 for a 0.8 mm retraction);
- then it lifts by ``retract_lift``; after the travel it lowers and primes back what was pulled
  (plus ``retract_restart_extra``).  Firmware retraction writes ``G10``/``G11``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely
from loadpath._typing import Points2, Region
from loadpath.gcode.model import Program
from loadpath.splice.emit import Writer, fmt_many
from shapely.geometry import LineString

SHORT_REACH = 0.35
"""How far past the region's edge a travel shorter than ``retract_before_travel`` may pass primed,
mm: over the innermost perimeter beside the region (the reach :func:`route` gives its ends)."""

__all__ = [
    "SHORT_REACH",
    "Retraction",
    "Motion",
    "TravelState",
    "travel",
    "retract",
    "unretract",
    "wipe_back",
    "wipe_points",
    "wipe_distance",
    "prepare_wipes",
    "route",
    "cover_travels",
]


@dataclass(frozen=True)
class Retraction:
    """How the slicer retracts for a travel (PrusaSlicer names; Cura's equivalents in brackets).

    Attributes
    ----------
    length : float, mm
        ``retract_length`` [``retraction_amount``].
    speed : float, mm/s
        ``retract_speed`` [``retraction_retract_speed``].
    deretract_speed : float, mm/s
        ``deretract_speed`` (0: ``speed``) [``retraction_prime_speed``].
    restart_extra : float, mm
        ``retract_restart_extra`` [``retraction_extra_prime_amount``, in mm of filament].
    lift : float, mm
        ``retract_lift`` [``retraction_hop`` when ``retraction_hop_enabled``].
    lift_speed : float, mm/s
        ``travel_speed_z`` (0: the travel speed) [``speed_z_hop``].
    before_travel : float, mm
        ``retract_before_travel``: shorter travels inside the region do not retract
        [``retraction_min_travel``].
    only_when_crossing : bool
        ``only_retract_when_crossing_perimeters`` [``retraction_combing`` not ``"off"``]: travels
        inside the region never retract.
    wipe : bool
        ``wipe``: retract while moving back along the last path.
    before_wipe : float
        ``retract_before_wipe`` as a fraction (0..1).
    firmware : bool
        ``use_firmware_retraction``: ``G10`` / ``G11``.
    avoid_crossing : bool
        ``avoid_crossing_perimeters`` [combing]: route travels inside the region.
    """

    length: float = 0.8
    speed: float = 35.0
    deretract_speed: float = 0.0
    restart_extra: float = 0.0
    lift: float = 0.0
    lift_speed: float = 0.0
    before_travel: float = 1.0
    only_when_crossing: bool = False
    wipe: bool = False
    before_wipe: float = 0.0
    firmware: bool = False
    avoid_crossing: bool = False


@dataclass(frozen=True)
class Motion:
    """Speeds and retraction of the machine the file was sliced for.

    Attributes
    ----------
    travel_speed : float, mm/s
    retraction : Retraction
    """

    travel_speed: float = 150.0
    retraction: Retraction = Retraction()

    @property
    def travel_f(self) -> float:
        """Travel feedrate, mm/min."""
        return self.travel_speed * 60.0

    @property
    def lift_f(self) -> float:
        """Z feedrate for lifts, mm/min."""
        s = self.retraction.lift_speed or self.travel_speed
        return s * 60.0


class TravelState:
    """Bookkeeping of a rewrite that the Writer does not hold."""

    def __init__(
        self,
        program: Program,
        region: Region | None,
        motion: Motion,
        layer_z: float,
        comb: Region | None = None,
    ) -> None:
        self.program = program
        self.motion = motion
        self.layer_z = layer_z
        self.fw = False
        self.region = None
        if region is not None:
            self.region = region.buffer(1e-3)
            shapely.prepare(self.region)
        self.comb = None  # the island's part outline: where a travel may cross the walls (route)
        if comb is not None and not comb.is_empty:
            self.comb = comb.buffer(1e-3)
            shapely.prepare(self.comb)
        self.n_travels = 0
        self.n_retracts = 0
        self._rings: list | None = None
        self.cache: dict = {}
        self.covered: dict[tuple[float, float, float, float], bool] = {}  # cover_travels' answers
        self.wipes: dict[int, _WipeTail] = {}  # prepare_wipes' tails, under id() of the chain's points
        self.wipe_distance = float("nan")  # the distance they were made for

    @property
    def rings(self) -> list:
        """The region's boundary rings (for routing), computed on first use."""
        if self._rings is None:
            edge = [] if self.region is None else shapely.get_parts(self.region.boundary)
            self._rings = list(shapely.get_parts(edge)) if len(edge) else []
        return self._rings


def _inside(st: TravelState, a: Points2, b: Points2) -> bool:
    if st.region is None:
        return True
    got = st.covered.get((float(a[0]), float(a[1]), float(b[0]), float(b[1])))
    if got is not None:
        return got
    return bool(st.region.covers(LineString([a, b])))


def cover_travels(st: TravelState, starts: Points2, ends: Points2) -> None:
    """Test in one call whether the region covers each straight travel ``starts[k] -> ends[k]``.

    :func:`travel` then looks the answer up instead of building a LineString per travel (issue 17:
    one shapely object per path was a tenth of the rewrite).  The same prepared region and the same
    predicate on the same two points, so the same answer.

    Parameters
    ----------
    starts, ends : (k, 2) float, mm
    """
    if st.region is None or not len(starts):
        return
    segs = shapely.linestrings(np.stack([starts, ends], axis=1))
    ok = np.asarray(shapely.covers(st.region, segs), dtype=bool).tolist()
    keys = np.concatenate([starts, ends], axis=1).tolist()
    st.covered.update(zip(map(tuple, keys), ok, strict=True))


def route(st: TravelState, a: Points2, b: Points2, reach: float = 0.35) -> Points2 | None:
    """A travel from ``a`` to ``b`` inside the region: the straight segment, with each piece that leaves
    the region replaced by the shorter way round the edge it crosses; ``(k, 2)`` points after ``a``
    (ending with ``b``), or None when that is not possible (another island, several edges).

    A piece at either end that is at most ``reach`` mm long, or that stays within ``reach`` of the
    region all along, stays straight: the nozzle comes from (or goes to) the innermost perimeter,
    whose centre line lies that little outside the infill region.  The second case is CuraEngine's
    layer start: its travel ends on the infill line's end, 0.04 mm outside the region found from
    the perimeters, and the first new run may start a few mm along that edge: a straight travel
    over the edge, not one round it (the edge walk cannot start from a point off the edge).

    Any other piece at an end goes round the edge too, from the edge's point nearest that end, when
    the straight step between the two lies inside ``st.comb`` (the island's part outline): the
    nozzle is on the island's own walls, as where a block follows its outer wall, and crosses them
    to the region the way the slicer's combing would (CuraEngine combs inside the part).  Without
    ``comb`` such a piece is not routed (a start a millimetre off the edge may be another island's).
    """
    from shapely.ops import substring

    line = LineString([a, b])
    if st.region is None or st.region.covers(line):
        return np.asarray(b, dtype=float)[None]
    outside = shapely.get_parts(line.difference(st.region))
    if len(outside) == 0:
        return np.asarray(b, dtype=float)[None]
    pts: list[np.ndarray] = []
    pos_on_line = []
    for piece in outside:
        c = shapely.get_coordinates(piece)
        if len(c) < 2:
            continue
        t0, t1 = line.project(shapely.points(c[0])), line.project(shapely.points(c[-1]))
        pos_on_line.append((min(t0, t1), c[0] if t0 <= t1 else c[-1], c[-1] if t0 <= t1 else c[0], piece))
    pos_on_line.sort(key=lambda x: x[0])
    total_len = line.length
    crossed = [False, False]  # a step over the walls at the start, at the end
    for t, p, q, piece in pos_on_line:
        piece_len = float(np.hypot(*(q - p)))
        at_a, at_b = t < 1e-6, abs(t + piece_len - total_len) < 1e-6
        if (at_a or at_b) and (piece_len <= reach or _near_region(st, reach).covers(piece)):
            continue  # from or to the perimeter beside the region
        pp, qp = shapely.points(p), shapely.points(q)
        dp = np.array([ring.distance(pp) for ring in st.rings])
        dq = np.array([ring.distance(qp) for ring in st.rings])
        ok = (dp <= 0.01) & (dq <= 0.01)
        if not ok.any() and st.comb is not None:
            # an end off the edge: step straight over the walls (inside the part) to the nearest edge
            ok = ((dp <= 0.01) | _over_walls(st, p, at_a)) & ((dq <= 0.01) | _over_walls(st, q, at_b))
        if not ok.any():
            return None
        k = int(np.argmin(np.where(ok, dp + dq, np.inf)))
        ring = st.rings[k]
        crossed[0] |= bool(at_a and dp[k] > 0.01)
        crossed[1] |= bool(at_b and dq[k] > 0.01)
        total = ring.length
        sp, sq = ring.project(pp), ring.project(qp)
        fwd = (sq - sp) % total
        if fwd <= total - fwd:
            start, length, flip = sp, fwd, False
        else:
            start, length, flip = sq, total - fwd, True
        end = start + length
        if end <= total:
            walk = shapely.get_coordinates(substring(ring, start, end))
        else:
            walk = np.vstack(
                [
                    shapely.get_coordinates(substring(ring, start, total)),
                    shapely.get_coordinates(substring(ring, 0.0, end - total))[1:],
                ]
            )
        pts.append(walk[::-1] if flip else walk)
    pts.append(np.asarray(b, dtype=float)[None])
    full = np.vstack([np.asarray(a, dtype=float)[None], *pts])
    keep = np.r_[True, np.hypot(*np.diff(full, axis=0).T) > 1e-6]
    full = full[keep]
    inner = full[int(crossed[0]) : len(full) - int(crossed[1])]  # the steps over the walls were tested
    if len(full) < 2 or (len(inner) >= 2 and not _near_region(st, reach).covers(LineString(inner))):
        return None
    return full[1:]


def _over_walls(st: TravelState, end: Points2, at_end: bool) -> np.ndarray:
    """Per ring of the region: whether the straight step from ``end`` (a travel's own end, off the
    edge) to the ring's nearest point lies inside the part outline ``st.comb``, shape ``(rings,)``."""
    if not at_end:
        return np.zeros(len(st.rings), dtype=bool)
    pt = shapely.points(end)
    near = [shapely.get_coordinates(ring.interpolate(ring.project(pt)))[0] for ring in st.rings]
    steps = shapely.linestrings([[end, n] for n in near])
    return np.asarray(shapely.covers(st.comb, steps), dtype=bool)


def _near_region(st: TravelState, reach: float):
    key = ("near", reach)
    if key not in st.cache:
        g = st.region.buffer(reach)
        shapely.prepare(g)
        st.cache[key] = g
    return st.cache[key]


def wipe_points(chain_pts: Points2, distance: float, tail: int = 16) -> Points2:
    """Points of a wipe that retraces ``chain_pts`` backwards from its end for ``distance`` mm.

    Only the last ``tail`` points are measured when they reach ``distance`` (a wipe is a few mm; a
    chain may be thousands of points): the lengths summed from the end are the same numbers either
    way, so the points are too.
    """
    back = chain_pts[: -tail - 1 : -1] if len(chain_pts) > tail else chain_pts[::-1]
    seg = np.hypot(*(back[1:] - back[:-1]).T)
    cum = np.concatenate([[0.0], np.cumsum(seg)])
    if len(back) < len(chain_pts) and not cum[-1] >= distance:  # the tail is too short: all of it
        back = chain_pts[::-1]
        seg = np.hypot(*(back[1:] - back[:-1]).T)
        cum = np.concatenate([[0.0], np.cumsum(seg)])
    d = min(distance, float(cum[-1]))
    k = int(np.searchsorted(cum, d, side="left"))
    pts = back[1:k]
    if k < len(back):
        t = (d - cum[k - 1]) / max(seg[k - 1], 1e-12)
        end = back[k - 1] + t * (back[k] - back[k - 1])
        pts = np.vstack([pts, end[None]]) if len(pts) else end[None]
    return pts


def wipe_back(
    w: Writer, chain_pts: Points2, distance: float, total: float, tail: _WipeTail | None = None
) -> float:
    """Move back along ``chain_pts`` for up to ``distance`` mm pulling ``total`` mm; returns mm pulled.

    ``tail``: the chain's wipe made beforehand for this distance (:func:`prepare_wipes`), used when
    the nozzle is at the chain's end (where it was made from).
    """
    if distance <= 0 or total <= 0:
        return 0.0
    if tail is not None and w.x == tail.x0 and w.y == tail.y0:
        if tail.total <= 0:
            return 0.0
        w.wipe_lines(tail.xs, tail.ys, tail.xw, tail.yw, [total * s / tail.total for s in tail.seg])
        return total
    pts = wipe_points(chain_pts, distance)
    if len(pts) == 0:
        return 0.0
    path = np.vstack([[w.x, w.y], pts])
    seg = np.hypot(*(path[1:] - path[:-1]).T)
    if seg.sum() <= 0:
        return 0.0
    w.wipe_many(pts, total * seg / seg.sum())
    return total


@dataclass(frozen=True)
class _WipeTail:
    """A chain's wipe made beforehand (:func:`prepare_wipes`): what :func:`wipe_back` computes from it.

    ``x0, y0``: the chain's end (where the wipe starts); ``xs, ys``: the wipe's points, ``xw, yw``
    their text (3 decimals); ``seg``: the length of each wipe move, from the chain's end; ``total``:
    their sum as ``np.sum`` makes it.
    """

    x0: float
    y0: float
    xs: list[float]
    ys: list[float]
    xw: list[str]
    yw: list[str]
    seg: list[float]
    total: float


def _sum_as_numpy(values: list[float]) -> float:
    """``float(np.sum(values))`` for a short list: left to right from 0 below 8 values (numpy's pairwise
    sum adds fewer than 8 values one after the other), numpy's own sum above."""
    if len(values) >= 8:
        return float(np.sum(np.array(values)))
    acc = 0.0
    for v in values:
        acc += v
    return acc


def wipe_distance(motion: Motion) -> float:
    """How far a retraction wipes back, mm (:func:`retract` and :func:`prepare_wipes`: as long as the
    retraction takes at ``retract_speed``, at 0.8 x travel speed)."""
    r = motion.retraction
    return r.length / r.speed * (0.8 * motion.travel_speed)


def prepare_wipes(
    st: TravelState, chains: list[Points2], distance: float, leading_zero: bool = False, tail: int = 16
) -> None:
    """Make the wipe back along each of ``chains`` for ``distance`` mm in one numpy pass.

    :func:`retract` then takes each chain's wipe from ``st.wipes`` instead of measuring its tail,
    formatting its points and summing its moves one chain at a time (issue 17: a fifth of the
    rewrite's time on the 100-layer specimen).  The same figures as :func:`wipe_points` and
    :func:`wipe_back`: the same element-wise operations on each chain's last ``tail + 1`` points
    (cumulative sums row by row, sequential as ``np.cumsum`` is), the same text (:func:`fmt_many`);
    a chain whose tail is shorter than ``distance`` (the wipe needs more of it) is left to them.

    Parameters
    ----------
    st : TravelState
    chains : list of (n_i, 2) float, mm
        The chains a travel may wipe back along (each with n_i >= 2).
    distance : float, mm
    leading_zero : bool
        The style's (the text of the wipe's points).
    """
    st.wipes, st.wipe_distance = {}, distance
    if not chains or not distance > 0:
        return
    n = np.array([len(c) for c in chains])
    if n.min() < 2:
        return
    b_at = np.arange(len(n))
    rows = np.minimum(n, tail + 1)  # the points wipe_points reads backwards from each chain's end
    end = np.cumsum(n) - 1  # each chain's last point among the stacked points
    j = np.minimum(np.arange(tail + 1)[None, :], rows[:, None] - 1)  # a short chain repeats its first
    back = np.concatenate(chains)[end[:, None] - j]  # (B, tail + 1, 2), backwards from each end
    step = back[:, 1:] - back[:, :-1]
    seg = np.hypot(step[..., 0], step[..., 1])  # (B, tail); 0 on the repeated points
    cum = np.concatenate([np.zeros((len(n), 1)), np.cumsum(seg, axis=1)], axis=1)
    last = cum[:, -1]  # each row's own total (the repeated points add zeros)
    d = np.minimum(distance, last)
    k = np.sum(cum < d[:, None], axis=1)  # np.searchsorted(cum, d, "left") of each row
    # wipe_points reads the whole chain where its tail is too short, and has no wipe for k = 0
    ok = ((rows == n) | (last >= distance)) & (k >= 1)
    km = np.maximum(k, 1) - 1
    t = (d - cum[b_at, km]) / np.maximum(seg[b_at, km], 1e-12)
    stop = back[b_at, km] + t[:, None] * (back[b_at, np.minimum(k, tail)] - back[b_at, km])
    # each wipe's points back[1 : k] and its end, and the moves' lengths from the chain's end
    pts = back[:, 1:].copy()
    pts[b_at, km] = stop
    moves = seg.copy()
    moves[b_at, km] = np.hypot(*(stop - back[b_at, km]).T)
    take = (np.arange(tail)[None, :] < k[:, None]) & ok[:, None]
    wp = pts[take]
    xs, ys = wp[:, 0].tolist(), wp[:, 1].tolist()
    xw, yw = fmt_many(xs, 3, leading_zero), fmt_many(ys, 3, leading_zero)
    ms = moves[take].tolist()
    x0, y0 = back[:, 0, 0].tolist(), back[:, 0, 1].tolist()
    a = 0
    for i, kk in zip(np.flatnonzero(ok).tolist(), k[ok].tolist(), strict=True):
        z = a + kk
        seg_i = ms[a:z]
        st.wipes[id(chains[i])] = _WipeTail(
            x0[i], y0[i], xs[a:z], ys[a:z], xw[a:z], yw[a:z], seg_i, _sum_as_numpy(seg_i)
        )
        a = z


def retract(w: Writer, st: TravelState, last: Points2 | None, last_length: float | None = None) -> None:
    """Retract (wipe first when the slicer does) and lift, as the slicer would before a travel.

    ``last_length``: the length of ``last`` (mm) when the caller has it (else measured here).
    """
    r = st.motion.retraction
    st.n_retracts += 1
    if r.firmware:
        w.raw("G10")
        st.fw = True
    elif r.length > 0:
        done = 0.0
        if r.before_wipe > 0 or not (r.wipe and last is not None):
            first = r.length * (r.before_wipe if (r.wipe and last is not None) else 1.0)
            w.e_move(-first, r.speed * 60.0)
            done += first
        if r.wipe and last is not None and r.length - done > 0:
            # PrusaSlicer: wipe for the time the retraction takes at retract_speed, at 0.8 x travel
            # speed, pulling 95 % of what is left; the rest is an E-only move (verified on 2.5 output).
            wipe_speed = 0.8 * st.motion.travel_speed
            dist = wipe_distance(st.motion)  # the same figure prepare_wipes was given
            avail = last_length if last_length is not None else _length(last)
            want = 0.95 * (r.length - done) * min(1.0, avail / dist) if dist > 0 else 0.0
            w.marker(w.style.wipe_start, "")
            w.feed(wipe_speed * 60.0)
            tail = st.wipes.get(id(last)) if dist == st.wipe_distance else None
            done += wipe_back(w, last, dist, want, tail)
            w.marker(w.style.wipe_end, "")
        if r.length - done > 1e-9:
            w.e_move(-(r.length - done), r.speed * 60.0)
    if r.lift > 0:
        w.z_move(st.layer_z + r.lift, st.motion.lift_f)


def _length(points: Points2) -> float:
    """Length of a polyline ``(n, 2)``, mm (the sum :attr:`loadpath.splice.plan.Chain.length` makes)."""
    return float(np.sum(np.hypot(*(points[1:] - points[:-1]).T)))


def unretract(w: Writer, st: TravelState) -> None:
    """Lower back to the layer and prime what was pulled (plus the restart extra), or ``G11``."""
    r = st.motion.retraction
    if abs(w.z - st.layer_z) > 1e-9:
        w.z_move(st.layer_z, st.motion.lift_f)
    if st.fw:
        w.raw("G11")
        st.fw = False
    elif w.retracted > 0 or r.restart_extra:
        w.e_move(w.retracted + r.restart_extra, (r.deretract_speed or r.speed) * 60.0)
        w.retracted = 0.0


def travel(
    w: Writer,
    st: TravelState,
    target: Points2,
    last: Points2 | None,
    f: float | None = None,
    z: float | None = None,
    last_length: float | None = None,
) -> None:
    """Travel to ``target``, retracting by the slicer's rules when primed; never leave the region primed.

    ``last``: the path just printed (a retraction wipes back along it), ``last_length`` its length
    when the caller has it.
    """
    here = np.array([w.x, w.y])
    d = float(np.hypot(*(target - here)))
    if d < 1e-9 and z is None:
        return
    st.n_travels += 1
    primed = w.retracted <= 1e-9 and not st.fw
    own = False
    r = st.motion.retraction
    way = np.asarray(target, dtype=float)[None]
    if d > 1e-9:
        inside = _inside(st, here, target)
        if not inside and d < r.before_travel and st.region is not None:
            # PrusaSlicer never retracts a travel shorter than retract_before_travel, whatever it
            # crosses (``GCode::needs_retraction``, src/libslic3r/GCode.cpp); one that stays over the
            # innermost perimeter beside the region is taken primed, as the slicer would
            inside = bool(_near_region(st, SHORT_REACH).covers(LineString([here, target])))
        if not inside and (r.avoid_crossing or r.only_when_crossing):
            routed = route(st, here, target)
            if routed is not None:
                way, inside = routed, True
                d = float(np.sum(np.hypot(*np.diff(np.vstack([here[None], way]), axis=0).T)))
        if primed and (not inside or (d > r.before_travel and not r.only_when_crossing)):
            retract(w, st, last, last_length)
            own = True
    for k, (x, y) in enumerate(way):
        last_leg = k == len(way) - 1
        w.travel(float(x), float(y), f or st.motion.travel_f, z if last_leg else None)
    if own:
        unretract(w, st)
