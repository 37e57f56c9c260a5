"""Craig-Bampton (Hurty-Craig-Bampton) reduction, orthogonalised like an Adams flexible body.

Pipeline
--------
1. RBE2 interfaces: every interface patch moves rigidly (6 DOF per patch), as in
   Exudyn's ``FEMinterface.ComputeHurtyCraigBamptonModes(computationMode=RBE2)``.
2. Static (constraint) modes: unit rigid motion of one patch, all others fixed,
   interior statically condensed: ``Psi_i = -K_ii^-1 K_ib T``.
3. Fixed-interface normal modes of ``(K_ii, M_ii)`` up to ``max_frequency_hz``
   (thesis: 300 Hz), by shift-invert Lanczos on the SAME factorisation of ``K_ii``
   (Exudyn's implementation factors ``K_ii`` twice; this is the main speed-up).
4. Orthogonalisation (thesis Section 2.4, eq. 25-26): solve the reduced generalised
   eigenproblem ``K_cb x = w^2 M_cb x``, drop the six rigid-body modes, keep all the
   others (each now has a frequency). The basis is mass-normalised: the reduced mass
   matrix is the identity and the reduced stiffness ``diag(w_i^2)``.

The static modes are kept for all interfaces (``excludeRigidBodyMotion=False``) and the
rigid-body modes removed after orthogonalisation, so that the flexible body in Exudyn
gets its rigid motion from the floating frame only.

The result is a :class:`ReducedBody`: plain arrays, cached on disk by
:mod:`exudyn_study.cache`, turned into an Exudyn ``ObjectFFRFreducedOrder`` by
:mod:`exudyn_study.flexbody`.

References
----------
Craig, R. R., Bampton, M. C. C. (1968). Coupling of substructures for dynamic
analyses. AIAA Journal 6(7), 1313-1319.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .errors import InputError

__all__ = [
    "ReductionSettings",
    "ReducedBody",
    "craig_bampton",
    "rbe2_mapping",
    "patched_full_model_frequencies",
]

log = logging.getLogger(__name__)

TWO_PI = 2.0 * math.pi


@dataclass(frozen=True)
class ReductionSettings:
    """Settings of the Craig-Bampton reduction.

    Parameters
    ----------
    max_frequency_hz : float
        Fixed-interface normal modes up to this frequency are kept (thesis: 300 Hz).
    max_fixed_interface_modes : int
        Upper bound on the number of fixed-interface modes (guards against a
        mis-scaled model asking for thousands).
    rigid_body_tolerance_hz : float
        Orthogonalised modes below this frequency are rigid-body modes and removed;
        exactly six are expected.
    solver : {'ngsolve', 'scipy'}
        Sparse factorisation used for ``K_ii`` (see :mod:`exudyn_study.fe.solvers`).
    """

    max_frequency_hz: float = 300.0
    max_fixed_interface_modes: int = 400
    rigid_body_tolerance_hz: float = 0.5
    solver: str = "ngsolve"

    def __post_init__(self) -> None:
        if not (math.isfinite(self.max_frequency_hz) and self.max_frequency_hz > 0):
            raise InputError(
                f"max_frequency_hz = {self.max_frequency_hz!r}; expected a positive frequency in Hz"
            )
        if self.max_fixed_interface_modes < 0:
            raise InputError(
                f"max_fixed_interface_modes = {self.max_fixed_interface_modes!r}; expected >= 0"
            )
        if self.solver not in ("ngsolve", "scipy"):
            raise InputError(f"solver {self.solver!r}: expected 'ngsolve' or 'scipy'")


@dataclass(frozen=True)
class ReducedBody:
    """An orthogonalised Craig-Bampton flexible body (what an Adams MNF holds).

    Attributes
    ----------
    name : str
    node_positions_m : ndarray, shape (n_nodes, 3)
        Reference positions in body coordinates (m).
    mode_basis : ndarray, shape (3 n_nodes, n_modes)
        Mass-normalised flexible modes, xyz interleaved per node.
    frequencies_hz : ndarray, shape (n_modes,)
        Free-free frequency of each orthogonalised mode, ascending.
    surface_triangles : ndarray of int, shape (n_tri, 6) or (n_tri, 3)
        For drawing.
    interface_names : tuple of str
    interface_nodes : tuple of ndarray of int
    interface_weights : tuple of ndarray of float
    interface_centers_m : ndarray, shape (n_interfaces, 3)
    region_nodes : mapping region -> node indices
    region_components : mapping region -> component
    fixed_interface_frequencies_hz : ndarray
        Frequencies of the fixed-interface normal modes that were kept.
    n_static_modes : int
    total_mass_kg : float
    mass_matrix, stiffness_matrix : scipy.sparse.csr_matrix or None
        The full FE matrices, needed once to compute the FFRF inertia integrals; not
        stored in the cache (see :class:`exudyn_study.flexbody.FFRFData`).
    """

    name: str
    node_positions_m: np.ndarray
    mode_basis: np.ndarray
    frequencies_hz: np.ndarray
    surface_triangles: np.ndarray
    interface_names: tuple[str, ...]
    interface_nodes: tuple[np.ndarray, ...]
    interface_weights: tuple[np.ndarray, ...]
    interface_centers_m: np.ndarray
    region_nodes: Mapping[str, np.ndarray]
    region_components: Mapping[str, str]
    fixed_interface_frequencies_hz: np.ndarray
    n_static_modes: int
    total_mass_kg: float
    mass_matrix: sp.csr_matrix | None = field(default=None, repr=False, compare=False)
    stiffness_matrix: sp.csr_matrix | None = field(default=None, repr=False, compare=False)

    @property
    def n_modes(self) -> int:
        """Number of flexible (orthogonalised) modes."""
        return self.mode_basis.shape[1]

    @property
    def n_nodes(self) -> int:
        """Number of mesh nodes."""
        return self.node_positions_m.shape[0]

    def interface_index(self, name: str) -> int:
        """Index of the interface called ``name``.

        Raises
        ------
        InputError
            If the body has no such interface.
        """
        try:
            return self.interface_names.index(name)
        except ValueError:
            raise InputError(
                f"body {self.name!r} has no interface {name!r}; it has {list(self.interface_names)}"
            ) from None

    def component_nodes(self, component: str) -> np.ndarray:
        """Node indices of ``component`` (all its regions)."""
        regions = [r for r, c in self.region_components.items() if c == component]
        if not regions:
            raise InputError(
                f"body {self.name!r} has no component {component!r}; it has "
                f"{sorted(set(self.region_components.values()))}"
            )
        return np.unique(np.concatenate([self.region_nodes[r] for r in regions]))

    def modal_stiffness(self) -> np.ndarray:
        """Diagonal of the reduced stiffness matrix, ``(2 pi f_i)^2`` (1/s^2)."""
        return (TWO_PI * self.frequencies_hz) ** 2


def rbe2_mapping(node_positions_m: np.ndarray, center_m: np.ndarray) -> np.ndarray:
    """Rigid-body map of a patch: 6 patch DOF -> 3 displacements per node.

    ``u_node = t + theta x (p_node - c)`` with ``q = [t, theta]``.

    Parameters
    ----------
    node_positions_m : ndarray, shape (n, 3)
    center_m : ndarray, shape (3,)

    Returns
    -------
    ndarray, shape (3 n, 6)
    """
    d = np.asarray(node_positions_m, dtype=float) - np.asarray(center_m, dtype=float)
    n = d.shape[0]
    t = np.zeros((n, 3, 6))
    t[:, 0, 0] = t[:, 1, 1] = t[:, 2, 2] = 1.0
    # theta x d = [ty*dz - tz*dy, tz*dx - tx*dz, tx*dy - ty*dx]
    t[:, 0, 4], t[:, 0, 5] = d[:, 2], -d[:, 1]
    t[:, 1, 3], t[:, 1, 5] = -d[:, 2], d[:, 0]
    t[:, 2, 3], t[:, 2, 4] = d[:, 1], -d[:, 0]
    return t.reshape(3 * n, 6)


def _check_interfaces(n_nodes: int, interfaces: Sequence) -> None:
    seen: dict[int, str] = {}
    for itf in interfaces:
        if len(itf.node_indices) == 0:
            raise InputError(f"interface {itf.name!r} selects no nodes; check its boundary or region")
        if np.any(itf.node_indices < 0) or np.any(itf.node_indices >= n_nodes):
            raise InputError(f"interface {itf.name!r} refers to nodes outside the mesh (0..{n_nodes - 1})")
        for node in itf.node_indices:
            other = seen.get(int(node))
            if other is not None:
                raise InputError(
                    f"interfaces {other!r} and {itf.name!r} overlap (share node {int(node)}); "
                    "interface node sets must be disjoint"
                )
            seen[int(node)] = itf.name
    if len(interfaces) == 0:
        raise InputError("a Craig-Bampton body needs at least one interface; none was given")


def _fixed_interface_modes(
    k_ii: sp.csr_matrix,
    m_ii: sp.csr_matrix,
    solve: Callable[[np.ndarray], np.ndarray],
    settings: ReductionSettings,
) -> tuple[np.ndarray, np.ndarray]:
    """Eigenpairs of (K_ii, M_ii) below ``max_frequency_hz`` by shift-invert Lanczos."""
    n = k_ii.shape[0]
    lam_max = (TWO_PI * settings.max_frequency_hz) ** 2
    op = spla.LinearOperator((n, n), matvec=solve, dtype=float)
    k = min(40, settings.max_fixed_interface_modes, n - 2)
    while True:
        if k <= 0:
            return np.zeros(0), np.zeros((n, 0))
        vals, vecs = spla.eigsh(k_ii, k=k, M=m_ii, sigma=0.0, OPinv=op, which="LM", tol=1e-10)
        order = np.argsort(vals)
        vals, vecs = vals[order], vecs[:, order]
        if vals[-1] > lam_max or k >= min(settings.max_fixed_interface_modes, n - 2):
            break
        k = min(2 * k, settings.max_fixed_interface_modes, n - 2)
        log.info("fixed-interface modes: increasing the number computed to %d", k)
    keep = vals <= lam_max
    if keep.all() and k >= settings.max_fixed_interface_modes:
        log.warning(
            "fixed-interface modes: hit max_fixed_interface_modes=%d below %.0f Hz",
            k,
            settings.max_frequency_hz,
        )
    return vals[keep], vecs[:, keep]


def craig_bampton(
    fe_model,
    interfaces: Sequence,
    settings: ReductionSettings = ReductionSettings(),
    name: str = "body",
    timings: dict | None = None,
) -> ReducedBody:
    """Reduce an FE model to an orthogonalised Craig-Bampton flexible body.

    Parameters
    ----------
    fe_model : exudyn_study.fe.assembly.FEModel
        Assembled model (positions, sparse ``M`` and ``K``).
    interfaces : sequence of exudyn_study.fe.assembly.Interface
        Disjoint RBE2 patches (nodes, weights, centre).
    settings : ReductionSettings
    name : str
        Name of the body.
    timings : dict, optional
        Filled with the wall time (s) of each step: ``factorisation``, ``static_modes``,
        ``fixed_interface_modes``, ``orthogonalisation``.

    Returns
    -------
    ReducedBody

    Raises
    ------
    InputError
        An interface selects no nodes, interfaces overlap, or there is none.
    """
    from .fe.solvers import factorize_spd

    t_start = time.perf_counter()
    positions = fe_model.node_positions_m
    n_nodes = positions.shape[0]
    n = 3 * n_nodes
    _check_interfaces(n_nodes, interfaces)
    mass = sp.csr_matrix(fe_model.mass_matrix)
    stiffness = sp.csr_matrix(fe_model.stiffness_matrix)

    boundary_dofs = []
    blocks = []
    for itf in interfaces:
        nodes = np.asarray(itf.node_indices, dtype=np.int64)
        boundary_dofs.append((3 * nodes[:, None] + np.arange(3)).ravel())
        blocks.append(rbe2_mapping(positions[nodes], np.asarray(itf.center_m)))
    dof_b = np.concatenate(boundary_dofs)
    t_all = sp.block_diag([sp.csr_matrix(b) for b in blocks], format="csr")  # (n_b, 6 n_itf)
    interior = np.ones(n, dtype=bool)
    interior[dof_b] = False
    dof_i = np.flatnonzero(interior)

    k_ii = stiffness[dof_i][:, dof_i].tocsr()
    m_ii = mass[dof_i][:, dof_i].tocsr()
    k_ib = stiffness[dof_i][:, dof_b].tocsr()

    t0 = time.perf_counter()
    solve = factorize_spd(k_ii, settings.solver)
    t_factor = time.perf_counter() - t0

    t0 = time.perf_counter()
    rhs = -(k_ib @ t_all).toarray()
    static_interior = solve(rhs)
    t_static = time.perf_counter() - t0

    t0 = time.perf_counter()
    lam_fixed, phi_fixed = _fixed_interface_modes(k_ii, m_ii, solve, settings)
    t_eig = time.perf_counter() - t0

    n_static = t_all.shape[1]
    n_fixed = phi_fixed.shape[1]
    psi = np.zeros((n, n_static + n_fixed))
    psi[dof_b, :n_static] = t_all.toarray()
    psi[dof_i, :n_static] = static_interior
    psi[dof_i, n_static:] = phi_fixed

    # orthogonalisation (Adams flexible body): reduced eigenproblem, rigid modes removed
    t0 = time.perf_counter()
    m_cb = psi.T @ (mass @ psi)
    k_cb = psi.T @ (stiffness @ psi)
    m_cb = 0.5 * (m_cb + m_cb.T)
    k_cb = 0.5 * (k_cb + k_cb.T)
    lam, vecs = sla.eigh(k_cb, m_cb)
    freq = np.sqrt(np.abs(lam)) / TWO_PI * np.sign(lam)
    rigid = freq < settings.rigid_body_tolerance_hz
    n_rigid = int(rigid.sum())
    if n_rigid != 6:
        raise InputError(
            f"body {name!r}: {n_rigid} modes below {settings.rigid_body_tolerance_hz} Hz after "
            "orthogonalisation, expected the 6 rigid-body modes; the body may be made of "
            "disconnected parts or a material constant may be wrong"
        )
    basis = psi @ vecs[:, ~rigid]
    frequencies = freq[~rigid]
    t_orth = time.perf_counter() - t0

    if timings is not None:
        timings.update(
            factorisation=t_factor, static_modes=t_static, fixed_interface_modes=t_eig, orthogonalisation=t_orth
        )
    log.info(
        "Craig-Bampton %s: %d DOF, %d static + %d fixed-interface modes -> %d flexible; "
        "factor %.1fs static %.1fs eig %.1fs orth %.1fs (total %.1fs)",
        name, n, n_static, n_fixed, basis.shape[1], t_factor, t_static, t_eig, t_orth,
        time.perf_counter() - t_start,
    )
    return ReducedBody(
        name=name,
        node_positions_m=positions,
        mode_basis=basis,
        frequencies_hz=frequencies,
        surface_triangles=np.asarray(fe_model.surface_triangles),
        interface_names=tuple(itf.name for itf in interfaces),
        interface_nodes=tuple(np.asarray(itf.node_indices) for itf in interfaces),
        interface_weights=tuple(np.asarray(itf.node_weights) for itf in interfaces),
        interface_centers_m=np.array([np.asarray(itf.center_m, dtype=float) for itf in interfaces]),
        region_nodes=dict(fe_model.region_nodes),
        region_components=dict(fe_model.region_components),
        fixed_interface_frequencies_hz=np.sqrt(np.maximum(lam_fixed, 0.0)) / TWO_PI,
        n_static_modes=n_static,
        total_mass_kg=fe_model.total_mass_kg,
        mass_matrix=mass,
        stiffness_matrix=stiffness,
    )


def patched_full_model_frequencies(
    fe_model, interfaces: Sequence, n_modes: int = 20, solver: str = "ngsolve"
) -> np.ndarray:
    """Free-free elastic frequencies of the FULL FE model with rigid (RBE2) interface patches.

    The like-for-like reference of a Craig-Bampton body: RBE2 patches stiffen a body, so a
    reduced body is compared with the unreduced model carrying the same rigid patches.
    Every patch is replaced by its 6 rigid DOF (``u_patch = T q``); the interior DOF stay.

    Parameters
    ----------
    fe_model : FEModel
    interfaces : sequence of Interface
    n_modes : int
        Number of elastic modes wanted (the six rigid-body modes are removed).
    solver : {'ngsolve', 'scipy'}

    Returns
    -------
    ndarray, shape (n_modes,)
        Frequencies in Hz, ascending.
    """
    from .fe.solvers import factorize_spd

    positions = fe_model.node_positions_m
    n = 3 * positions.shape[0]
    _check_interfaces(positions.shape[0], interfaces)
    dof_b, blocks = [], []
    for itf in interfaces:
        nodes = np.asarray(itf.node_indices, dtype=np.int64)
        dof_b.append((3 * nodes[:, None] + np.arange(3)).ravel())
        blocks.append(sp.csr_matrix(rbe2_mapping(positions[nodes], np.asarray(itf.center_m))))
    dof_b = np.concatenate(dof_b)
    rbe2 = sp.block_diag(blocks).tocoo()
    interior = np.setdiff1d(np.arange(n), dof_b)
    rows = np.concatenate([interior, dof_b[rbe2.row]])
    cols = np.concatenate([np.arange(interior.size), interior.size + rbe2.col])
    data = np.concatenate([np.ones(interior.size), rbe2.data])
    t = sp.csr_matrix((data, (rows, cols)), shape=(n, interior.size + rbe2.shape[1]))
    k = (t.T @ fe_model.stiffness_matrix @ t).tocsr()
    m = (t.T @ fe_model.mass_matrix @ t).tocsr()
    shift = -((TWO_PI * 1.0) ** 2)  # below the rigid-body zeros: K - shift M is positive definite
    solve = factorize_spd(k - shift * m, solver)
    op = spla.LinearOperator(k.shape, matvec=solve, dtype=float)
    lam = spla.eigsh(k, k=n_modes + 6, M=m, sigma=shift, OPinv=op, which="LM", return_eigenvectors=False)
    lam = np.sort(lam)[6:]
    return np.sqrt(np.maximum(lam, 0.0)) / TWO_PI
