"""System modal analysis of an assembled rig model via Exudyn's linearisation.

:func:`linearize` asks Exudyn for the linearised, unconstrained ODE2 matrices and the
constraint Jacobian of the assembled model (``ComputeLinearizedSystem``) at the
reference configuration (drive held at zero), projects them into the constraint
null space (``q = N^T z``), and adds two maps of its own:

- the *drive shape* ``r``: the static response of all coordinates to a unit piston
  displacement (the particular solution of the drive constraint made statically
  admissible), so that ``q = r u(t) + N^T z(t)``;
- the *sensor map* ``S``: sensor acceleration (global direction) per unit coordinate
  acceleration, from each body's mode basis at the sensor's mesh node.

:func:`system_modes` solves the undamped (``K phi = w^2 M phi``) and damped (state
space) eigenproblems of the projected system and gives frequencies, damping ratios,
complex shapes at the sensors and a description of which component moves most (share
of the squared nodal displacement per component). :func:`to_modal_model` turns them into
the identification module's :class:`~exudyn_study.identify.model.ModalModel` so that
computed and identified modes can be compared directly (:func:`pair_modes`, MAC and
frequency).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla

from .errors import InputError, StudyError
from .flexbody import skew_columns
from .identify.model import ModalModel, Mode

__all__ = [
    "LinearSystem",
    "SystemModes",
    "linearize",
    "system_modes",
    "to_modal_model",
    "pair_modes",
    "ModePair",
    "body_displacement_map",
]

log = logging.getLogger(__name__)
TWO_PI = 2.0 * math.pi


@dataclass(frozen=True)
class LinearSystem:
    """The linearised, constrained model: ``M z'' + C z' + K z = -b2 u'' - b1 u' - b0 u``.

    With ``q = r u + N^T z`` (``q``: Exudyn's ODE2 coordinates, ``u``: drive displacement)
    and ``b_k = N X r`` for ``X = M, C, K``. Sensor accelerations are ``S q''``.

    Attributes
    ----------
    mass, damping, stiffness : ndarray, shape (n, n)
        Projected matrices (SI).
    nullspace : ndarray, shape (n, n_q)
        Rows span the admissible coordinate increments.
    drive_shape : ndarray, shape (n_q,)
        ``r``, coordinates per metre of drive.
    b0, b1, b2 : ndarray, shape (n,)
        Drive forcing vectors (see above).
    sensor_map : ndarray, shape (n_sensors, n_q)
        ``S``.
    sensor_names : tuple of str
    metadata : dict
    """

    mass: np.ndarray
    damping: np.ndarray
    stiffness: np.ndarray
    nullspace: np.ndarray
    drive_shape: np.ndarray
    b0: np.ndarray
    b1: np.ndarray
    b2: np.ndarray
    sensor_map: np.ndarray
    sensor_names: tuple
    metadata: dict = field(default_factory=dict)
    full_mass: np.ndarray | None = field(default=None, repr=False)  # unprojected (n_q, n_q)
    full_damping: np.ndarray | None = field(default=None, repr=False)
    full_stiffness: np.ndarray | None = field(default=None, repr=False)

    @property
    def size(self) -> int:
        """Number of independent coordinates ``n``."""
        return self.mass.shape[0]

    @property
    def sensor_output(self) -> np.ndarray:
        """``S N^T``, shape (n_sensors, n): sensor accelerations per unit ``z''``."""
        return self.sensor_map @ self.nullspace.T

    @property
    def sensor_drive(self) -> np.ndarray:
        """``S r``, shape (n_sensors,): sensor accelerations per unit ``u''`` (rigid drive motion)."""
        return self.sensor_map @ self.drive_shape


def body_displacement_map(model, body_name: str, nodes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Linear map from a body's ODE2 coordinates to the displacements of mesh ``nodes``.

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
        from .model.linear_body import rigid_body_basis

        data = model.body_data[body_name]
        rigid = rigid_body_basis(data.body, data.ffrf, nodes)
        return modal_idx, np.hstack([rigid, np.asarray(body.mode_basis)[rows]])
    rigid_idx = np.asarray(mbs.systemData.GetNodeLTGODE2(handle.rigid_node), dtype=int)
    x = np.asarray(body.node_positions_m)[nodes] + np.asarray(handle.position_m)
    rigid = np.zeros((rows.size, 7))
    rigid[:, :3] = np.tile(np.eye(3), (nodes.size, 1))
    rigid[:, 4:7] = -2.0 * skew_columns(x.ravel())  # u = 2 e_v x x at the reference (EP)
    return np.concatenate([rigid_idx, modal_idx]), np.hstack([rigid, np.asarray(body.mode_basis)[rows]])


def _nullspace(jac: np.ndarray, rtol: float = 1e-10) -> np.ndarray:
    """Orthonormal rows spanning the null space of ``jac.T`` (constraint Jacobian jac: n_q x n_ae)."""
    if jac.size == 0:
        return np.eye(jac.shape[0])
    u, s, _ = sla.svd(jac, full_matrices=True)
    rank = int((s > rtol * (s[0] if s.size else 1.0)).sum())
    return u[:, rank:].T


def linearize(model) -> LinearSystem:
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
        raise StudyError("linearize: the drive constraint is not independent of the other constraints")
    kz = null @ k_full @ null.T
    try:
        z_p = -np.linalg.solve(kz, null @ k_full @ q_p)
    except np.linalg.LinAlgError:
        raise StudyError("linearize: the constrained stiffness is singular (a free mechanism?)") from None
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


@dataclass(frozen=True)
class SystemModes:
    """Modes of the constrained system, sorted by natural frequency.

    Attributes
    ----------
    undamped_frequency_hz : ndarray, shape (n_modes,)
        From ``K phi = w^2 M phi``.
    frequency_hz : ndarray, shape (n_modes,)
        Natural frequency ``|lambda| / 2 pi`` of each damped pole (oscillatory poles only).
    damping_ratio : ndarray, shape (n_modes,)
        ``-Re(lambda) / |lambda|``.
    damped_frequency_hz : ndarray
        ``Im(lambda) / 2 pi``.
    shapes : ndarray, complex, shape (n_sensors, n_modes)
        Damped mode shapes (displacement) at the sensors, largest coefficient 1.
    coordinates : ndarray, complex, shape (n, n_modes)
        Damped mode shapes in the projected coordinates ``z``.
    energy_share : list of dict component -> share (sums to 1)
    direction : list of dict component -> 'X'|'Y'|'Z' (dominant direction)
    descriptions : list of str
    sensor_names : tuple of str
    """

    undamped_frequency_hz: np.ndarray
    frequency_hz: np.ndarray
    damping_ratio: np.ndarray
    damped_frequency_hz: np.ndarray
    shapes: np.ndarray
    coordinates: np.ndarray
    energy_share: list
    direction: list
    descriptions: list
    sensor_names: tuple


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
        From :func:`linearize` (computed if None).
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
    lin = linearize(model) if lin is None else lin
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


def to_modal_model(modes: SystemModes, metadata: dict | None = None) -> ModalModel:
    """The modes as a :class:`~exudyn_study.identify.model.ModalModel` (modes JSON schema)."""
    out = []
    for j in range(modes.frequency_hz.size):
        shape = {n: complex(modes.shapes[i, j]) for i, n in enumerate(modes.sensor_names)}
        out.append(Mode(frequency_hz=float(modes.frequency_hz[j]),
                        damping_ratio=float(min(modes.damping_ratio[j], 0.999999)),
                        shape=shape, description=modes.descriptions[j]))
    meta = {"source": "exudyn_study.modal"}
    meta.update(metadata or {})
    return ModalModel(tuple(out), meta)


@dataclass(frozen=True)
class ModePair:
    """A model mode paired with a reference (identified) mode."""

    model_index: int
    reference_index: int
    mac: float | None
    frequency_error: float  # (f_model - f_ref) / f_ref


def pair_modes(model_modes: ModalModel, reference: ModalModel, min_mac: float = 0.5,
               max_frequency_error: float = 0.3, channels: Sequence[str] | None = None) -> list[ModePair]:
    """Pair model modes with reference modes by MAC and frequency (one-to-one, greedy).

    Candidates need ``MAC >= min_mac`` (when both have shapes on common channels) and a
    relative frequency difference within ``max_frequency_error``; the best MAC (or,
    without shapes, the closest frequency) is paired first.

    Returns
    -------
    list of ModePair, ordered by reference mode.
    """
    from .identify.mac import mac

    if not (0.0 <= min_mac <= 1.0):
        raise InputError(f"min_mac {min_mac!r}; expected a value in [0, 1]")
    fm, fr = model_modes.frequency_hz, reference.frequency_hz
    if channels is None:
        channels = [ch for ch in reference.channels if ch in set(model_modes.channels)]
    channels = list(channels)
    use_shapes = len(channels) >= 2 and len(model_modes) and len(reference)
    macs = mac(model_modes.shapes(channels), reference.shapes(channels)) if use_shapes else None
    ferr = (fm[:, None] - fr[None, :]) / fr[None, :]
    cand = []
    for i in range(fm.size):
        for j in range(fr.size):
            if abs(ferr[i, j]) > max_frequency_error:
                continue
            if macs is not None:
                if macs[i, j] < min_mac:
                    continue
                cand.append((-macs[i, j], abs(ferr[i, j]), i, j))
            else:
                cand.append((abs(ferr[i, j]), 0.0, i, j))
    cand.sort()
    used_i, used_j, pairs = set(), set(), []
    for _, _, i, j in cand:
        if i in used_i or j in used_j:
            continue
        used_i.add(i)
        used_j.add(j)
        pairs.append(ModePair(i, j, None if macs is None else float(macs[i, j]), float(ferr[i, j])))
    return sorted(pairs, key=lambda p: p.reference_index)
