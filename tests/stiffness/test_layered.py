"""The bead model sampled a few layers at a time (issue 17: the verdict's memory).

- The chunked sampling gives the whole part's fields bit for bit, on the shipped example's beads
  with chunks of a layer or two and sample-point batches that straddle the chunks, also for a
  :class:`~loadpath.stiffness.deposits.Stack` whose parts interleave the layers (the kept beads of
  every layer, then one lazily made part per layer, as the verdict passes them).
- Its memory does not grow with the layers: the pieces it holds at once stay within a chunk, and
  tracemalloc's peak for 2N layers is within 5 % of the whole-part sampling's growth from N to 2N
  of the peak for N (the test can tell the two apart).  No timing.
"""

from __future__ import annotations

import tracemalloc
from pathlib import Path

import numpy as np
import pytest
from loadpath import gcode
from loadpath.gcode.flavors import Role
from loadpath.stiffness import fields as fields_mod
from loadpath.stiffness import layered
from loadpath.stiffness.beads import attributes
from loadpath.stiffness.cards import PLA_CARD
from loadpath.stiffness.deposits import Deposits, Stack, from_program
from meshes import rectangle_tri6

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "ohs.gcode"
MAT = PLA_CARD.elastic
STEP = 0.5  # mm between bead samples: coarse, so the module runs quickly (chunked and whole sampling agree bit for bit at any step)


@pytest.fixture(scope="module")
def example():
    """The shipped example's beads (10 layers, PrusaSlicer's), moved to the origin, and a mesh over them."""
    program = gcode.read(EXAMPLE)
    dep = from_program(program, 0, 1.75)
    lo = np.minimum(dep.start.min(axis=0), dep.end.min(axis=0)) - 0.5
    hi = np.maximum(dep.start.max(axis=0), dep.end.max(axis=0)) + 0.5
    dep = Deposits(dep.start - lo, dep.end - lo, dep.z0, dep.height, dep.volume, dep.layer, dep.role)
    size = hi - lo
    mesh = rectangle_tri6(float(size[0]), float(size[1]), 30, 8, thickness=2.0)
    return dep, mesh


def _whole(mesh, dep):
    pieces, attrs = attributes(dep, MAT.E1, MAT.G12)
    return fields_mod.sample_deposits(mesh, pieces, STEP, attrs)


def _same(a, b) -> None:
    for name in ("layers", "height", "weight", "fill", "moments", "volume"):
        assert np.array_equal(getattr(a, name), getattr(b, name)), name
    assert a.extra.keys() == b.extra.keys()
    for k in a.extra:
        assert np.array_equal(a.extra[k], b.extra[k]), k
    assert a.lost == pytest.approx(b.lost, rel=1e-9, abs=1e-9)


def _tall(dep: Deposits, times: int) -> Deposits:
    """The part ``times`` as tall: its layers printed again on top of each other."""
    top = int(dep.layer.max()) + 1
    dz = float(dep.z0.max() - dep.z0.min() + np.median(dep.height))
    return Deposits.concat(
        Deposits(dep.start, dep.end, dep.z0 + r * dz, dep.height, dep.volume, dep.layer + r * top, dep.role)
        for r in range(times)
    )


def test_chunks_of_layers_give_the_whole_parts_fields_bit_for_bit(example, monkeypatch):
    dep, mesh = example
    whole = _whole(mesh, dep)
    per_layer = np.bincount(dep.layer, weights=np.ceil(dep.length))
    # chunks of one or two layers, sample batches of a third of a layer: batches straddle chunks
    monkeypatch.setattr(layered, "CHUNK_PIECES", int(1.5 * np.median(per_layer[per_layer > 0])))
    monkeypatch.setattr(fields_mod, "_CHUNK", 40_000)
    _same(layered.sample_beads(mesh, dep, STEP, MAT.E1, MAT.G12), _whole(mesh, dep))
    # the defaults (one chunk here) too
    monkeypatch.undo()
    _same(layered.sample_beads(mesh, dep, STEP, MAT.E1, MAT.G12), whole)


def test_a_stack_with_interleaved_layers_gives_the_fields_of_its_concatenation(example, monkeypatch):
    dep, mesh = example
    solid = dep.role == int(Role.SOLID_INFILL)
    assert solid.any() and (~solid).any()
    kept = dep.select(~solid)
    later = [dep.select(solid & (dep.layer == k)) for k in np.unique(dep.layer[solid])]
    # one part per layer, made when read (as the verdict's units are)
    stack = Stack((kept, *(lambda d=d: d for d in later)))
    monkeypatch.setattr(layered, "CHUNK_PIECES", 30_000)
    monkeypatch.setattr(fields_mod, "_CHUNK", 50_000)
    got = layered.sample_beads(mesh, stack, STEP, MAT.E1, MAT.G12)
    _same(got, _whole(mesh, stack.concat()))


def test_fine_sampling_partly_off_the_mesh_gives_numpys_fields_bit_for_bit(example):
    """The compiled batch sampling (:mod:`loadpath.stiffness.sample_kernel`) against numpy's.

    At 0.1 mm the beads fall into several width classes (sample points across: 4, 5, ...), whose
    order decides the order of the sums (the test fails with the classes taken in descending
    order); the mesh covers the beads' left 70 %, so points are lost.  Numpy's
    ``fields.sample_deposits`` is the reference (its samples, point location and sums).
    """
    dep, mesh = example
    x = np.concatenate([dep.start[:, 0], dep.end[:, 0]])
    width = 0.7 * float(x.max())
    part = rectangle_tri6(width, float(mesh.points[:, 1].max()), 21, 8, thickness=2.0)
    got = layered.sample_beads(part, dep, 0.1, MAT.E1, MAT.G12)
    pieces, attrs = attributes(dep, MAT.E1, MAT.G12)
    want = fields_mod.sample_deposits(part, pieces, 0.1, attrs)
    w = pieces.volume / (pieces.length * pieces.height)
    assert len(np.unique(np.ceil(w / 0.1))) >= 2  # several width classes
    assert want.lost > 0.1 * float(np.sum(dep.volume))  # a good share off the mesh
    _same(got, want)  # the lost volume to 1e-9: summed by chunk of layers (module docstring)


def test_points_on_element_edges_get_numpys_elements_bit_for_bit():
    """The compiled sampling tries the element of the point before first (``sample_kernel.HINT``);
    a point on an edge or a vertex must still get the element the grid scan gives it.  Beads laid
    along a horizontal, a vertical and a diagonal edge of a mesh of unit squares (two triangles
    each, split along that diagonal), five sample points across each (the middle one on the edge),
    against numpy's sampling."""
    from loadpath.stiffness import sample_kernel

    assert sample_kernel.HINT > 100 * 1e-9  # well clear of the locator's eps
    mesh = rectangle_tri6(8.0, 8.0, 8, 8, thickness=1.0)
    start = np.array([[0.3, 4.0], [3.0, 0.3], [0.5, 0.5], [7.7, 2.0]])
    end = np.array([[7.7, 4.0], [3.0, 7.7], [7.5, 7.5], [0.3, 2.0]])
    length = np.hypot(*(end - start).T)
    height = np.full(4, 0.2)
    dep = Deposits(start, end, np.zeros(4), height, 0.5 * height * length, np.zeros(4, dtype=np.int64),
                   np.full(4, int(Role.SOLID_INFILL)))
    pieces, attrs = attributes(dep, MAT.E1, MAT.G12)
    w = pieces.volume / (pieces.length * pieces.height)
    assert np.all(np.ceil(w / 0.1 - 1e-9) % 2 == 1)  # an odd count across: one sample on the centre line
    want = fields_mod.sample_deposits(mesh, pieces, 0.1, attrs)
    _same(layered.sample_beads(mesh, dep, 0.1, MAT.E1, MAT.G12), want)


def _peak(fn) -> int:
    tracemalloc.start()
    try:
        fn()
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def test_memory_does_not_grow_with_the_layers(example, monkeypatch):
    dep, mesh = example
    monkeypatch.setattr(layered, "CHUNK_PIECES", 40_000)  # about three layers of the example
    short, tall = _tall(dep, 2), _tall(dep, 4)  # 20 and 40 layers
    peaks, held = [], []
    for d in (short, tall):
        layered.PEAK[0] = 0
        peaks.append(_peak(lambda d=d: layered.sample_beads(mesh, d, STEP, MAT.E1, MAT.G12)))
        held.append(layered.PEAK[0])
    biggest_layer = int(np.bincount(dep.layer, weights=np.ceil(dep.length)).max())
    assert max(held) <= 40_000 + biggest_layer  # pieces held at once: one chunk
    # what the measure is sensitive to: the whole part's sampling holds every piece at once
    whole = [_peak(lambda d=d: _whole(mesh, d)) for d in (short, tall)]
    grows = whole[1] - whole[0]  # 20 more layers: about 80 MB
    assert grows > 0.3 * whole[0], whole
    assert peaks[1] - peaks[0] <= 0.05 * grows, (peaks, whole)
    assert peaks[1] < 0.5 * whole[1], (peaks, whole)
