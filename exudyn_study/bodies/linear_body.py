"""A flexible body for small motions: linear component-mode synthesis in Exudyn.

The rig moves the chassis by fractions of a millimetre and milliradians. For such motion
the floating-frame (FFRF) formulation of :func:`exudyn_study.bodies.ffrf.add_flexible_body`
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
from dataclasses import dataclass, field

import numpy as np

from exudyn_study.bodies.ffrf import FFRFData, FlexibleBodyHandle, modal_damping_matrix, skew_columns
from exudyn_study.bodies.reduction import ReducedBody

__all__ = [
    "rigid_body_basis",
    "add_linear_cms_body",
    "add_linear_matrix_body",
    "MatrixBodyHandle",
    "interface_rigid_map",
    "interface_coordinate_transformation",
    "node_modal_map",
    "small_rigid_motion",
    "marker_node_subset",
    "patch_is_rigid",
]

log = logging.getLogger(__name__)


def small_rigid_motion(positions_m: np.ndarray) -> np.ndarray:
    """Displacements of points at ``positions_m`` (n, 3) per small rigid motion, shape (3 n, 6).

    Columns: translation (x, y, z), then small rotation about the origin: ``u_i = t + theta x x_i``.

    Parameters
    ----------
    positions_m : array_like, shape (n, 3)
        Point positions relative to the rotation centre (m); any shape with 3 n entries.

    Returns
    -------
    ndarray, shape (3 n, 6)
        Displacements (xyz interleaved per point; m per m of translation, m per rad of rotation).
    """
    x = np.asarray(positions_m, dtype=float).reshape(-1, 3)
    g = np.zeros((3 * x.shape[0], 6))
    g[:, :3] = np.tile(np.eye(3), (x.shape[0], 1))
    g[:, 3:] = -skew_columns(x.ravel())  # theta x x = -skew(x) theta
    return g


def rigid_body_basis(body: ReducedBody, ffrf: FFRFData, nodes=None) -> np.ndarray:
    """Mass-normalised rigid-body modes of ``body``, shape (3 n_nodes, 6) (or at ``nodes`` only).

    Translations and rotations about the reference point, ``u_i = t + theta x x_i``,
    made mass-orthonormal with the body's mass, centre of mass and inertia
    (``Psi_r^T M Psi_r = I`` without the full FE mass matrix).

    Parameters
    ----------
    body : ReducedBody
        The body (node positions in body coordinates, m).
    ffrf : FFRFData
        Its mass, centre of mass and inertia.
    nodes : array_like of int, optional
        Mesh node indices whose rows to return (default: every node).

    Returns
    -------
    ndarray, shape (3 n_nodes, 6)
        Nodal displacements (xyz interleaved per node) per unit rigid-body modal coordinate
        (m / sqrt(kg)).
    """
    x = np.asarray(body.node_positions_m, dtype=float)
    if nodes is not None:
        x = x[np.asarray(nodes, dtype=int)]
    basis = small_rigid_motion(x)
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
    for itf_name, nodes, weights in zip(
        body.interface_names, body.interface_nodes, body.interface_weights, strict=False
    ):
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
        patch_nodes = [int(n) for p in patches.values() for n in p[0]]
        used = list(dict.fromkeys([int(n) for n in mesh_nodes] + patch_nodes))
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
    """Return True if the patch ``nodes`` moves as a rigid body (small rotation) in every mode of ``body``.

    Parameters
    ----------
    body : ReducedBody
        The body and its mode basis.
    nodes : array_like of int
        Mesh node indices of the patch.
    rtol : float
        Largest norm of the non-rigid part of the patch's mode displacements, relative to their
        norm, that still counts as rigid.

    Returns
    -------
    bool
    """
    nodes = np.asarray(nodes, dtype=int)
    x = np.asarray(body.node_positions_m)[nodes]
    rel = x - x.mean(axis=0)
    rows = (3 * nodes[:, None] + np.arange(3)).ravel()
    u = np.asarray(body.mode_basis)[rows]
    g = small_rigid_motion(rel)
    coef = np.linalg.lstsq(g, u, rcond=None)[0]
    scale = np.linalg.norm(u)
    return bool(scale == 0.0 or np.linalg.norm(u - g @ coef) <= rtol * scale)


def marker_node_subset(body: ReducedBody, nodes, centre, count: int = 6):
    """Choose a few well-spread nodes of a rigid patch with weights that keep its centre.

    Farthest-point sampling (from the node farthest from the patch centre) picks
    ``count`` nodes, more (up to ``4 count``) if needed; the weights are the smallest
    change of equal weights that puts the weighted centre exactly at ``centre``
    (Exudyn's marker ``offset`` is not carried along with the patch rotation, so the
    centre must come from the nodes) and must stay positive; the nodes must span a
    plane (a rigid marker needs non-collinear nodes). Otherwise the whole patch is
    kept.

    Parameters
    ----------
    body : ReducedBody
        The body (node positions, m).
    nodes : array_like of int
        Mesh node indices of the patch.
    centre : array_like, shape (3,)
        The patch centre the weights must keep (m, body coordinates), e.g. :func:`weighted_center`.
    count : int
        Number of nodes to start from.

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


# ------------------------------------------------------------------------------- constant-matrix element
def interface_rigid_map(body: ReducedBody, ffrf: FFRFData, interface: str, rtol: float = 1e-8) -> np.ndarray:
    """Small rigid motion of an interface patch per unit modal coordinate, shape (6, 6 + n_modes).

    Rows: translation of the patch's weighted centre (m), then small rotation (rad), per
    unit coordinate of the linear CMS body (six rigid-body modes, then the flexible
    modes). The patch must move rigidly in every mode (:func:`patch_is_rigid`); then
    this is exactly the linearised kinematics of Exudyn's ``MarkerSuperElementRigid`` on
    the patch.

    Parameters
    ----------
    body : ReducedBody
        The body, its mode basis and interface patches.
    ffrf : FFRFData
        Its mass, centre of mass and inertia (for the rigid-body modes).
    interface : str
        Interface name (one of ``body.interface_names``).
    rtol : float
        Tolerance of the rigidity check, relative to the norm of the patch's displacements.

    Returns
    -------
    ndarray, shape (6, 6 + n_modes)
        Translation (m) and rotation (rad) per unit linear-CMS coordinate.

    Raises
    ------
    InputError
        If the patch deforms in the mode basis.
    """
    from exudyn_study.errors import InputError

    i = body.interface_index(interface)
    nodes = np.asarray(body.interface_nodes[i], dtype=int)
    w = np.asarray(body.interface_weights[i], dtype=float)
    centre = weighted_center(body, interface)
    u = node_modal_map(body, ffrf, nodes)
    g = small_rigid_motion(np.asarray(body.node_positions_m)[nodes] - centre)
    sw = np.sqrt(np.repeat(w / w.sum(), 3))[:, None]
    coef = np.linalg.lstsq(sw * g, sw * u, rcond=None)[0]
    scale = np.linalg.norm(u)
    if scale > 0.0 and np.linalg.norm(u - g @ coef) > rtol * scale:
        raise InputError(
            f"interface {interface!r} of body {body.name!r} deforms in the mode basis; element='matrix' "
            "needs rigid interface patches (RBE2 reduction): use element='superelement'")
    return coef


def node_modal_map(body: ReducedBody, ffrf: FFRFData, nodes) -> np.ndarray:
    """Displacements of mesh ``nodes`` per unit linear-CMS coordinate, shape (3 len(nodes), 6 + n_modes).

    Parameters
    ----------
    body : ReducedBody
        The body and its mode basis.
    ffrf : FFRFData
        Its mass, centre of mass and inertia (for the rigid-body modes, :func:`rigid_body_basis`).
    nodes : int or array_like of int
        Mesh node indices.

    Returns
    -------
    ndarray, shape (3 len(nodes), 6 + n_modes)
        Rigid-body modes then flexible modes; xyz interleaved per node.
    """
    nodes = np.atleast_1d(np.asarray(nodes, dtype=int))
    rows = (3 * nodes[:, None] + np.arange(3)).ravel()
    return np.hstack([rigid_body_basis(body, ffrf, nodes), np.asarray(body.mode_basis)[rows]])


@dataclass
class MatrixBodyHandle(FlexibleBodyHandle):
    """Handle of a linear CMS body added by :func:`add_linear_matrix_body`.

    ``object_number`` is the ``ObjectGenericODE2`` (no mesh nodes: no super-element
    markers or sensors on it); ``rigid_node`` and ``modal_node`` are -1 (no floating frame,
    and the body's coordinates are not modal, see ``transformation``).

    Attributes
    ----------
    interface_nodes : dict name -> NodeRigidBodyRxyz number
    fixed_interfaces : tuple of str
        Interfaces fixed to ground by eliminating their coordinates (no node, no marker).
    coordinate_nodes : list of int
        Nodes of the body's coordinates, in the object's order (the interface nodes, then
        the ``NodeGenericODE2`` of the remaining coordinates if any).
    transformation : ndarray, shape (n_modal, n_coordinates)
        ``P``: linear-CMS (modal) coordinates = ``P @`` body coordinates.
    ffrf : FFRFData
    """

    interface_nodes: dict = field(default_factory=dict)
    coordinate_nodes: list = field(default_factory=list)
    transformation: np.ndarray | None = field(default=None, repr=False)
    ffrf: FFRFData | None = field(default=None, repr=False)
    fixed_interfaces: tuple = ()

    def node_map(self, nodes) -> np.ndarray:
        """Displacements of mesh ``nodes`` per unit body coordinate, shape (3 len(nodes), n_coordinates).

        Parameters
        ----------
        nodes : int or array_like of int
            Mesh node indices of the body.

        Returns
        -------
        ndarray, shape (3 len(nodes), n_coordinates)
            Displacement (m, xyz interleaved per node) per unit body coordinate (m or rad).
        """
        return node_modal_map(self.body, self.ffrf, nodes) @ self.transformation

    def node_marker(self, mbs, node_index: int) -> int:
        """Add (once) and return a ``MarkerNodePosition`` that moves with mesh node ``node_index``.

        A ``NodePoint`` without mass at the node, its displacement tied to the body's
        coordinates by a constant linear constraint (``ObjectConnectorCoordinateVector``
        on a ``MarkerObjectODE2Coordinates`` of the body).

        Parameters
        ----------
        mbs : exudyn.MainSystem
            The system holding the body.
        node_index : int
            Mesh node index of the body.

        Returns
        -------
        int
            The marker number (the same one on every call with this node).
        """
        import exudyn.itemInterface as eii

        cache = self.__dict__.setdefault("_node_markers", {})
        if node_index not in cache:
            x = np.asarray(self.body.node_positions_m)[int(node_index)] + np.asarray(self.position_m)
            node = mbs.AddNode(eii.NodePoint(name=f"{self.body.name}:node{int(node_index)}",
                                             referenceCoordinates=[float(v) for v in x],
                                             visualization=eii.VNodePoint(show=False)))
            m_node = mbs.AddMarker(eii.MarkerNodeCoordinates(nodeNumber=node))
            m_body = mbs.AddMarker(eii.MarkerObjectODE2Coordinates(objectNumber=self.object_number))
            scaling = self.node_map([node_index])
            # C = S (r_body + q_body) - (x + q_node) - offset = 0 (both markers give reference + displacement)
            offset = scaling @ self._reference_coordinates() - x
            mbs.AddObject(eii.ObjectConnectorCoordinateVector(
                name=f"{self.body.name}:node{int(node_index)}:tie", markerNumbers=[m_node, m_body],
                scalingMarker0=np.eye(3), scalingMarker1=scaling, offset=[float(v) for v in offset]))
            cache[node_index] = mbs.AddMarker(eii.MarkerNodePosition(nodeNumber=node))
        return cache[node_index]

    def _reference_coordinates(self) -> np.ndarray:
        """Return the reference coordinates of the body's nodes in the object's order."""
        ref = [np.r_[self.interface_positions_m[itf], np.zeros(3)] for itf in self.interface_nodes]
        n_rest = self.transformation.shape[1] - 6 * len(self.interface_nodes)
        return np.concatenate(ref + [np.zeros(n_rest)])


def interface_coordinate_transformation(body: ReducedBody, ffrf: FFRFData) -> np.ndarray:
    """``P`` with linear-CMS coordinates ``q = P [y; z]``: ``y`` the interfaces' small rigid motions.

    ``y`` stacks :func:`interface_rigid_map` ``T_k q`` of every interface (6 each, in
    ``body.interface_names`` order); ``z = N^T q`` with ``N`` an orthonormal basis of the
    null space of ``T``. So ``P = [T^+, N]`` (``T^+`` the right pseudo-inverse),
    ``P^-1 = [T; N^T]``. The interface motions must be independent (``T`` of full row rank).

    Parameters
    ----------
    body : ReducedBody
        The body, its mode basis and interface patches.
    ffrf : FFRFData
        Its mass, centre of mass and inertia (for the rigid-body modes).

    Returns
    -------
    ndarray, shape (6 + n_modes, 6 + n_modes)
        ``P = [T^+, N]``.

    Raises
    ------
    InputError
        If an interface patch deforms in the mode basis, or the interface motions are not
        independent in it.
    """
    from exudyn_study.errors import InputError

    t = np.vstack([interface_rigid_map(body, ffrf, itf) for itf in body.interface_names])
    u, sv, vt = np.linalg.svd(t)
    if sv.size < t.shape[0] or sv[-1] < 1e-9 * sv[0]:
        raise InputError(
            f"body {body.name!r}: its {len(body.interface_names)} interfaces' motions are not independent in "
            f"the {t.shape[1]} linear-CMS coordinates; element='matrix' needs them independent: use "
            "element='superelement'")
    t_plus = vt[: t.shape[0]].T @ (u / sv).T  # V S^-1 U^T
    null = vt[t.shape[0]:].T
    return np.hstack([t_plus, null])


def add_linear_matrix_body(
    mbs,
    body: ReducedBody,
    ffrf: FFRFData,
    damping_ratios: Sequence[float] | np.ndarray,
    name: str | None = None,
    fixed_interfaces=(),
) -> MatrixBodyHandle:
    """Add ``body`` as a linear CMS body with constant matrices (``ObjectGenericODE2``).

    The same linear CMS body as :func:`add_linear_cms_body` (six rigid-body modes and the
    flexible modes: mass I, stiffness ``diag(0, w_i^2)``, damping ``diag(0, 2 zeta_i
    w_i)``) in coordinates whose first entries are the interfaces' motions
    (:func:`interface_coordinate_transformation`, ``q = P [y; z]``; mass ``P^T P``,
    stiffness ``P^T K P``, damping ``P^T D P``): each interface patch (rigid in every
    mode) is a ``NodeRigidBodyRxyz`` at its weighted centre whose six coordinates are
    the centre's displacement and, to first order, the patch's small rotation, and the
    joints attach to its ``MarkerNodeRigid``; the remaining coordinates ``z`` sit on a
    ``NodeGenericODE2``. Exudyn does no per-iteration work for the body beyond three
    dense matrix-vector products and no constraints are needed to attach it, where
    ``ObjectFFRFreducedOrder`` rebuilds its mass matrix, FFRF terms and mesh-node
    coordinates in every residual evaluation. The linearised system is that of the
    super-element body (a change of coordinates).

    Parameters
    ----------
    mbs : exudyn.MainSystem
    body : ReducedBody
    ffrf : FFRFData
        Mass, centre of mass and inertia (for the rigid-body modes).
    damping_ratios : array_like, shape (body.n_modes,)
        Damping ratio per flexible mode; the rigid-body modes are undamped.
    name : str, optional
    fixed_interfaces : sequence of str
        Interfaces fixed to ground: their six coordinates are eliminated (the columns of
        ``P`` dropped), the same constrained system as a fixed joint to ground without its
        six equations and the joint's per-step work (the rig's foundation feet).

    Returns
    -------
    MatrixBodyHandle
        ``interface_markers`` are ``MarkerNodeRigid`` on the interface nodes.

    Raises
    ------
    InputError
        If an interface patch deforms in the mode basis or the interfaces' motions are
        not independent.
    """
    import exudyn as exu
    import exudyn.itemInterface as eii

    name = name or body.name
    damping = modal_damping_matrix(body.frequencies_hz, damping_ratios)
    from exudyn_study.errors import InputError

    fixed = tuple(fixed_interfaces)
    unknown = sorted(set(fixed) - set(body.interface_names))
    if unknown:
        raise InputError(f"fixed_interfaces {unknown} are not interfaces of body {body.name!r}; it has "
                         f"{list(body.interface_names)}")
    p = interface_coordinate_transformation(body, ffrf)
    free = [i for i, itf in enumerate(body.interface_names) if itf not in fixed]
    columns = np.r_[np.concatenate([6 * i + np.arange(6) for i in free] + [np.zeros(0, int)]).astype(int),
                    np.arange(6 * len(body.interface_names), p.shape[1])]
    p = p[:, columns]
    stiffness = np.concatenate([np.zeros(6), body.modal_stiffness()])
    damp = np.concatenate([np.zeros(6), np.diag(damping)])

    def container(mat: np.ndarray, dense: bool = True):
        mc = exu.MatrixContainer()
        mc.SetWithDenseMatrix(0.5 * (mat + mat.T), useDenseMatrix=dense)
        return mc

    # mass P^T P = blockdiag((T T^T)^-1, I) exactly (N orthonormal, N^T T^+ = 0): stored sparse
    n_itf = 6 * len(free)
    mass = p.T @ p
    mass[:n_itf, n_itf:] = 0.0
    mass[n_itf:, :n_itf] = 0.0
    mass[n_itf:, n_itf:] = np.eye(p.shape[1] - n_itf)

    nodes, markers, positions = {}, {}, {}
    for itf in body.interface_names:
        centre = weighted_center(body, itf)
        positions[itf] = centre
        if itf in fixed:
            continue
        nodes[itf] = mbs.AddNode(eii.NodeRigidBodyRxyz(
            name=f"{name}:{itf}", referenceCoordinates=[float(v) for v in centre] + [0.0, 0.0, 0.0],
            visualization=eii.VNodeRigidBodyRxyz(show=False)))
        markers[itf] = mbs.AddMarker(eii.MarkerNodeRigid(nodeNumber=nodes[itf]))
    coordinate_nodes = list(nodes.values())
    n_rest = p.shape[1] - 6 * len(nodes)
    if n_rest:
        coordinate_nodes.append(mbs.AddNode(eii.NodeGenericODE2(
            name=f"NodeGeneric:{name}", numberOfODE2Coordinates=n_rest, referenceCoordinates=[0.0] * n_rest,
            initialCoordinates=[0.0] * n_rest, initialCoordinates_t=[0.0] * n_rest)))
    obj = mbs.AddObject(eii.ObjectGenericODE2(
        name=name, nodeNumbers=coordinate_nodes, massMatrix=container(mass, dense=False),
        stiffnessMatrix=container(p.T @ (stiffness[:, None] * p)),
        dampingMatrix=container(p.T @ (damp[:, None] * p)),
        visualization=eii.VObjectGenericODE2(show=False)))
    log.info("added linear CMS body %s as constant matrices: 6 rigid + %d flexible modes, %d interface nodes",
             name, body.n_modes, len(nodes))
    return MatrixBodyHandle(
        body=body, object_number=obj, rigid_node=-1, modal_node=-1, interface_markers=markers,
        interface_positions_m=positions, damping_ratios=np.asarray(damping_ratios, dtype=float),
        position_m=np.zeros(3), interface_nodes=nodes, coordinate_nodes=coordinate_nodes, transformation=p,
        ffrf=ffrf, fixed_interfaces=fixed)
