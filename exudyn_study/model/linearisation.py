"""The rig model linearised by Exudyn, and its damped system modes.

:func:`linearise` asks Exudyn for the linearised, unconstrained ODE2 matrices and the
constraint Jacobian of the assembled model (``ComputeLinearizedSystem``) at the
reference configuration (drive held at zero), projects them into the constraint
null space (``q = N^T z``), and adds two maps of its own:

- the *drive shape* ``r``: the static response of all coordinates to a unit piston
  displacement (the particular solution of the drive constraint made statically
  admissible), so that ``q = r u(t) + N^T z(t)``;
- the *sensor map* ``S``: sensor acceleration (global direction) per unit coordinate
  acceleration, from each body's mode basis at the sensor's mesh node.

:func:`system_modes` solves the undamped and damped eigenproblems of the projected system
and describes each mode by the share of the squared nodal displacement per component.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.linalg as sla

from exudyn_study.bodies.ffrf import skew_columns
from exudyn_study.errors import InputError, StudyError
from exudyn_study.linear.modes import SystemModes
from exudyn_study.linear.system import TWO_PI, LinearSystem


def body_displacement_map(model, body_name: str, nodes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Linear map from a body's ODE2 coordinates to the displacements of mesh ``nodes``.

    Parameters
    ----------
    model : Model
        An assembled model (:func:`~exudyn_study.model.build_model`).
    body_name : str
        Key of ``model.bodies`` (e.g. 'chassis', 'frame', 'rear_foundation').
    nodes : array_like of int, shape (n_nodes,)
        Mesh node indices of the body (its FE mesh numbering).

    Returns
    -------
    indices : ndarray of int
        Global ODE2 indices of the body's coordinates.
    matrix : ndarray, shape (3 len(nodes), len(indices))
        Displacements (xyz interleaved per node) per unit coordinate, at the reference.
    """
    handle = model.bodies[body_name]
    body = handle.body
    mbs = model.mbs
    nodes = np.asarray(nodes, dtype=int)
    rows = (3 * nodes[:, None] + np.arange(3)).ravel()
    if hasattr(handle, "node_map"):  # constant-matrix linear CMS body (element='matrix')
        idx = np.concatenate([np.asarray(mbs.systemData.GetNodeLTGODE2(n), dtype=int)
                              for n in handle.coordinate_nodes])
        return idx, handle.node_map(nodes)
    modal_idx = np.asarray(mbs.systemData.GetNodeLTGODE2(handle.modal_node), dtype=int)
    if model.formulation == "linear":
        from exudyn_study.bodies.linear_body import rigid_body_basis

        data = model.body_data[body_name]
        rigid = rigid_body_basis(data.body, data.ffrf, nodes)
        return modal_idx, np.hstack([rigid, np.asarray(body.mode_basis)[rows]])
    rigid_idx = np.asarray(mbs.systemData.GetNodeLTGODE2(handle.rigid_node), dtype=int)
    x = np.asarray(body.node_positions_m)[nodes] + np.asarray(handle.position_m)
    rigid = np.zeros((rows.size, 7))
    rigid[:, :3] = np.tile(np.eye(3), (nodes.size, 1))
    rigid[:, 4:7] = -2.0 * skew_columns(x.ravel())  # u = 2 e_v x x at the reference (EP)
    return np.concatenate([rigid_idx, modal_idx]), np.hstack([rigid, np.asarray(body.mode_basis)[rows]])


def _component_nodes(model, max_nodes: int = 1500) -> list[tuple[str, str, np.ndarray]]:
    """(body, component, sampled node indices) for every flexible-body component but the foundation."""
    out = []
    for b, handle in model.bodies.items():
        if b == "rear_foundation":
            continue
        comp = model.body_components.get(b)
        body = handle.body
        comps = sorted(set(body.region_components.values())) if comp is None else [comp]
        for c in comps:
            nodes = body.component_nodes(c) if comp is None else np.arange(body.n_nodes)
            step = max(1, nodes.size // max_nodes)
            out.append((b, c, nodes[::step]))
    return out


def _describe(share: dict, direction: dict, threshold: float = 0.3) -> str:
    top = max(share.values())
    parts = [f"{c.replace('_', ' ')} {direction[c].lower()}" for c, v in
             sorted(share.items(), key=lambda kv: -kv[1]) if v >= threshold * top]
    return ", ".join(parts)


def system_modes(model, lin: LinearSystem | None = None, max_frequency_hz: float = 100.0,
                 n_modes: int | None = None) -> SystemModes:
    """Damped and undamped modes of the assembled, constrained model.

    Parameters
    ----------
    model : Model
    lin : LinearSystem, optional
        From :func:`linearise` (computed if None).
    max_frequency_hz : float
        Keep modes up to this natural frequency.
    n_modes : int, optional
        Keep at most this many (lowest) modes.

    Returns
    -------
    SystemModes
    """
    if not (math.isfinite(max_frequency_hz) and max_frequency_hz > 0):
        raise InputError(f"max_frequency_hz {max_frequency_hz!r}; expected a positive frequency in Hz")
    lin = linearise(model) if lin is None else lin
    m, c, k = lin.mass, lin.damping, lin.stiffness
    lam2 = sla.eigh(k, m, eigvals_only=True)
    undamped = np.sqrt(np.clip(lam2, 0.0, None)) / TWO_PI
    n = lin.size
    minv = np.linalg.inv(m)
    a = np.block([[np.zeros((n, n)), np.eye(n)], [-minv @ k, -minv @ c]])
    lam, vec = sla.eig(a)
    osc = lam.imag > 1e-6 * np.abs(lam).max()
    lam, vec = lam[osc], vec[:n, osc]
    fn = np.abs(lam) / TWO_PI
    order = np.argsort(fn)
    keep = order[fn[order] <= max_frequency_hz]
    if n_modes is not None:
        keep = keep[:n_modes]
    lam, vec = lam[keep], vec[:, keep]
    undamped = undamped[undamped > 1e-3]
    undamped = undamped[: lam.size] if undamped.size >= lam.size else undamped
    q_modes = lin.nullspace.T @ vec
    shapes = lin.sensor_map @ q_modes
    scale = shapes[np.argmax(np.abs(shapes), axis=0), np.arange(shapes.shape[1])]
    shapes = shapes / np.where(scale == 0, 1.0, scale)
    shares, dirs, descs = [], [], []
    comp_maps = []
    for b, comp, nodes in _component_nodes(model):
        idx, mat = body_displacement_map(model, b, nodes)
        comp_maps.append((comp, idx, mat, nodes.size))
    for j in range(lam.size):
        share, direction = {}, {}
        for comp, idx, mat, n_nodes in comp_maps:
            u = np.abs(mat @ q_modes[idx, j]).reshape(-1, 3) ** 2
            per_dir = u.sum(axis=0)
            share[comp] = share.get(comp, 0.0) + float(per_dir.sum()) / n_nodes
            direction[comp] = "XYZ"[int(np.argmax(per_dir))]
        total = sum(share.values()) or 1.0
        share = {kk: v / total for kk, v in share.items()}
        shares.append(share)
        dirs.append(direction)
        descs.append(_describe(share, direction))
    return SystemModes(
        undamped_frequency_hz=undamped, frequency_hz=np.abs(lam) / TWO_PI,
        damping_ratio=-lam.real / np.abs(lam), damped_frequency_hz=lam.imag / TWO_PI,
        shapes=shapes, coordinates=vec, energy_share=shares, direction=dirs, descriptions=descs,
        sensor_names=lin.sensor_names)


def _nullspace(jac: np.ndarray, rtol: float = 1e-10) -> np.ndarray:
    """Orthonormal rows spanning the null space of ``jac.T`` (constraint Jacobian jac: n_q x n_ae)."""
    if jac.size == 0:
        return np.eye(jac.shape[0])
    u, s, _ = sla.svd(jac, full_matrices=True)
    rank = int((s > rtol * (s[0] if s.size else 1.0)).sum())
    return u[:, rank:].T


def linearise(model) -> LinearSystem:
    """Linearise an assembled model about its reference configuration (drive at zero).

    Parameters
    ----------
    model : exudyn_study.model.Model
        Assembled (assembled here if not).

    Returns
    -------
    LinearSystem

    Raises
    ------
    StudyError
        If the constrained system is singular (a mechanism left free).
    """
    if not model.assembled:
        model.assemble()
    mbs = model.mbs
    m_full, k_full, d_full, jac, _ = mbs.ComputeLinearizedSystem(
        returnConstraintJacobian=True, returnConstraintNullspace=True, autoAssemble=False)
    m_full, k_full, d_full = (np.asarray(a, dtype=float) for a in (m_full, k_full, d_full))
    jac = np.asarray(jac, dtype=float)  # (n_q, n_ae)
    n_q = m_full.shape[0]
    drive_ae = int(np.asarray(mbs.systemData.GetObjectLTGAE(model.drive.joint))[model.drive.axis])
    # all constraints except the drive: null space of the drive-free motion
    others = np.delete(jac, drive_ae, axis=1)
    others = others[:, np.any(others != 0.0, axis=0)]
    null = _nullspace(jac[:, np.any(jac != 0.0, axis=0)])
    # drive shape: satisfy all constraints with the drive row = 1, statically admissible
    g = jac.T
    e = np.zeros(g.shape[0])
    e[drive_ae] = 1.0
    q_p = np.linalg.lstsq(g, e, rcond=None)[0]
    if not np.allclose(g @ q_p, e, atol=1e-8):
        raise StudyError("linearise: the drive constraint is not independent of the other constraints")
    kz = null @ k_full @ null.T
    try:
        z_p = -np.linalg.solve(kz, null @ k_full @ q_p)
    except np.linalg.LinAlgError:
        raise StudyError("linearise: the constrained stiffness is singular (a free mechanism?)") from None
    r = q_p + null.T @ z_p
    # orient: positive drive lifts the piston
    z_piston = int(np.asarray(mbs.systemData.GetNodeLTGODE2(model.rig.nodes["piston"]))[2])
    if r[z_piston] < 0:
        r = -r
    del others, n_q
    mz = null @ m_full @ null.T
    cz = null @ d_full @ null.T
    mz, cz, kz = (0.5 * (a + a.T) for a in (mz, cz, kz))
    names = tuple(model.sensors)
    s_map = np.zeros((len(names), m_full.shape[0]))
    for i, name in enumerate(names):
        att = model.sensors[name]
        idx, mat = body_displacement_map(model, att.body, np.array([att.node]))
        s_map[i, idx] = att.direction @ mat
    return LinearSystem(
        mass=mz, damping=cz, stiffness=kz, nullspace=null, drive_shape=r,
        b0=null @ k_full @ r, b1=null @ d_full @ r, b2=null @ m_full @ r,
        sensor_map=s_map, sensor_names=names, metadata=dict(model.metadata), full_mass=m_full,
        full_damping=d_full, full_stiffness=k_full)
