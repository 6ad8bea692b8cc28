"""In-house linear-elastic finite elements (numpy/scipy): plane stress and 3D, quadratic elements.

Typical use::

    from loadpath.loadcase import read, resolve
    from loadpath.fea import analyze

    for rb in resolve(read("case.toml"), bodies):
        a = analyze(rb, pitch=0.45)      # mesh (gmsh), load, rigid-body check, solve
        field = a.field(z=1.1)           # FEStressField of the layer at z = 1.1 mm
        field.sample(points)             # principal stress, direction, validity, ...

Lower level: :func:`stiffness` (per-cell constitutive matrices accepted), :func:`solve` on a
:class:`Problem`, :func:`nodal_stress`, :class:`FEStressField`.
"""

from loadpath.fea.analysis import Analysis, analyze, build_mesh, field_for_layer, stress_scale
from loadpath.fea.assembly import element_stiffness, stiffness
from loadpath.fea.boundary import Facets, check_rigid, facets_of, load_vector, pick, support_dofs
from loadpath.fea.field import FEStressField, field_from_2d, field_from_slice, slice_tets
from loadpath.fea.material import elasticity_matrix, isotropic_3d, plane_stress, rotate_plane_stress
from loadpath.fea.solver import FEAResult, Problem, solve
from loadpath.fea.stress import cell_stress, nodal_stress, principal_3d, von_mises

__all__ = [
    "Analysis",
    "analyze",
    "build_mesh",
    "field_for_layer",
    "stress_scale",
    "stiffness",
    "element_stiffness",
    "Facets",
    "facets_of",
    "pick",
    "support_dofs",
    "load_vector",
    "check_rigid",
    "FEStressField",
    "field_from_2d",
    "field_from_slice",
    "slice_tets",
    "plane_stress",
    "isotropic_3d",
    "elasticity_matrix",
    "rotate_plane_stress",
    "Problem",
    "FEAResult",
    "solve",
    "cell_stress",
    "nodal_stress",
    "von_mises",
    "principal_3d",
]
