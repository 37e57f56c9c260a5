"""Second-order solid FE model: mesh -> mass and stiffness matrices (NGsolve).

This module and :mod:`exudyn_study.bodies.fe.chassis` are the only places that import
ngsolve/netgen. The result, :class:`FEModel`, is plain NumPy/SciPy data that the
reduction (Exudyn) and everything downstream use.

Layouts
-------
- nodes: ``node_positions_m[n_nodes, 3]``; node ``i`` is netgen point ``i + 1``;
- degrees of freedom interleaved per node: ``[x0, y0, z0, x1, y1, z1, ...]`` (Exudyn's
  order), so ``M`` and ``K`` are ``(3 n_nodes, 3 n_nodes)`` sparse CSR matrices;
- ``surface_triangles[n_tri, 6]``: the corners, then the mid nodes of edges 0-1, 1-2,
  2-0 (Exudyn's ``Trigs6`` convention); ``surface_boundary[n_tri]`` indexes
  ``boundary_names``.
"""

from __future__ import annotations

import logging
import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from exudyn_study.bodies.materials import material as lookup_material
from exudyn_study.errors import InputError

__all__ = [
    "PartMaterial",
    "FEModel",
    "Interface",
    "assemble",
    "load_mesh",
    "interface_from_boundary",
    "rigid_body_modes",
    "linear_subtriangles",
]

log = logging.getLogger(__name__)

#: Relative size of ``K @ r`` for a rigid-body motion ``r`` above which the assembled
#: stiffness is rejected: a correct assembly gives ~1e-12; a wrong node order ~1.
RIGID_BODY_RESIDUAL_TOL = 1e-6


@dataclass(frozen=True)
class PartMaterial:
    """Material of one mesh region.

    Parameters
    ----------
    region : str
        Material label of the region in the mesh.
    material : str
        Key of :data:`exudyn_study.bodies.materials.MATERIALS`.
    added_mass_kg : float
        Non-structural mass smeared over the region by raising its density (the water
        in a fuel tank, thesis Section 4.3). Must be >= 0.
    component : str
        Component the region belongs to (``'frame'``, ``'tank_left'``, ...), used to
        map nodes and sensors to components.
    """

    region: str
    material: str
    added_mass_kg: float = 0.0
    component: str = ""

    def __post_init__(self) -> None:
        lookup_material(self.material)  # raises InputError on unknown names
        if not (math.isfinite(self.added_mass_kg) and self.added_mass_kg >= 0.0):
            raise InputError(
                f"region {self.region!r}: added_mass_kg = {self.added_mass_kg!r}; "
                "expected a finite value >= 0"
            )


@dataclass(frozen=True)
class Interface:
    """A rigid (RBE2) interface patch of a flexible body.

    Parameters
    ----------
    name : str
        Interface name (``'front_left_drive'``, ...).
    node_indices : ndarray of int, shape (n,)
        Mesh nodes of the patch (0-based).
    node_weights : ndarray of float, shape (n,)
        Surface-area weights, summing to 1.
    center_m : ndarray, shape (3,)
        Weighted centre of the patch in body coordinates (m); the point where a
        joint acts and where a partner marker must sit.
    """

    name: str
    node_indices: np.ndarray
    node_weights: np.ndarray
    center_m: np.ndarray

    def __post_init__(self) -> None:
        if len(self.node_indices) == 0:
            raise InputError(
                f"interface {self.name!r} selects no nodes; check its boundary name or region"
            )
        if len(self.node_indices) != len(self.node_weights):
            raise InputError(f"interface {self.name!r}: node_indices and node_weights differ in length")


@dataclass(frozen=True)
class FEModel:
    """Assembled linear elastic FE model of one body (SI units).

    Attributes
    ----------
    node_positions_m : ndarray, shape (n_nodes, 3)
    mass_matrix : scipy.sparse.csr_matrix, shape (3 n_nodes, 3 n_nodes), kg
    stiffness_matrix : scipy.sparse.csr_matrix, shape (3 n_nodes, 3 n_nodes), N/m
    surface_triangles : ndarray of int, shape (n_tri, 6)
    surface_boundary : ndarray of int, shape (n_tri,)
    boundary_names : tuple of str
    region_nodes : mapping region -> ndarray of node indices
    region_components : mapping region -> component name
    region_mass_kg : mapping region -> mass incl. added mass (kg)
    """

    node_positions_m: np.ndarray
    mass_matrix: sp.csr_matrix
    stiffness_matrix: sp.csr_matrix
    surface_triangles: np.ndarray
    surface_boundary: np.ndarray
    boundary_names: tuple[str, ...]
    region_nodes: Mapping[str, np.ndarray]
    region_components: Mapping[str, str] = field(default_factory=dict)
    region_mass_kg: Mapping[str, float] = field(default_factory=dict)

    @property
    def n_nodes(self) -> int:
        """Number of mesh nodes."""
        return self.node_positions_m.shape[0]

    @property
    def n_dof(self) -> int:
        """Number of displacement degrees of freedom (3 per node)."""
        return 3 * self.n_nodes

    @property
    def total_mass_kg(self) -> float:
        """Total mass from the consistent mass matrix (kg)."""
        ones_x = np.zeros(self.n_dof)
        ones_x[0::3] = 1.0
        return float(ones_x @ (self.mass_matrix @ ones_x))

    def component_nodes(self, component: str) -> np.ndarray:
        """Node indices of all regions that belong to ``component`` (sorted, unique).

        Parameters
        ----------
        component : str
            Component name (a value of ``region_components``, e.g. 'frame', 'tank_left').

        Returns
        -------
        ndarray of int
            Mesh node indices.

        Raises
        ------
        InputError
            If no region belongs to ``component``.
        """
        regions = [r for r, c in self.region_components.items() if c == component]
        if not regions:
            known = sorted(set(self.region_components.values()))
            raise InputError(f"component {component!r} is not in this body; it has {known}")
        return np.unique(np.concatenate([self.region_nodes[r] for r in regions]))


def load_mesh(path: str | os.PathLike):
    """Read a Netgen volume mesh file (``.vol`` or ``.vol.gz``).

    Parameters
    ----------
    path : str or os.PathLike
        The mesh file.

    Returns
    -------
    netgen.meshing.Mesh

    Raises
    ------
    InputError
        If the file does not exist, is not readable or is not a Netgen mesh.
    """
    from netgen.meshing import Mesh as NetgenMesh

    path = os.fspath(path)
    if not os.path.isfile(path):
        raise InputError(f"mesh file {path!r} does not exist; rebuild it with meshes/make_meshes.py")
    if not (path.endswith(".vol") or path.endswith(".vol.gz")):
        raise InputError(f"mesh file {path!r}: expected a Netgen '.vol' or '.vol.gz' file")
    mesh = NetgenMesh()
    try:
        mesh.Load(path)
    except Exception as exc:  # netgen raises plain exceptions on malformed files
        raise InputError(f"mesh file {path!r} could not be read as a Netgen mesh ({exc})") from None
    if mesh.ne == 0:
        raise InputError(f"mesh file {path!r} holds no volume elements; expected a tetrahedral mesh")
    return mesh


def _xyz_interleave_permutation(n_nodes: int) -> np.ndarray:
    """Index map from NGsolve's blocked order (x0..xn, y0..yn, z0..zn) to interleaved."""
    # interleaved dof 3*i + k  <-  blocked dof k*n + i
    i = np.arange(n_nodes)
    return np.stack([i, i + n_nodes, i + 2 * n_nodes], axis=1).ravel()


def rigid_body_modes(node_positions_m: np.ndarray, center_m: Sequence[float] | None = None) -> np.ndarray:
    """Six rigid-body displacement fields (3 translations, 3 small rotations).

    Parameters
    ----------
    node_positions_m : ndarray, shape (n_nodes, 3)
    center_m : sequence of 3 floats, optional
        Centre of the rotations (default: origin).

    Returns
    -------
    ndarray, shape (3 n_nodes, 6), interleaved xyz per node.
    """
    p = np.asarray(node_positions_m, dtype=float)
    if center_m is not None:
        p = p - np.asarray(center_m, dtype=float)
    n = p.shape[0]
    r = np.zeros((n, 3, 6))
    r[:, 0, 0] = r[:, 1, 1] = r[:, 2, 2] = 1.0
    # small rotation about axis a: u = e_a x p
    r[:, 1, 3], r[:, 2, 3] = -p[:, 2], p[:, 1]  # about x
    r[:, 0, 4], r[:, 2, 4] = p[:, 2], -p[:, 0]  # about y
    r[:, 0, 5], r[:, 1, 5] = -p[:, 1], p[:, 0]  # about z
    return r.reshape(3 * n, 6)


def assemble(ngmesh, parts: Sequence[PartMaterial], *, order: int = 2, check: bool = True) -> FEModel:
    """Assemble the mass and stiffness matrices of a linear elastic solid.

    Second-order (10-node) tetrahedra on a mesh that netgen curves to the geometry.

    Parameters
    ----------
    ngmesh : netgen.meshing.Mesh
        First-order volume mesh; it is made second order here (``SecondOrder()``,
        as Exudyn's ``ImportMeshFromNGsolve(meshOrder=2)`` does). The object is
        modified in place.
    parts : sequence of PartMaterial
        One entry per material label of the mesh.
    order : {1, 2}
        Element order (2 recommended; 1 is for convergence studies only).
    check : bool
        Verify that the six rigid-body motions lie in the null space of ``K`` and that
        ``M`` is symmetric (cheap; catches a wrong node order).

    Returns
    -------
    FEModel

    Raises
    ------
    InputError
        If a mesh region has no entry in ``parts`` (or a part names no region), or
        the mesh has no volume elements.
    """
    import ngsolve as ngs

    if order not in (1, 2):
        raise InputError(f"element order {order!r}: expected 1 or 2")
    if ngmesh.ne == 0:
        raise InputError("mesh holds no volume elements; expected a tetrahedral volume mesh")
    if order == 2:
        ngmesh.SecondOrder()
    mesh = ngs.Mesh(ngmesh)
    regions = list(mesh.GetMaterials())
    by_region = {p.region: p for p in parts}
    missing = [r for r in dict.fromkeys(regions) if r not in by_region]
    if missing:
        raise InputError(
            f"mesh regions {missing} have no material; add PartMaterial entries for them"
        )
    unused = [r for r in by_region if r not in regions]
    if unused:
        raise InputError(
            f"parts {unused} name regions that are not in the mesh (it has {sorted(set(regions))})"
        )

    # region volumes, to smear added (non-structural) mass into the density
    volumes = {}
    for region in dict.fromkeys(regions):
        volumes[region] = ngs.Integrate(ngs.CoefficientFunction(1.0), mesh, definedon=mesh.Materials(region))
    density, young, poisson = {}, {}, {}
    region_mass = {}
    for region in dict.fromkeys(regions):
        part = by_region[region]
        mat = lookup_material(part.material)
        density[region] = mat.density_kg_m3 + part.added_mass_kg / volumes[region]
        young[region] = mat.youngs_modulus_pa
        poisson[region] = mat.poisson_ratio
        region_mass[region] = density[region] * volumes[region]

    rho = ngs.CoefficientFunction([density[r] for r in regions])
    e_mod = ngs.CoefficientFunction([young[r] for r in regions])
    nu = ngs.CoefficientFunction([poisson[r] for r in regions])
    mu = e_mod / (2 * (1 + nu))
    lam = e_mod * nu / ((1 + nu) * (1 - 2 * nu))

    if order == 2:
        fes = ngs.NodalFESpace(mesh, order=2) ** 3
    else:
        fes = ngs.VectorH1(mesh, order=1)
    u, v = fes.TnT()
    eps_u, eps_v = ngs.Sym(ngs.Grad(u)), ngs.Sym(ngs.Grad(v))
    bf_k = ngs.BilinearForm(fes, symmetric=False)
    bf_k += (2 * mu * ngs.InnerProduct(eps_u, eps_v) + lam * ngs.Trace(eps_u) * ngs.Trace(eps_v)) * ngs.dx
    bf_m = ngs.BilinearForm(fes, symmetric=False)
    bf_m += rho * u * v * ngs.dx
    with ngs.TaskManager():
        bf_k.Assemble()
        bf_m.Assemble()

    n_nodes = len(ngmesh.Points()) if order == 2 else mesh.nv
    if fes.ndof != 3 * n_nodes:
        raise InputError(
            f"mesh has {n_nodes} nodes but the FE space {fes.ndof // 3}; the mesh may contain "
            "elements other than tetrahedra"
        )
    perm = _xyz_interleave_permutation(n_nodes)
    k_blocked = sp.csr_matrix(bf_k.mat.CSR())
    m_blocked = sp.csr_matrix(bf_m.mat.CSR())
    stiffness = k_blocked[perm][:, perm].tocsr()
    mass = m_blocked[perm][:, perm].tocsr()
    stiffness.sum_duplicates()
    mass.sum_duplicates()

    positions = np.array(ngmesh.Coordinates(), dtype=float)[:n_nodes]

    # surface triangles (6-node, Exudyn's order) and their boundary labels
    surf = ngmesh.Elements2D().NumPy()
    nodes6 = np.asarray(surf["nodes"], dtype=np.int64) - 1
    if order == 2:
        # netgen order: corners, then the mid nodes of edges (1-2, 0-2, 0-1) -> Exudyn: 0-1, 1-2, 2-0
        tri6 = nodes6[:, [0, 1, 2, 5, 3, 4]]
    else:
        tri6 = nodes6[:, :3]
    boundary_names = tuple(mesh.GetBoundaries())
    surface_boundary = np.asarray(surf["index"], dtype=np.int64) - 1

    vol = ngmesh.Elements3D().NumPy()
    el_nodes = np.asarray(vol["nodes"], dtype=np.int64)
    el_np = np.asarray(vol["np"], dtype=np.int64) if "np" in vol.dtype.names else None
    el_index = np.asarray(vol["index"], dtype=np.int64) - 1
    n_el_nodes = 10 if order == 2 else 4
    if el_np is not None and np.any(el_np != n_el_nodes):
        raise InputError("mesh contains volume elements that are not tetrahedra; expected tets only")
    el_nodes = el_nodes[:, :n_el_nodes] - 1
    region_nodes = {}
    for region_index, region in enumerate(regions):
        sel = el_nodes[el_index == region_index]
        if sel.size:
            region_nodes.setdefault(region, []).append(np.unique(sel))
    region_nodes = {r: np.unique(np.concatenate(v)) for r, v in region_nodes.items()}

    model = FEModel(
        node_positions_m=positions,
        mass_matrix=mass,
        stiffness_matrix=stiffness,
        surface_triangles=tri6,
        surface_boundary=surface_boundary,
        boundary_names=boundary_names,
        region_nodes=region_nodes,
        region_components={r: (by_region[r].component or r) for r in region_nodes},
        region_mass_kg=region_mass,
    )
    if check:
        _check_model(model)
    log.info("assembled %d nodes (%d DOF), %.1f kg", model.n_nodes, model.n_dof, model.total_mass_kg)
    return model


def _check_model(model: FEModel) -> None:
    """Invariants of a correct assembly: rigid motions are stress free, M symmetric."""
    rb = rigid_body_modes(model.node_positions_m, model.node_positions_m.mean(axis=0))
    k_rb = model.stiffness_matrix @ rb
    scale = abs(model.stiffness_matrix).max() * np.abs(rb).max(axis=0)
    residual = np.abs(k_rb).max(axis=0) / scale
    if np.any(residual > RIGID_BODY_RESIDUAL_TOL):
        raise AssertionError(
            f"assembled stiffness is not stress free under rigid-body motion (residuals {residual}); "
            "node order of the FE space and the mesh points disagree"
        )
    asym = abs(model.mass_matrix - model.mass_matrix.T).max() / abs(model.mass_matrix).max()
    if asym > 1e-10:
        raise AssertionError(f"assembled mass matrix is not symmetric (relative {asym:.1e})")


def linear_subtriangles(triangles: np.ndarray) -> np.ndarray:
    """Split 6-node triangles (corners, mid nodes 0-1, 1-2, 2-0) into four 3-node triangles.

    Parameters
    ----------
    triangles : ndarray of int, shape (n, 6) or (n, 3)
        3-node triangles are returned unchanged.

    Returns
    -------
    ndarray of int, shape (4 n, 3) or (n, 3)
    """
    triangles = np.asarray(triangles)
    if triangles.shape[1] != 6:
        return triangles
    c0, c1, c2, m01, m12, m20 = (triangles[:, k] for k in range(6))
    return np.concatenate(
        [np.stack(t, axis=1) for t in ((c0, m01, m20), (m01, c1, m12), (m01, m12, m20), (m20, m12, c2))]
    )


def _triangle_node_weights(model: FEModel, tri_mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Nodes and area weights of selected surface triangles (each 6-node triangle split in 4)."""
    sub = linear_subtriangles(model.surface_triangles[tri_mask])
    p = model.node_positions_m
    area = 0.5 * np.linalg.norm(np.cross(p[sub[:, 1]] - p[sub[:, 0]], p[sub[:, 2]] - p[sub[:, 0]]), axis=1)
    nodes, inverse = np.unique(sub.ravel(), return_inverse=True)
    weights = np.bincount(inverse, weights=np.repeat(area / 3.0, 3), minlength=len(nodes))
    return nodes, weights


def interface_from_boundary(model: FEModel, boundary: str, name: str | None = None) -> Interface:
    """Interface patch made of all nodes on the named boundary faces.

    Parameters
    ----------
    model : FEModel
    boundary : str
        Boundary (face) label in the mesh.
    name : str, optional
        Interface name (default: the boundary label).

    Returns
    -------
    Interface
        Nodes, area weights (normalised to 1) and the weighted centre.

    Raises
    ------
    InputError
        If no surface triangle carries the label ``boundary``.
    """
    name = name or boundary
    labels = np.array(model.boundary_names, dtype=object)
    match = np.flatnonzero(labels == boundary)
    tri_mask = np.isin(model.surface_boundary, match)
    if not tri_mask.any():
        known = sorted({b for b in model.boundary_names if b and b != "default"})
        raise InputError(
            f"interface {name!r}: boundary {boundary!r} selects no nodes; the mesh has boundaries {known}"
        )
    nodes, weights = _triangle_node_weights(model, tri_mask)
    weights = weights / weights.sum()
    center = weights @ model.node_positions_m[nodes]
    return Interface(name=name, node_indices=nodes, node_weights=weights, center_m=center)
