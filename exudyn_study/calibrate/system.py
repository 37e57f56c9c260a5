"""The seam between the calibration and a rig model.

A :class:`CalibrationSystem` is an assembled Exudyn system, its flexible-body handles by
name and the sensor points (:class:`SensorPoint`: body, mesh node, measuring direction).
:func:`system_from_model` makes one from a :class:`~exudyn_study.model.Model`; the sensors'
linearised displacements are evaluated by Exudyn itself (central differences).
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from exudyn_study.errors import InputError, StudyError

log = logging.getLogger(__name__)

_AXES = {"X": (1.0, 0.0, 0.0), "Y": (0.0, 1.0, 0.0), "Z": (0.0, 0.0, 1.0)}
#: finite-difference step for the sensor output matrix (coordinates in m, -, sqrt(kg) m)
_FD_STEP = 1e-6


@dataclass(frozen=True)
class SensorPoint:
    """A measuring point: a mesh node of a flexible body and a measuring direction.

    Parameters
    ----------
    body : str
        Name of the flexible body (a key of :attr:`CalibrationSystem.bodies`).
    node : int
        Mesh node index of the body.
    direction : sequence of 3 float
        Measuring direction in global coordinates (normalised on construction).
    """

    body: str
    node: int
    direction: tuple[float, float, float]

    def __post_init__(self) -> None:
        d = np.asarray(self.direction, dtype=float).ravel()
        if d.size != 3 or not np.all(np.isfinite(d)) or np.linalg.norm(d) == 0:
            raise InputError(
                f"sensor on {self.body!r}: direction {self.direction!r}: expected a nonzero 3-vector"
            )
        if int(self.node) < 0:
            raise InputError(f"sensor on {self.body!r}: node {self.node!r}: expected a mesh node index >= 0")
        object.__setattr__(self, "node", int(self.node))
        object.__setattr__(self, "direction", tuple(float(v) for v in d / np.linalg.norm(d)))


@dataclass(frozen=True)
class CalibrationSystem:
    """An assembled Exudyn system with named flexible bodies and sensors.

    Parameters
    ----------
    mbs : exudyn.MainSystem
        Assembled, in the configuration to linearise about (its initial state).
    bodies : mapping str -> exudyn_study.bodies.ffrf.FlexibleBodyHandle
        The flexible bodies whose modal damping is calibrated (others may exist in ``mbs``;
        their damping stays as built).
    sensors : mapping str -> SensorPoint
        Measuring points, named like the target's shape channels.
    owner : object, optional
        Whatever must stay alive for ``mbs`` to stay valid (its ``exudyn.SystemContainer``
        or the rig's model object).
    """

    mbs: object
    bodies: Mapping[str, object]
    sensors: Mapping[str, SensorPoint] = field(default_factory=dict)
    owner: object = field(default=None, repr=False, compare=False)


def _reduced_damping(mbs, handle) -> np.ndarray:
    """Return the body's reduced damping matrix as held by Exudyn (dense, modal-node size)."""
    value = mbs.GetObjectParameter(handle.object_number, "dampingMatrixReduced")
    if hasattr(value, "Convert2DenseMatrix"):
        return np.atleast_2d(np.asarray(value.Convert2DenseMatrix(), float))
    if isinstance(value, Mapping):
        n = int(value.get("numberOfRows", 0))
        out = np.zeros((n, n))
        for i, j, v in np.asarray(value.get("triplets", []), float).reshape(-1, 3):
            out[int(i), int(j)] += v
        return out
    return np.atleast_2d(np.asarray(value, float))


def _modal_coordinates(mbs, handle) -> np.ndarray:
    """Return the global ODE2 indices of the modal node; the body's flexible modes are the last ``n_modes``.

    (An FFRF body's modal node holds its flexible modes only; the rig's linear CMS body
    puts six rigid-body modes first.)
    """
    import exudyn as exu

    count = len(np.atleast_1d(mbs.GetNodeOutput(handle.modal_node, exu.OutputVariableType.Coordinates)))
    if count < handle.body.n_modes:
        raise InputError(
            f"body {handle.body.name!r}: modal node has {count} coordinates < {handle.body.n_modes} modes"
        )
    return mbs.GetNodeODE2Index(handle.modal_node) + np.arange(count)


def _sensor_matrix(mbs, bodies, sensors: Mapping[str, SensorPoint]) -> np.ndarray:
    """Linearised sensor displacements per ODE2 coordinate, by central differences in Exudyn."""
    import exudyn as exu

    cur = exu.ConfigurationType.Current
    pos_type = exu.OutputVariableType.Position
    q0 = np.array(mbs.systemData.GetODE2Coordinates(configuration=cur), float)
    out = np.zeros((len(sensors), q0.size))
    names = list(sensors)
    by_body: dict[str, list[int]] = {}
    for k, s in enumerate(sensors.values()):
        by_body.setdefault(s.body, []).append(k)
    try:
        for body, rows in by_body.items():
            h = bodies[body]
            coords = []
            for node in (h.rigid_node, h.modal_node):
                start = mbs.GetNodeODE2Index(node)
                count = len(np.atleast_1d(mbs.GetNodeOutput(node, exu.OutputVariableType.Coordinates)))
                coords.extend(range(start, start + count))
            for c in coords:
                col = []
                for sign in (1.0, -1.0):
                    q = q0.copy()
                    q[c] += sign * _FD_STEP
                    mbs.systemData.SetODE2Coordinates(q, configuration=cur)
                    col.append(
                        [
                            mbs.GetObjectOutputSuperElement(
                                h.object_number, pos_type, sensors[names[k]].node, configuration=cur
                            )
                            for k in rows
                        ]
                    )
                diff = (np.asarray(col[0], float) - np.asarray(col[1], float)) / (2 * _FD_STEP)
                for j, k in enumerate(rows):
                    out[k, c] = diff[j] @ np.asarray(sensors[names[k]].direction)
    finally:
        mbs.systemData.SetODE2Coordinates(q0, configuration=cur)
    return out


def system_from_model(model) -> CalibrationSystem:
    """Adapt a rig model (``exudyn_study.model.build_model``) to a :class:`CalibrationSystem`.

    Expects ``model.mbs`` (assembled), ``model.bodies`` (name -> FlexibleBodyHandle) and
    ``model.sensors`` (name -> object with a body name ``body``/``component``, a mesh node
    ``node``/``mesh_node``/``node_index`` and a ``direction`` given as a 3-vector or
    'X'/'Y'/'Z'). Sensors that do not fit are skipped with a log message.

    Parameters
    ----------
    model : object
        Rig model as returned by ``exudyn_study.model.build_model``, with the attributes listed
        above.

    Returns
    -------
    CalibrationSystem
        The system over ``model.mbs`` and ``model.bodies``, with the sensors that have a body, a
        mesh node and a direction; ``model`` is kept as its owner.

    Raises
    ------
    StudyError
        If the model lacks ``mbs`` or ``bodies``.
    """
    for attr in ("mbs", "bodies"):
        if not hasattr(model, attr):
            raise StudyError(f"model has no {attr!r}; calibration needs model.mbs and model.bodies")
    sensors = {}
    for name, s in dict(getattr(model, "sensors", {}) or {}).items():
        if isinstance(s, SensorPoint):
            sensors[name] = s
            continue
        body = next((getattr(s, a) for a in ("body", "component") if hasattr(s, a)), None)
        node = next((getattr(s, a) for a in ("node", "mesh_node", "node_index") if hasattr(s, a)), None)
        direction = getattr(s, "direction", None)
        if isinstance(direction, str):
            direction = _AXES.get(direction.upper())
        if body in model.bodies and node is not None and direction is not None:
            sensors[name] = SensorPoint(str(body), int(node), tuple(direction))
        else:
            log.info("sensor %r skipped for calibration shapes (no body/node/direction)", name)
    return CalibrationSystem(model.mbs, dict(model.bodies), sensors, owner=model)


