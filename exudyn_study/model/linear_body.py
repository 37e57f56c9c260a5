"""A flexible body for small motions: linear component-mode synthesis in Exudyn.

The rig moves the chassis by fractions of a millimetre and milliradians. For such motion
the floating-frame (FFRF) formulation of :func:`exudyn_study.flexbody.add_flexible_body`
linearises to a constant mass matrix; its configuration-dependent inertia terms
(``mPsiTildePsi`` ..., quadratic velocity vector) cost time in every Newton iteration and
change nothing measurable. A *linear CMS body* keeps the floating frame fixed at the
reference and adds the six rigid-body modes to the mode basis: all motion is modal,
the reduced mass matrix is the identity, stiffness ``diag(0, ..., 0, w_i^2)`` and damping
``diag(0, ..., 0, 2 zeta_i w_i)`` - exactly the linearised FFRF body, with
``ObjectFFRFreducedOrder`` with the frame fixed and zero rigid-flexible coupling integrals.

Interfaces and mesh-node markers work as for the FFRF body (``MarkerSuperElementRigid``,
``MarkerSuperElementPosition``).
"""

from __future__ import annotations

import logging
from collections.abc import Sequence

import numpy as np

from ..flexbody import FFRFData, FlexibleBodyHandle, modal_damping_matrix, skew_columns
from ..reduction import ReducedBody

__all__ = ["rigid_body_basis", "add_linear_cms_body"]

log = logging.getLogger(__name__)


def rigid_body_basis(body: ReducedBody, ffrf: FFRFData, nodes=None) -> np.ndarray:
    """Mass-normalised rigid-body modes of ``body``, shape (3 n_nodes, 6) (or at ``nodes`` only).

    Translations and rotations about the reference point, ``u_i = t + theta x x_i``,
    made mass-orthonormal with the body's mass, centre of mass and inertia
    (``Psi_r^T M Psi_r = I`` without the full FE mass matrix).
    """
    x = np.asarray(body.node_positions_m, dtype=float)
    if nodes is not None:
        x = x[np.asarray(nodes, dtype=int)]
    n = x.shape[0]
    basis = np.zeros((3 * n, 6))
    basis[:, :3] = np.tile(np.eye(3), (n, 1))
    basis[:, 3:] = -skew_columns(x.ravel())  # theta x x = -skew(x) theta
    m = float(ffrf.mass)
    c = np.asarray(ffrf.center_of_mass, dtype=float)
    sc = np.array([[0.0, -c[2], c[1]], [c[2], 0.0, -c[0]], [-c[1], c[0], 0.0]])
    m_rr = np.block([[m * np.eye(3), -m * sc], [m * sc, np.asarray(ffrf.inertia, dtype=float)]])
    chol = np.linalg.cholesky(0.5 * (m_rr + m_rr.T))
    return np.linalg.solve(chol, basis.T).T  # basis @ L^-T


def add_linear_cms_body(
    mbs,
    body: ReducedBody,
    ffrf: FFRFData,
    damping_ratios: Sequence[float] | np.ndarray,
    ground: int,
    name: str | None = None,
    color: Sequence[float] = (0.2, 0.5, 0.9, 1.0),
) -> FlexibleBodyHandle:
    """Add ``body`` as a linear CMS body (fixed floating frame, rigid modes in the basis).

    Parameters
    ----------
    mbs : exudyn.MainSystem
    body : ReducedBody
    ffrf : FFRFData
        Mass, centre of mass and inertia (for the rigid-body modes).
    damping_ratios : array_like, shape (body.n_modes,)
        Damping ratio per flexible mode; the rigid-body modes are undamped.
    ground : int
        Ground object (the floating frame is fixed to it).
    name : str, optional
    color : RGBA

    Returns
    -------
    FlexibleBodyHandle
        ``modal_node`` holds 6 rigid-body + ``body.n_modes`` flexible coordinates.
    """
    import exudyn as exu
    import exudyn.itemInterface as eii

    name = name or body.name
    damping = modal_damping_matrix(body.frequencies_hz, damping_ratios)
    basis = np.hstack([rigid_body_basis(body, ffrf), np.asarray(body.mode_basis)])
    n_modes = basis.shape[1]
    stiffness = np.concatenate([np.zeros(6), body.modal_stiffness()])
    damp = np.concatenate([np.zeros(6), np.diag(damping)])
    rigid_node = mbs.AddNode(eii.NodeRigidBodyEP(
        name=f"NodeRigidBody:{name}", referenceCoordinates=[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0],
        initialVelocities=[0.0] * 7))
    modal_node = mbs.AddNode(eii.NodeGenericODE2(
        name=f"NodeGeneric:{name}", numberOfODE2Coordinates=n_modes,
        referenceCoordinates=[0.0] * n_modes, initialCoordinates=[0.0] * n_modes,
        initialCoordinates_t=[0.0] * n_modes))

    def container(diag: np.ndarray):
        mc = exu.MatrixContainer()
        mc.SetWithDenseMatrix(np.diag(np.asarray(diag, dtype=float)), useDenseMatrix=False)
        return mc

    tris = np.asarray(body.surface_triangles)
    zeros3 = np.zeros(3)
    obj = mbs.AddObject(eii.ObjectFFRFreducedOrder(
        name=name,
        nodeNumbers=[rigid_node, modal_node],
        massMatrixReduced=container(np.ones(n_modes)),
        stiffnessMatrixReduced=container(stiffness),
        dampingMatrixReduced=container(damp),
        modeBasis=basis,
        referencePositions=np.asarray(body.node_positions_m).ravel(),
        # the frame is fixed: its inertia only keeps the mass matrix regular, and the
        # rigid-flexible coupling integrals are not needed (all motion is modal)
        mass=float(ffrf.mass),
        inertia=np.asarray(ffrf.inertia),
        centerOfMass=zeros3 + np.asarray(ffrf.center_of_mass),
        mPsiTildePsi=np.zeros((3 * n_modes, n_modes)),
        mPsiTildePsiTilde=np.zeros((3 * n_modes, 3 * n_modes)),
        mPhitTPsi=np.zeros((3, n_modes)),
        mPhitTPsiTilde=np.zeros((3, 3 * n_modes)),
        mXRefTildePsi=np.zeros((3, n_modes)),
        mXRefTildePsiTilde=np.zeros((3, 3 * n_modes)),
        computeFFRFterms=True,
        visualization=eii.VObjectFFRFreducedOrder(
            triangleMesh=tris[:, :3] if tris.shape[1] == 6 else tris, color=list(color), showNodes=False),
    ))
    # fix the floating frame to ground (all six coordinates; the EP normalisation is the 7th)
    m_node = mbs.AddMarker(eii.MarkerNodeRigid(nodeNumber=rigid_node))
    m_ground = mbs.AddMarker(eii.MarkerBodyRigid(bodyNumber=ground, localPosition=[0.0, 0.0, 0.0]))
    mbs.AddObject(eii.ObjectJointGeneric(
        name=f"{name}_frame_fixed", markerNumbers=[m_ground, m_node], constrainedAxes=[1] * 6,
        visualization=eii.VObjectJointGeneric(show=False)))
    markers, positions = {}, {}
    for itf_name, nodes, weights in zip(body.interface_names, body.interface_nodes, body.interface_weights, strict=False):
        markers[itf_name] = mbs.AddMarker(eii.MarkerSuperElementRigid(
            bodyNumber=obj, offset=[0.0, 0.0, 0.0], meshNodeNumbers=[int(n) for n in nodes],
            weightingFactors=[float(w) for w in weights]))
        positions[itf_name] = weighted_center(body, itf_name)
    log.info("added linear CMS body %s: 6 rigid + %d flexible modes, %.1f kg", name, body.n_modes, ffrf.mass)
    return FlexibleBodyHandle(
        body=body, object_number=obj, rigid_node=rigid_node, modal_node=modal_node,
        interface_markers=markers, interface_positions_m=positions,
        damping_ratios=np.asarray(damping_ratios, dtype=float), position_m=np.zeros(3))


def weighted_center(body: ReducedBody, interface: str) -> np.ndarray:
    """Weighted centre of an interface patch (where Exudyn's rigid marker sits), m."""
    i = body.interface_index(interface)
    w = np.asarray(body.interface_weights[i], dtype=float)
    x = np.asarray(body.node_positions_m)[np.asarray(body.interface_nodes[i])]
    return (w[:, None] * x).sum(axis=0) / w.sum()
