"""Helpers of the catalogue entries for placing Exudyn items on a flexible body's mesh nodes."""

from __future__ import annotations

import numpy as np

from exudyn_study.errors import InputError


def require_super_element(handle, body_name: str, what: str) -> None:
    """Refuse the constant-matrix body (``element='matrix'``) where an entry needs ``what``.

    That element has no mesh nodes and no reduced damping matrix of its own (see
    :func:`exudyn_study.bodies.linear_body.add_linear_matrix_body`).

    Parameters
    ----------
    handle : object
        Handle of the body as stored in ``model.bodies``.
    body_name : str
        Name of the body, for the error message.
    what : str
        What the entry needs of the body (for example "markers on mesh nodes"), for the error message.

    Raises
    ------
    InputError
        If ``handle`` is a constant-matrix body.
    """
    from exudyn_study.bodies.linear_body import MatrixBodyHandle

    if isinstance(handle, MatrixBodyHandle):
        raise InputError(f"body {body_name!r} is a constant-matrix element (element='matrix'), which has no "
                         f"{what}: build the model with element='superelement' for this entry")


def exudyn_mesh_nodes(model, body_name: str, nodes) -> list[int]:
    """Exudyn node indices of mesh ``nodes`` of a flexible body, adding them to the body if needed.

    A linear CMS body built with ``exudyn_mesh='used'`` carries only the nodes its markers and
    sensors use (``handle.mesh_node_map``); missing nodes are appended to its
    ``referencePositions`` and ``modeBasis`` (rigid-body modes and flexible modes at those
    nodes), which leaves the existing markers, sensors and the linearised system unchanged.
    Call before assembly.

    Parameters
    ----------
    model : object
        Rig model (not yet assembled) with ``bodies``, ``body_data`` and ``mbs``.
    body_name : str
        Name of the flexible body in ``model.bodies``.
    nodes : iterable of int
        Mesh node indices of the body.

    Returns
    -------
    list of int
        Exudyn node index of each of ``nodes``, in the same order.

    Raises
    ------
    InputError
        If the body is a constant-matrix element.
    """
    handle = model.bodies[body_name]
    require_super_element(handle, body_name, "markers on mesh nodes")
    nodes = [int(n) for n in nodes]
    node_map = handle.__dict__.get("mesh_node_map")
    if node_map is None:
        return nodes
    missing = [n for n in dict.fromkeys(nodes) if n not in node_map]
    if missing:
        from exudyn_study.bodies.linear_body import node_modal_map

        mbs, obj = model.mbs, handle.object_number
        data = model.body_data[body_name]
        extra = node_modal_map(data.body, data.ffrf, missing)
        basis = np.vstack([np.asarray(mbs.GetObjectParameter(obj, "modeBasis")), extra])
        ref = np.concatenate([np.asarray(mbs.GetObjectParameter(obj, "referencePositions")).ravel(),
                              np.asarray(data.body.node_positions_m)[missing].ravel()])
        mbs.SetObjectParameter(obj, "modeBasis", basis)
        mbs.SetObjectParameter(obj, "referencePositions", ref)
        start = len(node_map)
        for j, n in enumerate(missing):
            node_map[n] = start + j
    return [node_map[n] for n in nodes]


def _spread(x: np.ndarray, count: int) -> np.ndarray:
    """Return the indices of ``count`` well-spread points of ``x`` (farthest-point sampling)."""
    order = [int(np.argmax(np.linalg.norm(x - x.mean(axis=0), axis=1)))]
    dmin = np.linalg.norm(x - x[order[0]], axis=1)
    while len(order) < min(count, x.shape[0]):
        k = int(np.argmax(dmin))
        order.append(k)
        dmin = np.minimum(dmin, np.linalg.norm(x - x[k], axis=1))
    return np.asarray(order)


def _node_set_marker(model, body_name: str, nodes, rigid: bool) -> tuple[int, np.ndarray]:
    """Add a marker averaging mesh ``nodes`` (equal weights); return it and their mean global position."""
    import exudyn.itemInterface as eii

    handle = model.bodies[body_name]
    nodes = np.asarray(nodes, dtype=int)
    local = exudyn_mesh_nodes(model, body_name, nodes)
    w = [1.0 / nodes.size] * nodes.size
    kind = eii.MarkerSuperElementRigid if rigid else eii.MarkerSuperElementPosition
    marker = model.mbs.AddMarker(kind(bodyNumber=handle.object_number, meshNodeNumbers=local,
                                      weightingFactors=w))
    pos = np.asarray(handle.body.node_positions_m)[nodes].mean(axis=0) + np.asarray(handle.position_m)
    return int(marker), pos
