"""The linking's candidate tests one by one, as they were before they were batched: the reference
that ``loadpath.engines.linking`` must equal to the bit.

:class:`OneByOne` is the linking's layer (:class:`loadpath.engines.linking._Layer`, the same
preparation) whose geometric test of a candidate is the code of commit a57aa31: each straight link
sampled and tested against the paths on its own, each boundary link's ring piece made with
``shapely`` calls one end at a time (``_ring_link``, ``_substring``), then turned, measured,
contained and sampled one link at a time.  :func:`assert_links_as_one_by_one` links a layer both
ways with it and with the batched code, and compares every candidate's test and the runs.
"""

from __future__ import annotations

import numpy as np
import shapely
from loadpath.engines.linking import LinkOptions, _Layer, _link, drop_fragments
from loadpath.toolpath import Path


def _samples(points: np.ndarray, step: float) -> np.ndarray:
    dv = points[1:] - points[:-1]
    n = np.maximum(1, np.ceil(np.hypot(dv[:, 0], dv[:, 1]) / step).astype(np.int64))
    rep = np.repeat(np.arange(len(n)), n)
    k = np.arange(len(rep)) - np.repeat(np.cumsum(n) - n, n)
    return np.vstack([points[:-1][rep] + (k / n[rep])[:, None] * dv[rep], points[-1:]])


def _ring_link(region, a, b, inset: float, limit: float, cache: dict):
    key = round(inset, 2)
    if key in cache:
        rings, per_end, arcs = cache[key]
    else:
        inner = region.buffer(-key, quad_segs=4) if key > 1e-6 else region
        rings = shapely.get_parts(shapely.get_parts(shapely.boundary(inner))) if not inner.is_empty else []
        per_end: dict = {}
        arcs: dict = {}
        cache[key] = (rings, per_end, arcs)
    if not len(rings):
        return None

    def near(p):
        k = p.tobytes()
        if k not in per_end:
            pt = shapely.points(p)
            per_end[k] = (shapely.distance(rings, pt), pt)
        return per_end[k]

    da, pa = near(a)
    db, pb = near(b)
    k = int(np.argmin(da))
    ring = rings[k]
    if da[k] > 0.5 * limit or float(db[k]) > 0.5 * limit:
        return None
    total = float(ring.length)
    sa, sb = float(ring.project(pa)), float(ring.project(pb))
    if ring.is_closed:
        fwd = (sb - sa) % total
        back = total - fwd
        if min(fwd, back) > limit:
            return None
        start, length, flip = (sa, fwd, False) if fwd <= back else (sb, back, True)
        end = start + length
        if end <= total:
            piece = _substring(ring, start, end, arcs, k)
        else:
            rest = _substring(ring, 0.0, end - total, arcs, k)[1:]
            piece = np.vstack([_substring(ring, start, total, arcs, k), rest])
    else:
        lo, hi = sorted((sa, sb))
        if hi - lo > limit:
            return None
        piece = _substring(ring, lo, hi, arcs, k)
        flip = sa > sb
    if flip:
        piece = piece[::-1]
    pts = np.vstack([a[None], piece, b[None]])
    keep = np.r_[True, np.hypot(*np.diff(pts, axis=0).T) > 1e-6]
    pts = pts[keep]
    return pts if len(pts) >= 2 else None


def _substring(ring, start: float, end: float, arcs: dict, k: int) -> np.ndarray:
    if k not in arcs:
        xy = shapely.get_coordinates(ring)
        run = [0.0]
        c = xy.tolist()
        for (x1, y1), (x2, y2) in zip(c[:-1], c[1:], strict=True):
            run.append(run[-1] + ((x2 - x1) ** 2 + (y2 - y1) ** 2) ** 0.5)
        arcs[k] = (xy, np.array(run))
    xy, run = arcs[k]
    p0 = shapely.get_coordinates(ring.interpolate(start))
    if start == end:
        return p0
    p1 = shapely.get_coordinates(ring.interpolate(end))
    inner = run[:-1]
    mid = np.flatnonzero((inner > start) & (inner < end))
    return np.vstack([p0, xy[mid], p1])


class OneByOne(_Layer):
    """A prepared layer whose candidate tests are made one link at a time (module docstring)."""

    def _clear_one(self, s: np.ndarray, ea: int, eb: int) -> bool:
        pitch = self.pitch
        hits = self.tree.query_ball_point(s, self.options.clearance * pitch - 0.125 * pitch)
        found = [h for h in hits if h]
        if not found:
            return True
        h = np.concatenate(found)
        return not bool(np.any(~self._exempt(h, ea) & ~self._exempt(h, eb)))

    def geometry(self, ea: int, eb: int, straight_ok: bool, edge_ok: bool):
        key = (ea, eb, straight_ok, edge_ok)
        if key in self.tried:
            return self.tried[key]
        pitch, e_pt = self.pitch, self.e_pt
        out = None
        if straight_ok:
            cand = np.vstack([e_pt[ea], e_pt[eb]])
            s = _samples(cand, 0.25 * pitch)
            if self._clear_one(s, ea, eb):
                out = (cand, s, False)
        if out is None and edge_ok:
            o = self.options
            edge_limit = max(o.max_edge_link, o.max_link) * pitch
            inset = float(np.clip(0.5 * (self.edge_d[ea] + self.edge_d[eb]), 0.0, o.edge_reach * pitch))
            rings = self.__dict__.setdefault("rings", {})
            cand = _ring_link(self.region, e_pt[ea], e_pt[eb], inset, edge_limit, rings)
            if (
                cand is not None
                and self.forward(cand, ea, eb)
                and float(np.sum(np.hypot(*np.diff(cand, axis=0).T))) <= edge_limit
                and self.grown.covers(shapely.LineString(cand))
            ):
                s = _samples(cand, 0.25 * pitch)
                if self._clear_one(s, ea, eb):
                    out = (cand, s, True)
        self.tried[key] = out
        return out


def _same(x, y) -> bool:
    if x is None or y is None:
        return x is None and y is None
    pairs = zip(x[:2], y[:2], strict=True)
    return x[2] == y[2] and all(p.shape == q.shape and np.array_equal(p, q) for p, q in pairs)


def assert_links_as_one_by_one(
    paths: list[Path], region, pitch: float, options: LinkOptions | None = None, every: bool = True
) -> tuple[int, int]:
    """Link ``paths`` both ways with the batched tests and with :class:`OneByOne`: the same runs and
    counts; with ``every``, also every candidate's test (both ways round, as straight link, as
    boundary link and as either) the same points and samples.  Returns the boundary links laid."""
    options = LinkOptions() if options is None else options
    ps = [p for p in paths if len(p.points) >= 2]
    if options.min_fragment > 0:
        ps, _ = drop_fragments(ps, options.min_fragment * pitch, options.fragment_share)
    new = _Layer.of(ps, region, pitch, options)
    ref = OneByOne.of(ps, region, pitch, options)
    assert (new is None) == (ref is None)
    if new is None:
        return 0, 0
    boundary = 0
    for way in (True, False):
        stats = {"paths_in": len(ps), "links": 0, "boundary_links": 0, "link_mm": 0.0, "dropped": 0}
        runs, st = _link(new, way, dict(stats))
        runs_r, st_r = _link(ref, way, dict(stats))
        assert st == st_r
        assert len(runs) == len(runs_r)
        for r, q in zip(runs, runs_r, strict=True):
            assert r.kind == q.kind
            assert np.array_equal(r.points, q.points) and np.array_equal(r.pitch, q.pitch)
        boundary += st["boundary_links"]
    passing = 0
    if every:
        for ea, eb in zip(new.a.tolist(), new.b.tolist(), strict=True):
            for x, y in ((ea, eb), (eb, ea)):
                for flags in ((True, False), (False, True), (True, True)):
                    assert _same(new.geometry(x, y, *flags), ref.geometry(x, y, *flags)), (x, y, flags)
                passing += new.geometry(x, y, False, True) is not None
    return boundary, passing
