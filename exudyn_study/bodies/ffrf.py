"""Exudyn flexible bodies from reduced bodies: ``ObjectFFRFreducedOrder`` with modal damping.

A :class:`~exudyn_study.bodies.reduction.ReducedBody` holds an orthogonalised, mass-normalised
Craig-Bampton basis, so its reduced mass matrix is the identity and its reduced
stiffness ``diag(omega_i^2)``. Like an MSC Adams flexible body, each mode gets its own
damping ratio ``zeta_i``; the reduced damping matrix is ``diag(2 zeta_i omega_i)``
(thesis eq. 17 with unit modal mass), passed to Exudyn as ``dampingMatrixReduced``.

The floating-frame inertia integrals (``mPsiTildePsi`` ...) are computed once by
Exudyn's ``ObjectFFRFreducedOrderInterface`` from the full mass matrix and kept in
:class:`FFRFData`, which is what the cache stores: building a model from cache needs
neither the FE matrices nor ngsolve.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from exudyn_study.bodies.fe.assembly import linear_subtriangles
from exudyn_study.bodies.reduction import ReducedBody
from exudyn_study.errors import InputError

__all__ = [
    "FFRFData",
    "ffrf_data",
    "skew_columns",
    "modal_damping_matrix",
    "add_flexible_body",
    "FlexibleBodyHandle",
]

log = logging.getLogger(__name__)

#: Arrays of Exudyn's ObjectFFRFreducedOrder that depend only on the body.
FFRF_FIELDS = (
    "mass",
    "inertia",
    "center_of_mass",
    "m_psi_tilde_psi",
    "m_psi_tilde_psi_tilde",
    "m_phit_t_psi",
    "m_phit_t_psi_tilde",
    "m_xref_tilde_psi",
    "m_xref_tilde_psi_tilde",
)


@dataclass(frozen=True)
class FFRFData:
    """Floating-frame inertia terms of a reduced body (Zwölfer and Gerstmayr 2020).

    All arrays in SI units; shapes follow Exudyn's ``ObjectFFRFreducedOrder``. With ``n`` mesh
    nodes and ``m`` modes, ``M`` the FE mass matrix (3n, 3n), ``Psi`` the mode basis (3n, m),
    ``Phit`` the rigid translations (3n, 3), ``X~`` (3n, 3) and ``Psi~`` (3n, 3m) the node-wise
    skew matrices of the reference positions and of the modes (:func:`skew_columns`); the
    products with ``Psi`` carry the mode basis's units.

    Attributes
    ----------
    mass : float
        Total mass ``Phit^T M Phit`` (kg).
    inertia : ndarray, shape (3, 3)
        Inertia tensor about the body's reference point, ``X~^T M X~`` (kg m^2).
    center_of_mass : ndarray, shape (3,)
        Centre of mass in body coordinates (m).
    m_psi_tilde_psi : ndarray, shape (3m, m)
        ``Psi~^T M Psi``.
    m_psi_tilde_psi_tilde : ndarray, shape (3m, 3m)
        ``Psi~^T M Psi~``.
    m_phit_t_psi : ndarray, shape (3, m)
        ``Phit^T M Psi``.
    m_phit_t_psi_tilde : ndarray, shape (3, 3m)
        ``Phit^T M Psi~``.
    m_xref_tilde_psi : ndarray, shape (3, m)
        ``X~^T M Psi`` (kg m times the mode basis's units).
    m_xref_tilde_psi_tilde : ndarray, shape (3, 3m)
        ``X~^T M Psi~``.
    """

    mass: float
    inertia: np.ndarray
    center_of_mass: np.ndarray
    m_psi_tilde_psi: np.ndarray
    m_psi_tilde_psi_tilde: np.ndarray
    m_phit_t_psi: np.ndarray
    m_phit_t_psi_tilde: np.ndarray
    m_xref_tilde_psi: np.ndarray
    m_xref_tilde_psi_tilde: np.ndarray

    def as_arrays(self) -> dict[str, np.ndarray]:
        """Arrays by field name (for the cache)."""
        return {f: np.asarray(getattr(self, f)) for f in FFRF_FIELDS}

    @classmethod
    def from_arrays(cls, arrays) -> FFRFData:
        """Build an :class:`FFRFData` from the arrays of :meth:`as_arrays` (its inverse).

        Parameters
        ----------
        arrays : mapping str -> array_like
            One array per name in :data:`FFRF_FIELDS` (e.g. an opened ``.npz`` file); 'mass' a
            scalar (kg).

        Returns
        -------
        FFRFData
        """
        values = {f: np.asarray(arrays[f]) for f in FFRF_FIELDS}
        values["mass"] = float(values["mass"])
        return cls(**values)


def _fem_interface(body: ReducedBody):
    """Exudyn ``FEMinterface`` holding the body's nodes, surface, matrices and modes."""
    from exudyn.FEM import FEMinterface

    fem = FEMinterface()
    fem.nodes = {"Position": np.asarray(body.node_positions_m)}
    tris = np.asarray(body.surface_triangles)
    surface = {"Name": "meshSurface"}
    surface["Trigs"] = linear_subtriangles(tris)
    if tris.shape[1] == 6:
        surface["Trigs6"] = tris
    fem.surface = [surface]
    fem.massMatrix = body.mass_matrix
    fem.stiffnessMatrix = body.stiffness_matrix
    fem.nodeSets = [
        {"Name": name, "NodeNumbers": nodes, "NodeWeights": weights, "type": "boundary"}
        for name, nodes, weights in zip(
            body.interface_names, body.interface_nodes, body.interface_weights, strict=False
        )
    ]
    fem.modeBasis = {"matrix": np.asarray(body.mode_basis), "type": "HCBmodes"}
    fem.eigenValues = (2.0 * math.pi * np.asarray(body.frequencies_hz)) ** 2
    return fem


def skew_columns(v: np.ndarray) -> np.ndarray:
    """Node-wise skew matrices of displacement fields (vectorised ``ComputeSkewMatrix``).

    Parameters
    ----------
    v : ndarray, shape (3 n,) or (3 n, m)
        Interleaved xyz fields.

    Returns
    -------
    ndarray, shape (3 n, 3) or (3 n, 3 m)
        Block ``[3 i : 3 i + 3, 3 j : 3 j + 3]`` is ``skew(v[3 i : 3 i + 3, j])`` with
        ``skew(x, y, z) = [[0, -z, y], [z, 0, -x], [-y, x, 0]]``.
    """
    v = np.asarray(v, dtype=float)
    vec = v.ndim == 1
    if vec:
        v = v[:, None]
    n, m = v.shape[0] // 3, v.shape[1]
    comp = v.reshape(n, 3, m)
    out = np.zeros((n, 3, m, 3))
    out[:, 0, :, 1], out[:, 0, :, 2] = -comp[:, 2], comp[:, 1]
    out[:, 1, :, 0], out[:, 1, :, 2] = comp[:, 2], -comp[:, 0]
    out[:, 2, :, 0], out[:, 2, :, 1] = -comp[:, 1], comp[:, 0]
    return out.reshape(3 * n, 3 * m)


def ffrf_data(body: ReducedBody, method: str = "numpy") -> FFRFData:
    """Compute the floating-frame inertia terms of ``body``.

    Parameters
    ----------
    body : ReducedBody
        With its FE mass matrix.
    method : {'numpy', 'exudyn'}
        ``'numpy'``: the formulas of Exudyn's ``ObjectFFRFreducedOrderInterface``,
        vectorised (Exudyn builds the node-wise skew matrices in a Python loop over
        nodes x modes: ~40 s for a 140 k DOF chassis); ``'exudyn'``: Exudyn's class
        itself (the reference in the tests).

    Raises
    ------
    InputError
        If the body carries no FE mass matrix (a body restored from cache already has
        its :class:`FFRFData`).
    """
    if body.mass_matrix is None or body.stiffness_matrix is None:
        raise InputError(f"body {body.name!r} has no FE matrices; FFRF terms need the full mass matrix")
    if method == "exudyn":
        from exudyn.FEM import ObjectFFRFreducedOrderInterface

        cms = ObjectFFRFreducedOrderInterface(_fem_interface(body))
        return FFRFData(
            mass=float(cms.totalMass),
            inertia=np.asarray(cms.inertiaLocal),
            center_of_mass=np.asarray(cms.chiU),
            m_psi_tilde_psi=np.asarray(cms.mPsiTildePsi),
            m_psi_tilde_psi_tilde=np.asarray(cms.mPsiTildePsiTilde),
            m_phit_t_psi=np.asarray(cms.mPhitTPsi),
            m_phit_t_psi_tilde=np.asarray(cms.mPhitTPsiTilde),
            m_xref_tilde_psi=np.asarray(cms.mXRefTildePsi),
            m_xref_tilde_psi_tilde=np.asarray(cms.mXRefTildePsiTilde),
        )
    if method != "numpy":
        raise InputError(f"method {method!r}: expected 'numpy' or 'exudyn'")
    mass_matrix = body.mass_matrix
    psi = np.asarray(body.mode_basis)
    n = body.n_nodes
    phit = np.tile(np.eye(3), (n, 1))  # (3n, 3) rigid translations
    x_ref = np.asarray(body.node_positions_m, dtype=float).ravel()
    x_ref_tilde = skew_columns(x_ref)  # (3n, 3)
    psi_tilde = skew_columns(psi)  # (3n, 3m)
    m_phit = np.asarray(mass_matrix @ phit)
    m_x_tilde = np.asarray(mass_matrix @ x_ref_tilde)
    m_psi = np.asarray(mass_matrix @ psi)
    m_psi_tilde = np.asarray(mass_matrix @ psi_tilde)
    total_mass = float((phit.T @ m_phit)[0, 0])
    return FFRFData(
        mass=total_mass,
        inertia=x_ref_tilde.T @ m_x_tilde,
        center_of_mass=(m_phit.T @ x_ref) / total_mass,
        m_psi_tilde_psi=psi_tilde.T @ m_psi,
        m_psi_tilde_psi_tilde=psi_tilde.T @ m_psi_tilde,
        m_phit_t_psi=m_phit.T @ psi,
        m_phit_t_psi_tilde=m_phit.T @ psi_tilde,
        m_xref_tilde_psi=x_ref_tilde.T @ m_psi,
        m_xref_tilde_psi_tilde=x_ref_tilde.T @ m_psi_tilde,
    )


def modal_damping_matrix(
    frequencies_hz: np.ndarray, damping_ratios: Sequence[float] | np.ndarray
) -> np.ndarray:
    """Diagonal reduced damping matrix ``diag(2 zeta_i omega_i)`` of a mass-normalised body.

    Parameters
    ----------
    frequencies_hz : ndarray, shape (n_modes,)
        Mode frequencies of the flexible body (Hz).
    damping_ratios : array_like, shape (n_modes,)
        Critical damping ratio per mode, each in [0, 1).

    Returns
    -------
    ndarray, shape (n_modes, n_modes), units 1/s.

    Raises
    ------
    InputError
        On a ratio outside [0, 1), NaN, or a length mismatch.
    """
    zeta = np.asarray(damping_ratios, dtype=float)
    freq = np.asarray(frequencies_hz, dtype=float)
    if zeta.shape != freq.shape:
        raise InputError(
            f"damping ratios: got {zeta.size} values for {freq.size} modes; give one ratio per mode"
        )
    bad = ~np.isfinite(zeta) | (zeta < 0.0) | (zeta >= 1.0)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise InputError(
            f"damping ratio of mode {i + 1} ({freq[i]:.2f} Hz) is {zeta[i]!r}; expected a value in [0, 1) "
            "(a fraction of critical damping, e.g. 0.02 for 2 %)"
        )
    return np.diag(2.0 * zeta * 2.0 * math.pi * freq)


@dataclass
class FlexibleBodyHandle:
    """Exudyn item numbers of a flexible body and its interface markers.

    Attributes
    ----------
    body : ReducedBody
    object_number : int
        The ``ObjectFFRFreducedOrder``.
    rigid_node, modal_node : int
        Floating-frame node and modal-coordinate node.
    interface_markers : dict name -> MarkerSuperElementRigid number
    interface_positions_m : dict name -> global position of the patch centre (m)
    damping_ratios : ndarray
        Damping ratio per flexible mode, shape (n_modes,).
    position_m : ndarray, shape (3,)
        Global position of the body's reference frame (m).
    """

    body: ReducedBody
    object_number: int
    rigid_node: int
    modal_node: int
    interface_markers: dict
    interface_positions_m: dict
    damping_ratios: np.ndarray
    position_m: np.ndarray

    def node_marker(self, mbs, node_index: int) -> int:
        """Add (once) and return a ``MarkerSuperElementPosition`` at mesh node ``node_index``.

        Parameters
        ----------
        mbs : exudyn.MainSystem
            The system holding the body.
        node_index : int
            Mesh node index of the body (its FE mesh numbering).

        Returns
        -------
        int
            The marker number (the same one on every call with this node).
        """
        import exudyn as exu

        cache = self.__dict__.setdefault("_node_markers", {})
        if node_index not in cache:
            cache[node_index] = mbs.AddMarker(
                exu.itemInterface.MarkerSuperElementPosition(
                    bodyNumber=self.object_number, meshNodeNumbers=[int(node_index)], weightingFactors=[1.0]
                )
            )
        return cache[node_index]


def add_flexible_body(
    mbs,
    body: ReducedBody,
    ffrf: FFRFData,
    damping_ratios: Sequence[float] | np.ndarray,
    position_m: Sequence[float] = (0.0, 0.0, 0.0),
    name: str | None = None,
    color: Sequence[float] = (0.2, 0.5, 0.9, 1.0),
) -> FlexibleBodyHandle:
    """Add ``body`` to an Exudyn system as an ``ObjectFFRFreducedOrder``.

    Parameters
    ----------
    mbs : exudyn.MainSystem
    body : ReducedBody
    ffrf : FFRFData
    damping_ratios : array_like, shape (n_modes,)
        Damping ratio per flexible mode, in [0, 1).
    position_m : sequence of 3 floats
        Position of the body's reference frame in the global frame (m); body
        coordinates coincide with global coordinates for the default (0, 0, 0).
    name : str, optional
    color : RGBA

    Returns
    -------
    FlexibleBodyHandle
        With a ``MarkerSuperElementRigid`` on every interface patch.
    """
    import exudyn as exu
    import exudyn.itemInterface as eii

    name = name or body.name
    damping = modal_damping_matrix(body.frequencies_hz, damping_ratios)
    n_modes = body.n_modes
    rigid_node = mbs.AddNode(
        eii.NodeRigidBodyEP(
            name=f"NodeRigidBody:{name}",
            referenceCoordinates=list(map(float, position_m)) + [1.0, 0.0, 0.0, 0.0],
            initialVelocities=[0.0] * 7,
        )
    )
    modal_node = mbs.AddNode(
        eii.NodeGenericODE2(
            name=f"NodeGeneric:{name}",
            numberOfODE2Coordinates=n_modes,
            referenceCoordinates=[0.0] * n_modes,
            initialCoordinates=[0.0] * n_modes,
            initialCoordinates_t=[0.0] * n_modes,
        )
    )

    def container(matrix: np.ndarray):
        mc = exu.MatrixContainer()
        mc.SetWithDenseMatrix(np.asarray(matrix, dtype=float), useDenseMatrix=False)
        return mc

    tris = np.asarray(body.surface_triangles)
    obj = mbs.AddObject(
        eii.ObjectFFRFreducedOrder(
            name=name,
            nodeNumbers=[rigid_node, modal_node],
            massMatrixReduced=container(np.eye(n_modes)),
            stiffnessMatrixReduced=container(np.diag(body.modal_stiffness())),
            dampingMatrixReduced=container(damping),
            modeBasis=np.asarray(body.mode_basis),
            referencePositions=np.asarray(body.node_positions_m).ravel(),
            mass=ffrf.mass,
            inertia=ffrf.inertia,
            centerOfMass=ffrf.center_of_mass,
            mPsiTildePsi=ffrf.m_psi_tilde_psi,
            mPsiTildePsiTilde=ffrf.m_psi_tilde_psi_tilde,
            mPhitTPsi=ffrf.m_phit_t_psi,
            mPhitTPsiTilde=ffrf.m_phit_t_psi_tilde,
            mXRefTildePsi=ffrf.m_xref_tilde_psi,
            mXRefTildePsiTilde=ffrf.m_xref_tilde_psi_tilde,
            computeFFRFterms=True,
            visualization=eii.VObjectFFRFreducedOrder(
                triangleMesh=tris[:, :3] if tris.shape[1] == 6 else tris, color=list(color), showNodes=False
            ),
        )
    )
    markers, positions = {}, {}
    offset = np.asarray(position_m, dtype=float)
    for itf_name, nodes, weights, center in zip(
        body.interface_names, body.interface_nodes, body.interface_weights, body.interface_centers_m,
        strict=False,
    ):
        markers[itf_name] = mbs.AddMarker(
            eii.MarkerSuperElementRigid(
                bodyNumber=obj,
                offset=[0.0, 0.0, 0.0],
                meshNodeNumbers=[int(n) for n in nodes],
                weightingFactors=[float(w) for w in weights],
            )
        )
        positions[itf_name] = offset + np.asarray(center, dtype=float)
    log.info("added flexible body %s: %d modes, %.1f kg", name, n_modes, ffrf.mass)
    return FlexibleBodyHandle(
        body=body,
        object_number=obj,
        rigid_node=rigid_node,
        modal_node=modal_node,
        interface_markers=markers,
        interface_positions_m=positions,
        damping_ratios=np.asarray(damping_ratios, dtype=float),
        position_m=offset,
    )
