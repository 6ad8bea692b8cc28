"""The load case as data: material, selectors, supports, loads and ``[toolpath]`` options.

Every dataclass here is frozen and already valid: :mod:`loadpath.loadcase.parse` builds them from the
TOML file of interface.md (version 1) and raises :class:`~loadpath.errors.LoadCaseError` for anything
that does not make sense. Units: mm, N, MPa.
"""

from __future__ import annotations

from dataclasses import dataclass, field

__all__ = [
    "AXES",
    "SIDES",
    "Material",
    "PLA",
    "Selector",
    "SideSelector",
    "BoxSelector",
    "HoleSelector",
    "Support",
    "Load",
    "ToolpathOptions",
    "LoadCase",
]

AXES = ("x", "y", "z")
SIDES = ("x_min", "x_max", "y_min", "y_max", "z_min", "z_max")
BOX_KEYS = SIDES


@dataclass(frozen=True)
class Material:
    """Isotropic linear-elastic material.

    Attributes
    ----------
    youngs_modulus : float, MPa
        ``E > 0``.
    poissons_ratio : float
        ``-1 < nu < 0.5``.
    printed : str or None
        Material card of the printed-part model (``pla``, ``petg``, ``abs``;
        :mod:`loadpath.stiffness.cards`); None: the G-code's filament type.
    """

    youngs_modulus: float = 3500.0
    poissons_ratio: float = 0.35
    printed: str | None = None

    @property
    def E(self) -> float:  # noqa: N802 (the usual symbol)
        """Young's modulus, MPa."""
        return self.youngs_modulus

    @property
    def nu(self) -> float:
        """Poisson's ratio."""
        return self.poissons_ratio


PLA = Material(3500.0, 0.35)
"""The default material of interface.md (PLA)."""


class Selector:
    """Base class of the three ``where = {...}`` forms; each selects part of a part's boundary."""

    def describe(self) -> str:
        """Describe the selector as written, for messages (``side = "x_min", within = 10.0``)."""
        raise NotImplementedError

    @property
    def uses_z(self) -> bool:
        """True when the selector constrains z, so only a 3D analysis can honour it."""
        raise NotImplementedError


@dataclass(frozen=True)
class SideSelector(Selector):
    """Boundary within ``within`` mm of one side of the part's bounding box.

    Attributes
    ----------
    side : {"x_min", "x_max", "y_min", "y_max", "z_min", "z_max"}
    within : float, mm
        ``>= 0``.
    """

    side: str
    within: float

    @property
    def axis(self) -> int:
        """0, 1 or 2 for x, y, z."""
        return AXES.index(self.side[0])

    @property
    def is_max(self) -> bool:
        """True for the ``*_max`` sides."""
        return self.side.endswith("max")

    @property
    def uses_z(self) -> bool:  # noqa: D102
        return self.axis == 2

    def describe(self) -> str:  # noqa: D102
        return f'side = "{self.side}", within = {self.within}'


@dataclass(frozen=True)
class BoxSelector(Selector):
    """Boundary inside an axis-aligned box given by any subset of its six bounds.

    Attributes
    ----------
    lower, upper : (3,) tuple of float, mm
        Bounds; ``-inf`` / ``+inf`` where not given.
    """

    lower: tuple[float, float, float]
    upper: tuple[float, float, float]

    @property
    def uses_z(self) -> bool:  # noqa: D102
        return bool(self.lower[2] > -float("inf") or self.upper[2] < float("inf"))

    def describe(self) -> str:  # noqa: D102
        parts = []
        for i, a in enumerate(AXES):
            if self.lower[i] > -float("inf"):
                parts.append(f"{a}_min = {self.lower[i]}")
            if self.upper[i] < float("inf"):
                parts.append(f"{a}_max = {self.upper[i]}")
        return ", ".join(parts)


@dataclass(frozen=True)
class HoleSelector(Selector):
    """The hole (inner boundary loop) nearest to a point, if it lies within ``radius`` of it.

    A hole "lies within R" of the point when the distance from the point to the hole (0 when the point
    is inside it) is at most R.

    Attributes
    ----------
    near : (2,) tuple of float, mm
    radius : float or None, mm
        ``> 0``; None (``radius`` not given): the nearest hole, if the point lies within the hole's
        own diameter of it (the larger side of its bounding box).
    """

    near: tuple[float, float]
    radius: float | None = None

    @property
    def uses_z(self) -> bool:  # noqa: D102
        return False

    def describe(self) -> str:  # noqa: D102
        if self.radius is None:
            return f"hole_near = [{self.near[0]}, {self.near[1]}]"
        return f"hole_near = [{self.near[0]}, {self.near[1]}], radius = {self.radius}"


@dataclass(frozen=True)
class Support:
    """A support: the selected boundary is held in the listed directions.

    Attributes
    ----------
    name : str
    where : Selector
    fix : tuple of {"x", "y", "z"}
        Directions held (zero displacement), no repeats.
    """

    name: str
    where: Selector
    fix: tuple[str, ...]

    @property
    def fixed_axes(self) -> tuple[int, ...]:
        """The fixed directions as indices 0, 1, 2."""
        return tuple(AXES.index(a) for a in self.fix)


@dataclass(frozen=True)
class Load:
    """A load on the selected boundary: a total force or a pressure.

    Attributes
    ----------
    name : str
    where : Selector
    force : (3,) tuple of float, N, or None
        Total force, spread as a uniform traction over the selected boundary (a bearing load with a
        cosine distribution on the half of a hole that faces the force, for hole selectors).
    pressure : float, MPa, or None
        Pressure normal to the selected boundary (positive pushes into the part).
    """

    name: str
    where: Selector
    force: tuple[float, float, float] | None = None
    pressure: float | None = None

    @property
    def is_bearing(self) -> bool:
        """True for a force on a hole (a pin pressing on the hole)."""
        return self.force is not None and isinstance(self.where, HoleSelector)


@dataclass(frozen=True)
class ToolpathOptions:
    """The optional ``[toolpath]`` section (command-line options win over it).

    Attributes
    ----------
    engine : str or None
        A registered engine (:data:`loadpath.engines.NAMES`: ``"swarm"``, ``"streamlines"``, ``"levelset"``).
    sparse_engine : str or None
        The engine for sparse infill, or ``"auto"`` (:func:`loadpath.engines.for_sparse`).
    pitch : float or None, mm
    K : float or None
        Swarm: weight of stress alignment against even spacing.
    principal : str or None
        ``"max_abs"``, ``"min_abs"``, ``"tensile"``, ``"compressive"`` or ``"alternate"``.
    replace : tuple of str or None
        Infill kinds replaced: any of ``"solid"``, ``"sparse"``, ``"top"``, ``"bottom"``.
    density : str or None
        Where replaced sparse infill puts its plastic: ``"auto"``, ``"energy"``, ``"stack"``,
        ``"failure"`` or ``"uniform"`` (:mod:`loadpath.density`, :mod:`loadpath.plugin.density_choice`).
    sparse_fill : float or None
        Mean fill of the replaced sparse infill, 0-1 (default: the slicer's, same mass).
    """

    engine: str | None = None
    sparse_engine: str | None = None
    pitch: float | None = None
    K: float | None = None  # noqa: N815 (the paper's symbol)
    principal: str | None = None
    replace: tuple[str, ...] | None = None
    density: str | None = None
    sparse_fill: float | None = None


@dataclass(frozen=True)
class LoadCase:
    """A validated load case (interface.md, version 1).

    Attributes
    ----------
    version : int
        Always 1.
    object : str or None
        Name of the object the load case applies to; None: every object, each solved separately.
    frame : {"bed", "part"}
        ``"part"``: coordinates relative to the minimum corner of the object's bounding box.
    material : Material
    supports : tuple of Support
    loads : tuple of Load
    toolpath : ToolpathOptions
    source : str
        Where the load case came from (file name), for messages.
    """

    version: int
    supports: tuple[Support, ...]
    loads: tuple[Load, ...]
    material: Material = PLA
    object: str | None = None
    frame: str = "bed"
    toolpath: ToolpathOptions = field(default_factory=ToolpathOptions)
    source: str = "load case"

    @property
    def needs_3d(self) -> bool:
        """True when the load case has out-of-plane parts only a 3D analysis honours.

        That is: a force with a z component, a support that holds only z, or a selector that
        constrains z.
        """
        for load in self.loads:
            if load.force is not None and load.force[2] != 0.0:
                return True
            if load.where.uses_z:
                return True
        for sup in self.supports:
            if sup.where.uses_z or sup.fix == ("z",):
                return True
        return False
