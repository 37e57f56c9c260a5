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
``MarkerSuperElementPosition``), with one difference that matters for speed: a
``MarkerSuperElementRigid`` evaluates every node of its patch (position, velocity,
weighted rotation, Jacobian) in every Newton iteration, and on the rig the joints'
patches (20-400 nodes each) took ~95 % of the integration time (py-spy, mini frame).
The reduction makes every interface patch move *rigidly* in every mode (RBE2 static
modes, fixed-interface modes vanish on the patch, rigid-body modes), so any few
non-collinear patch nodes give the same marker kinematics. :func:`marker_node_subset`
picks ``marker_nodes`` well-spread nodes (farthest-point sampling) and the marker
``offset`` puts its centre back at the full patch's weighted centre: the linearised
system is unchanged (checked to machine precision) and the integration several times
faster. It is used only when the patch is verified rigid in the mode basis.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence

import numpy as np

from ..flexbody import FFRFData, FlexibleBodyHandle, modal_damping_matrix, skew_columns
from ..reduction import ReducedBody

__all__ = ["rigid_body_basis", "add_linear_cms_body", "marker_node_subset", "patch_is_rigid"]

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
    marker_nodes: int | None = 6,
    mesh_nodes: Sequence[int] | None = None,
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
    marker_nodes : int or None
        Nodes per interface marker (:func:`marker_node_subset`); None: the whole patch.
        A patch that does not move rigidly in the mode basis always keeps all its nodes.
    mesh_nodes : sequence of int, optional
        Give Exudyn only these mesh nodes plus the interface markers' nodes (in that
        order; ``handle.mesh_node_map`` maps mesh index -> Exudyn node). Exudyn's
        super-element markers and sensors evaluate the mesh coordinates from the whole
        mode basis, so a small node set is much cheaper. None: all nodes.

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
    patches = {}
    for itf_name, nodes, weights in zip(body.interface_names, body.interface_nodes, body.interface_weights, strict=False):
        centre = weighted_center(body, itf_name)
        offset = np.zeros(3)
        if marker_nodes is not None and len(nodes) > marker_nodes and patch_is_rigid(body, nodes):
            sub, w_sub, offset = marker_node_subset(body, nodes, centre, marker_nodes)
            if w_sub is not None:
                nodes, weights = sub, w_sub
        patches[itf_name] = (np.asarray(nodes, dtype=int), np.asarray(weights, dtype=float), offset, centre)
    positions_all = np.asarray(body.node_positions_m)
    if mesh_nodes is None:
        node_map = None
        ref_positions, exu_basis = positions_all, basis
    else:
        used = list(dict.fromkeys([int(n) for n in mesh_nodes] + [int(n) for p in patches.values() for n in p[0]]))
        node_map = {n: i for i, n in enumerate(used)}
        rows = (3 * np.asarray(used)[:, None] + np.arange(3)).ravel()
        ref_positions, exu_basis = positions_all[used], basis[rows]
    zeros3 = np.zeros(3)
    obj = mbs.AddObject(eii.ObjectFFRFreducedOrder(
        name=name,
        nodeNumbers=[rigid_node, modal_node],
        massMatrixReduced=container(np.ones(n_modes)),
        stiffnessMatrixReduced=container(stiffness),
        dampingMatrixReduced=container(damp),
        modeBasis=exu_basis,
        referencePositions=np.asarray(ref_positions).ravel(),
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
            triangleMesh=(tris[:, :3] if tris.shape[1] == 6 else tris) if node_map is None else [],
            color=list(color), showNodes=False),
    ))
    # fix the floating frame to ground (all six coordinates; the EP normalisation is the 7th)
    m_node = mbs.AddMarker(eii.MarkerNodeRigid(nodeNumber=rigid_node))
    m_ground = mbs.AddMarker(eii.MarkerBodyRigid(bodyNumber=ground, localPosition=[0.0, 0.0, 0.0]))
    mbs.AddObject(eii.ObjectJointGeneric(
        name=f"{name}_frame_fixed", markerNumbers=[m_ground, m_node], constrainedAxes=[1] * 6,
        visualization=eii.VObjectJointGeneric(show=False)))
    markers, positions = {}, {}
    for itf_name, (nodes, weights, offset, centre) in patches.items():
        local = nodes if node_map is None else [node_map[int(n)] for n in nodes]
        markers[itf_name] = mbs.AddMarker(eii.MarkerSuperElementRigid(
            bodyNumber=obj, offset=[float(v) for v in offset], meshNodeNumbers=[int(n) for n in local],
            weightingFactors=[float(w) for w in weights]))
        positions[itf_name] = centre
    log.info("added linear CMS body %s: 6 rigid + %d flexible modes, %.1f kg", name, body.n_modes, ffrf.mass)
    handle = FlexibleBodyHandle(
        body=body, object_number=obj, rigid_node=rigid_node, modal_node=modal_node,
        interface_markers=markers, interface_positions_m=positions,
        damping_ratios=np.asarray(damping_ratios, dtype=float), position_m=np.zeros(3))
    if node_map is not None:
        handle.mesh_node_map = node_map
    return handle


def weighted_center(body: ReducedBody, interface: str) -> np.ndarray:
    """Weighted centre of an interface patch (where Exudyn's rigid marker sits), m."""
    i = body.interface_index(interface)
    w = np.asarray(body.interface_weights[i], dtype=float)
    x = np.asarray(body.node_positions_m)[np.asarray(body.interface_nodes[i])]
    return (w[:, None] * x).sum(axis=0) / w.sum()


def patch_is_rigid(body: ReducedBody, nodes, rtol: float = 1e-8) -> bool:
    """True if the patch ``nodes`` move as a rigid body (small rotation) in every mode of ``body``."""
    nodes = np.asarray(nodes, dtype=int)
    x = np.asarray(body.node_positions_m)[nodes]
    rel = x - x.mean(axis=0)
    rows = (3 * nodes[:, None] + np.arange(3)).ravel()
    u = np.asarray(body.mode_basis)[rows]
    g = np.zeros((3 * nodes.size, 6))
    g[:, :3] = np.tile(np.eye(3), (nodes.size, 1))
    g[:, 3:] = -skew_columns(rel.ravel())
    coef = np.linalg.lstsq(g, u, rcond=None)[0]
    scale = np.linalg.norm(u)
    return bool(scale == 0.0 or np.linalg.norm(u - g @ coef) <= rtol * scale)


def marker_node_subset(body: ReducedBody, nodes, centre, count: int = 6):
    """A few well-spread nodes of a rigid patch with weights that keep its centre.

    Farthest-point sampling (from the node farthest from the patch centre) picks
    ``count`` nodes, more (up to ``4 count``) if needed; the weights are the smallest
    change of equal weights that puts the weighted centre exactly at ``centre``
    (Exudyn's marker ``offset`` is not carried along with the patch rotation, so the
    centre must come from the nodes) and must stay positive; the nodes must span a
    plane (a rigid marker needs non-collinear nodes). Otherwise the whole patch is
    kept.

    Returns
    -------
    nodes : ndarray of int
    weights : ndarray or None
        None when the whole patch is kept (use its own weights).
    offset : ndarray, shape (3,)
        Always zero (kept for the marker's ``offset`` field).
    """
    nodes = np.asarray(nodes, dtype=int)
    x = np.asarray(body.node_positions_m)[nodes]
    centre = np.asarray(centre, dtype=float)
    order = [int(np.argmax(np.linalg.norm(x - centre, axis=1)))]
    dmin = np.linalg.norm(x - x[order[0]], axis=1)
    while len(order) < min(4 * count, nodes.size):
        k = int(np.argmax(dmin))
        order.append(k)
        dmin = np.minimum(dmin, np.linalg.norm(x - x[k], axis=1))
    scale = max(float(np.ptp(x, axis=0).max()), 1e-12)
    for k in range(min(count, len(order)), len(order) + 1):
        sub = x[order[:k]]
        rel = (sub - centre) / scale
        if np.linalg.svd(rel - rel.mean(axis=0), compute_uv=False)[1] < 1e-3:
            continue
        a = np.vstack([rel.T, np.ones(k)])  # sum w (x - c) = 0, sum w = 1
        w0 = np.full(k, 1.0 / k)
        w = w0 + np.linalg.pinv(a) @ (np.r_[0.0, 0.0, 0.0, 1.0] - a @ w0)
        if w.min() > 0.2 / k and np.linalg.norm(rel.T @ w) * scale < 1e-10:
            return nodes[order[:k]], w, np.zeros(3)
    return nodes, None, np.zeros(3)
