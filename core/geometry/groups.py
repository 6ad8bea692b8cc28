"""Group layers whose regions are the same within a tolerance.

Coordinates in G-code are rounded to 1 um, so two layers of a prismatic part never give bit-identical
polygons; they are the same region when ``area(a xor b) / perimeter`` (the mean distance between
their boundaries, :func:`loadpath.geometry.ops.region_difference`) is below
``TOL.region_compare_mm``.  The pipeline solves the FEA once per distinct outline and computes paths
once per distinct replace region, reusing them on the layers of the same group.
"""

from __future__ import annotations

from collections.abc import Hashable, Iterable, Sequence
from dataclasses import dataclass, field

from loadpath._typing import Region
from loadpath.geometry.classify import DEFAULT_REPLACE
from loadpath.geometry.model import LayerGeometry, ObjectGeometry
from loadpath.geometry.ops import region_difference
from loadpath.tolerances import TOL

__all__ = ["LayerGroup", "group_regions", "distinct_layers", "KEYS"]

KEYS = ("outline", "domain", "replace")
"""What :func:`distinct_layers` compares."""


@dataclass(frozen=True)
class LayerGroup:
    """Layers that share one region.

    Attributes
    ----------
    layers : tuple of int
        Indices into ``Program.layers``, ascending.
    representative : int
        The first of them, whose region stands for the group.
    region : Polygon or MultiPolygon
        The representative's region.
    """

    layers: tuple[int, ...]
    representative: int
    region: Region = field(repr=False)


def group_regions(regions: Sequence[Region], keys: Sequence[Hashable] | None = None,
                  tol: float = TOL.region_compare_mm) -> list[int]:
    """Group label of every region: equal labels mean the same region within ``tol``.

    Parameters
    ----------
    regions : sequence of Polygon or MultiPolygon
    keys : sequence of hashable, optional
        Extra properties that must be equal too (layer height, pitch, ...).
    tol : float, mm
        Largest :func:`region_difference` between a region and its group's first member.

    Returns
    -------
    list of int
        Labels ``0, 1, ...`` in order of first appearance.

    Examples
    --------
    >>> from shapely import box
    >>> group_regions([box(0, 0, 10, 5), box(0, 0, 10, 5.0001), box(0, 0, 10, 6)])
    [0, 0, 1]
    """
    keys = [None] * len(regions) if keys is None else list(keys)
    reps: list[tuple[Region, Hashable, float, float]] = []  # region, key, area, perimeter
    labels = []
    for reg, key in zip(regions, keys, strict=True):
        area, per = reg.area, reg.length
        label = -1
        for k, (r, rk, ra, rp) in enumerate(reps):
            # |area(a) - area(b)| <= area(a xor b): a cheap necessary condition before the exact test
            if rk != key or abs(ra - area) > tol * max(rp, per):
                continue
            if region_difference(r, reg) <= tol:
                label = k
                break
        if label < 0:
            label = len(reps)
            reps.append((reg, key, area, per))
        labels.append(label)
    return labels


def distinct_layers(obj: ObjectGeometry | Iterable[LayerGeometry], key: str = "outline",
                    kinds: Iterable[str] = DEFAULT_REPLACE,
                    tol: float = TOL.region_compare_mm) -> list[LayerGroup]:
    """Group an object's layers by region.

    Parameters
    ----------
    obj : ObjectGeometry or iterable of LayerGeometry
    key : {"outline", "domain", "replace"}
        ``"outline"``: part outline (what the FEA meshes); ``"domain"``: infill domain;
        ``"replace"``: replace region for ``kinds``, and the layers must also agree in layer height
        and in the pitch and flow width of the replaced blocks (to 1 um), so paths can be reused as
        they are; layers with nothing to replace are left out.
    kinds : iterable of str
        Replaced kinds, for ``key = "replace"``.
    tol : float, mm

    Returns
    -------
    list of LayerGroup
        In order of first appearance; every layer (with something to replace, for ``"replace"``) is
        in exactly one group.
    """
    if key not in KEYS:
        raise ValueError(f"key must be one of {', '.join(KEYS)}, not {key!r}")
    layers = list(obj.layers if isinstance(obj, ObjectGeometry) else obj)
    kinds = tuple(kinds)
    extra: list[Hashable] | None = None
    if key == "outline":
        regs = [g.outline for g in layers]
    elif key == "domain":
        regs = [g.domain for g in layers]
    else:
        pairs = [(g, g.replace_region(kinds)) for g in layers]
        layers = [g for g, r in pairs if not r.is_empty]
        regs = [r for _, r in pairs if not r.is_empty]
        extra = [(round(g.height, 3),) + tuple(sorted({(round(b.pitch, 3), round(b.flow_width, 3))
                                                         for i in g.islands for b in i.replaced(kinds)}))
                 for g in layers]
    labels = group_regions(regs, extra, tol)
    groups: dict[int, list[int]] = {}
    for g, lab in zip(layers, labels, strict=True):
        groups.setdefault(lab, []).append(g.layer_index)
    return [LayerGroup(tuple(ix), ix[0], regs[labels.index(lab)]) for lab, ix in groups.items()]
