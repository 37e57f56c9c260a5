"""Model variants 1-3 of the thesis on the rig, with the 42 sensors: :func:`build_model`.

- **Model 1**: the chassis assembly as one flexible body, simplified bolted joints
  (thesis Section 4.3);
- **Model 2**: one flexible body, detailed bolted joints (Section 4.4);
- **Model 3**: frame, two fuel tanks and two mudguard brackets as five flexible bodies
  joined at their interface patches by fixed joints (Section 4.5), or by 6-DOF
  spring-damper bushings (:class:`BushingParameters`; the force element the thesis
  recommended as future work).

Every variant sits on the same rig (:mod:`exudyn_study.model.rig`) with the rear
foundation as a flexible body. Damping is a function of each body's mode frequencies
(:mod:`exudyn_study.bodies.damping`), evaluated per body.

The builder returns a :class:`Model`: the Exudyn ``SystemContainer``/``MainSystem``
and named handles (bodies, interfaces, joints, rig parts, sensors, drive). Add your own
Exudyn items to ``model.mbs``, then call :meth:`Model.assemble`.

Body formulation
----------------
``formulation='linear'`` (default) adds each flexible body as a linear CMS body
(:mod:`exudyn_study.bodies.linear_body`: fixed floating frame, rigid-body modes in the
basis), the linearisation of the FFRF body for small motions and several times faster to
integrate; ``'ffrf'`` uses the full floating-frame body of
:func:`exudyn_study.bodies.ffrf.add_flexible_body`. Both have the same linearised system.

The linear formulation has two Exudyn elements (``element``):

- ``'superelement'`` (default): an ``ObjectFFRFreducedOrder`` with its frame fixed
  (:func:`~exudyn_study.bodies.linear_body.add_linear_cms_body`); markers and sensors on
  any mesh node (``MarkerSuperElement*``, ``SensorSuperElement``), as the physics
  entries that attach to node sets or change the body's reduced damping need;
- ``'matrix'``: an ``ObjectGenericODE2`` with the constant mass, stiffness and damping
  matrices (:func:`~exudyn_study.bodies.linear_body.add_linear_matrix_body`) in
  coordinates whose first entries are the interface patches' small rigid motions (one
  rigid node per interface, so no constraints attach the body), and the sensors read
  from the body's coordinate accelerations; the rig's parts on Lie-group nodes (constant mass
  matrices) and the rear foundation's feet fixed by eliminating their coordinates (no
  joints ``foundation_ground_left``/``_right``, no interfaces ``rear_foundation.ground_*``).
  Same linearised system, and the Exudyn time integration
  of Model 1 several times faster (``benchmarks/bench_simulation.py``): the
  super-element rebuilds its mass matrix, FFRF terms and mesh-node coordinates in every
  residual evaluation. Markers at mesh nodes are available through
  ``handle.node_marker`` (a point node tied to the body's coordinates by a constant
  linear constraint), not as super-element markers.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from exudyn_study.bodies.damping import PerBody, damping_function
from exudyn_study.errors import InputError
from exudyn_study.model.rig import (
    FOUNDATION_GROUND_INTERFACES,
    Drive,
    RigHandles,
    RigParameters,
    add_rig,
    generic_joint,
)
from exudyn_study.model.sensors import SENSORS, Sensor
from exudyn_study.model.sensors import sensor as lookup_sensor

__all__ = [
    "VARIANTS",
    "FORMULATIONS",
    "ELEMENTS",
    "BushingParameters",
    "SensorAttachment",
    "InterfaceHandle",
    "Model",
    "build_model",
    "build_model_from_bodies",
    "model_bodies",
]

log = logging.getLogger(__name__)

VARIANTS = (1, 2, 3)
FORMULATIONS = ("linear", "ffrf")
#: Exudyn elements of the linear formulation (see the module docstring)
ELEMENTS = ("superelement", "matrix")
MODEL3_COMPONENTS = ("frame", "tank_left", "tank_right", "bracket_left", "bracket_right")
#: Damping of the rear foundation when the damping choice names no ratio for it.
FOUNDATION_DAMPING_RATIO = 0.02

_DIRECTION = {"X": np.array([1.0, 0.0, 0.0]), "Y": np.array([0.0, 1.0, 0.0]), "Z": np.array([0.0, 0.0, 1.0])}


@dataclass(frozen=True)
class BushingParameters:
    """A 6-DOF linear spring-damper joining two interface patches (Model 3).

    Parameters
    ----------
    stiffness : array_like, shape (6,) or (6, 6)
        Translational (N/m) then rotational (N m/rad) stiffness in the interface frame
        (global axes). A 6-vector is the diagonal.
    damping : array_like, shape (6,) or (6, 6), optional
        Viscous damping (N s/m, N m s/rad); default ``damping_time_s * stiffness``.
    damping_time_s : float
        Stiffness-proportional damping factor used when ``damping`` is None
        (1e-4 s gives ~1.6 % at 50 Hz).

    Notes
    -----
    The defaults (2e7 N/m, 2e5 N m/rad) are of the order of a small bolted bracket joint
    with a rubber-free contact; they are a starting point for calibration, not measured.
    """

    stiffness: Sequence[float] | np.ndarray = (2e7, 2e7, 2e7, 2e5, 2e5, 2e5)
    damping: Sequence[float] | np.ndarray | None = None
    damping_time_s: float = 1e-4

    def matrices(self) -> tuple[np.ndarray, np.ndarray]:
        """(K, D), both (6, 6).

        Raises
        ------
        InputError
            On a wrong shape, a non-finite or negative diagonal entry.
        """
        def as_matrix(v, what):
            a = np.asarray(v, dtype=float)
            if a.shape == (6,):
                a = np.diag(a)
            if a.shape != (6, 6) or not np.all(np.isfinite(a)) or np.any(np.diag(a) < 0):
                raise InputError(f"bushing {what}: expected 6 values >= 0 or a finite 6x6 matrix, got {v!r}")
            return a

        k = as_matrix(self.stiffness, "stiffness")
        if self.damping is None:
            if not (math.isfinite(self.damping_time_s) and self.damping_time_s >= 0):
                raise InputError(f"bushing damping_time_s {self.damping_time_s!r}; expected >= 0 s")
            return k, self.damping_time_s * k
        return k, as_matrix(self.damping, "damping")


def unloaded_joint_markers(mbs, m0: int, m1: int, gap_m) -> tuple[int, int, list[float]]:
    """Markers for a spring-damper across a joint whose two patch centres lie ``gap_m`` apart, and its offset.

    The frame's and a component's patch centres of one joint lie apart (1 cm across the web on
    the thesis chassis). ``ObjectConnectorRigidBodySpringDamper`` pulls its markers together
    (force ``k (A0^T (p1 - p0) - offset)`` at each marker): with the patch markers themselves
    and no offset it is preloaded by ``k`` times the gap (40 MN at 4e9 N/m: a spurious
    geometric stiffness in the linearisation, and that force's round-off in its damping
    matrix); with the gap as offset it is unloaded, but its force acts at two points the gap
    apart (a stiffness not symmetric, of order ``k`` times the gap). So each side gets a copy
    of its super-element marker moved to the mid-point between the centres (Exudyn's marker
    offset moves with the body's reference frame, so each copy moves with its patch centre: the
    5 mm lever of the patch's rotation is left out): no preload, no offset, and the spring and
    damper act on one relative translation ``B`` (the patch centres' relative motion),
    ``K = k B^T B`` and ``C = c B^T B``. Markers of another type (the constant-matrix element's
    interface nodes) are kept, with the gap as offset.

    Parameters
    ----------
    mbs : exudyn MainSystem
    m0, m1 : int
        The two patches' markers (``m1 - m0`` the spring's relative motion).
    gap_m : array_like, shape (3,)
        Position of patch centre 1 minus that of patch centre 0 at the reference (m).

    Returns
    -------
    (marker 0, marker 1, offset [dx, dy, dz, 0, 0, 0])
    """
    import exudyn.itemInterface as eii

    gap = np.asarray(gap_m, dtype=float)
    markers = [mbs.GetMarker(m) for m in (m0, m1)]
    if np.linalg.norm(gap) == 0.0 or any("SuperElementRigid" not in str(m["markerType"]) for m in markers):
        return m0, m1, [float(v) for v in gap] + [0.0, 0.0, 0.0]
    mid = []
    for m, sign in zip(markers, (0.5, -0.5), strict=True):
        mid.append(int(mbs.AddMarker(eii.MarkerSuperElementRigid(
            bodyNumber=m["bodyNumber"], offset=[float(v) for v in np.asarray(m["offset"]) + sign * gap],
            meshNodeNumbers=list(m["meshNodeNumbers"]), weightingFactors=list(m["weightingFactors"]),
            useAlternativeApproach=m["useAlternativeApproach"],
            rotationsExponentialMap=m["rotationsExponentialMap"],
            visualization=eii.VMarkerSuperElementRigid(show=False)))))
    return mid[0], mid[1], [0.0] * 6


@dataclass
class SensorAttachment:
    """Where a rig accelerometer sits in the model.

    Attributes
    ----------
    sensor : Sensor
        Appendix-A data (name, direction, position, component).
    body : str
        Name of the flexible body carrying it.
    node : int
        Mesh node (nearest surface node of the sensor's component).
    distance_m : float
        Distance from the table position to that node.
    direction : ndarray, shape (3,)
        Unit measuring direction (global).
    exudyn_sensor : int or None
        ``SensorSuperElement`` (acceleration, 3 components) of that node; with
        ``coordinate_map``: the ``SensorBody`` of the body's coordinate accelerations.
    coordinate_map : ndarray, shape (3, n_coordinates), or None
        Acceleration of the node per unit coordinate acceleration of the body
        (``element='matrix'``: the node's acceleration is ``coordinate_map @ q_tt``).
    """

    sensor: Sensor
    body: str
    node: int
    distance_m: float
    direction: np.ndarray
    exudyn_sensor: int | None = None
    coordinate_map: np.ndarray | None = field(default=None, repr=False)

    @property
    def component_index(self) -> int:
        """0, 1, 2 for X, Y, Z."""
        return "XYZ".index(self.sensor.direction)


@dataclass
class InterfaceHandle:
    """An interface patch of a flexible body: its rigid marker and global centre (m).

    Attributes
    ----------
    body : str
        Name of the flexible body carrying the patch (a key of ``Model.bodies``).
    name : str
        Interface name on that body (e.g. 'front_strut', 'rear_left').
    marker : int
        Exudyn marker number of the patch's rigid marker (``MarkerSuperElementRigid`` or the
        constant-matrix body's equivalent).
    position_m : ndarray, shape (3,)
        Global position of the patch centre in the reference configuration (m).
    """

    body: str
    name: str
    marker: int
    position_m: np.ndarray


@dataclass
class Model:
    """A model variant on the rig: the Exudyn system and named handles.

    Attributes
    ----------
    variant : int
        1, 2 or 3.
    system_container, mbs
        Exudyn ``SystemContainer`` and ``MainSystem``.
    bodies : dict name -> FlexibleBodyHandle
        'chassis' (Models 1, 2) or 'frame', 'tank_left', ... (Model 3), and
        'rear_foundation'.
    body_components : dict body name -> component name for sensor/energy bookkeeping
        (None: the body carries several components, see its ``region_components``).
    interfaces : dict 'body.interface' -> InterfaceHandle
    joints : dict name -> Exudyn object number (rig joints and Model-3 connections)
    rig : RigHandles
    sensors : dict sensor name -> SensorAttachment
    drive : Drive
        Prescribed piston displacement (set a signal before simulating).
    formulation : {'linear', 'ffrf'}
    damping_ratios : dict body name -> ndarray of per-mode ratios
    metadata : dict
        Model, damping and mesh description (goes into recordings and modes files).
    body_data : dict body name -> FlexibleBodyData
    local_nonlinearities : list of :class:`~exudyn_study.linear.nonlinear.LocalNonlinearity`
        Residual force elements beyond the linear items (added by physics entries;
        simulated by ``method='linear'``, see :mod:`exudyn_study.linear.nonlinear`).
    output_gains : dict sensor name -> float
        True sensitivity / stated sensitivity of a sensor (a calibration error; applied to
        the simulated channel, 1 if absent).
    assembled : bool
        True once :meth:`assemble` has run (``mbs.Assemble()``); items added after it need
        another ``assemble()``.
    """

    variant: int
    system_container: object
    mbs: object
    bodies: dict
    body_components: dict
    interfaces: dict
    joints: dict
    rig: RigHandles
    sensors: dict
    drive: Drive
    formulation: str
    damping_ratios: dict
    metadata: dict = field(default_factory=dict)
    body_data: dict = field(default_factory=dict, repr=False)
    assembled: bool = False
    local_nonlinearities: list = field(default_factory=list)
    output_gains: dict = field(default_factory=dict)

    def assemble(self) -> None:
        """``mbs.Assemble()`` (call after adding your own items)."""
        self.mbs.Assemble()
        self.assembled = True

    def sensor_names(self) -> tuple[str, ...]:
        """Sensor names in Table 8 order."""
        return tuple(self.sensors)


def _damping_for(damping, body: str, component: str | None) -> Callable[[np.ndarray], np.ndarray]:
    """Return the damping function of ``body`` under the damping choice ``damping``."""
    if isinstance(damping, str):
        return damping_function(damping)
    if isinstance(damping, PerBody):
        for key in (body, component, "frame" if body == "chassis" else None):
            if key is not None and key in damping.ratios:
                return damping.for_body(key)
        if damping.default is not None:
            return damping.for_body(body)
        if body == "rear_foundation":
            return damping_function("constant-2") if FOUNDATION_DAMPING_RATIO == 0.02 else None
        return damping.for_body(body)  # raises, naming the body
    if isinstance(damping, Mapping):
        if body in damping:
            return _damping_for(damping[body], body, component)
        if body == "rear_foundation":
            return lambda f: np.full(np.shape(f), FOUNDATION_DAMPING_RATIO)
        raise InputError(f"damping mapping has no entry for body {body!r}; it has {sorted(damping)}")
    if callable(damping):
        return damping
    raise InputError(
        f"damping {damping!r}: expected a name ('adams-default', 'step', 'constant-1', 'constant-2'), "
        "a function of mode frequency, a PerBody table or a mapping body -> damping"
    )


def _damping_label(damping) -> str:
    if isinstance(damping, str):
        return damping
    if isinstance(damping, PerBody):
        return "per-body " + ", ".join(f"{k}={v:g}" for k, v in damping.ratios.items())
    return getattr(damping, "__name__", type(damping).__name__)


def model_bodies(
    variant: int, mesh_size="production", cache_dir=None, progress: Callable | None = None
) -> dict:
    """Build or load the flexible bodies of ``variant``: name -> FlexibleBodyData.

    Parameters
    ----------
    variant : {1, 2, 3}
        Thesis model: 1 (chassis, simple joints), 2 (chassis, detailed joints) or 3 (separate
        component bodies); every variant also gets the 'rear_foundation'.
    mesh_size : {'production', 'coarse'} or float
        Mesh of every body (a float: maximum element size in m).
    cache_dir : path, optional
        Flexible-body cache (default ``$EXUDYN_STUDY_CACHE`` or ``~/.cache/exudyn_study``).
    progress : callable, optional
        Called with a short text (``"flexible body <name>"``) before each body is built or loaded.

    Returns
    -------
    dict
        Body name ('chassis' or the Model-3 components, and 'rear_foundation') ->
        :class:`~exudyn_study.bodies.spec.FlexibleBodyData`.

    Raises
    ------
    InputError
        For an unknown variant.
    """
    from exudyn_study.bodies.spec import BodySpec, flexible_body

    _check_variant(variant)
    if variant in (1, 2):
        joint_model = "simple" if variant == 1 else "detailed"
        specs = {"chassis": BodySpec(joint_model=joint_model, mesh_size=mesh_size)}
    else:
        specs = {c: BodySpec(component=c, mesh_size=mesh_size) for c in MODEL3_COMPONENTS}
    specs["rear_foundation"] = BodySpec(kind="rear_foundation", mesh_size=mesh_size)
    out = {}
    for name, spec in specs.items():
        if progress is not None:
            progress(f"flexible body {spec.name}")
        out[name] = flexible_body(spec, cache_dir=cache_dir)
    return out


def _check_variant(variant) -> None:
    if variant not in VARIANTS:
        raise InputError(f"model {variant!r} is unknown; expected one of {list(VARIANTS)}")


def build_model(
    variant: int = 1,
    damping="adams-default",
    mesh_size="production",
    bushing: BushingParameters | None = None,
    cache_dir=None,
    formulation: str = "linear",
    rig: RigParameters | None = None,
    sensors: Sequence[str] | None = None,
    progress: Callable | None = None,
    marker_nodes: int | None = 6,
    exudyn_mesh: str = "all",
    element: str = "superelement",
) -> Model:
    """Build a thesis model variant on the rig.

    Parameters
    ----------
    variant : {1, 2, 3}
    damping : str, callable, PerBody or mapping
        A named damping function (:data:`exudyn_study.bodies.damping.DAMPING_FUNCTIONS`), a
        function of mode frequency (Hz) returning ratios, a
        :class:`~exudyn_study.bodies.damping.PerBody` table (Model 3: thesis Table 6), or a
        mapping body name -> any of these. Evaluated at each body's mode frequencies.
    mesh_size : {'production', 'coarse'} or float
    bushing : BushingParameters, optional
        Model 3 only: join the components with 6-DOF spring-dampers instead of fixed joints.
    cache_dir : path, optional
        Flexible-body cache (default ``$EXUDYN_STUDY_CACHE`` or ``~/.cache/exudyn_study``).
    formulation : {'linear', 'ffrf'}
        Flexible-body formulation (see the module docstring).
    rig : RigParameters, optional
        Rig masses, lengths and stiffnesses (default ``RigParameters()``).
    sensors : sequence of str, optional
        Sensor names to attach (default: all 42 of Appendix A).
    progress : callable, optional
        Called with a short text before each expensive step.
    marker_nodes, exudyn_mesh, element
        See :func:`build_model_from_bodies` (``exudyn_mesh='used'``: much faster Exudyn
        time integration, same linearised system; ``element='matrix'``: faster still).

    Returns
    -------
    Model
        Not yet assembled: add your own items, then ``model.assemble()``.

    Raises
    ------
    InputError
        Unknown variant, damping, formulation or sensor name; a bushing on Model 1 or 2.
    """
    _check_variant(variant)
    if bushing is not None and variant != 3:
        raise InputError(
            f"bushing given for model {variant}; bushings join the separate bodies of model 3 only"
        )
    data = model_bodies(variant, mesh_size, cache_dir, progress)
    model = build_model_from_bodies(
        data, variant=variant, damping=damping, bushing=bushing, formulation=formulation, rig=rig,
        sensors=sensors, marker_nodes=marker_nodes, exudyn_mesh=exudyn_mesh, element=element)
    model.metadata["mesh"] = str(mesh_size)
    return model


def build_model_from_bodies(
    bodies: Mapping,
    variant: int = 1,
    damping="adams-default",
    bushing: BushingParameters | None = None,
    formulation: str = "linear",
    rig: RigParameters | None = None,
    sensors: Sequence[str] | None = None,
    marker_nodes: int | None = 6,
    exudyn_mesh: str = "all",
    element: str = "superelement",
) -> Model:
    """Assemble a rig model from given flexible bodies (the workhorse of :func:`build_model`).

    Parameters
    ----------
    bodies : mapping name -> FlexibleBodyData
        'rear_foundation' and either 'chassis' (one body with the five rig interfaces)
        or the Model-3 components (the 'frame' with the rig interfaces and the component
        interfaces; each component with its matching interfaces).
    variant, damping, bushing, formulation, rig, sensors
        As :func:`build_model`.
    marker_nodes : int or None
        Linear formulation: mesh nodes per interface marker (a few well-spread nodes of
        the rigid patch give the same kinematics at a fraction of the cost,
        :func:`exudyn_study.bodies.linear_body.marker_node_subset`); None: whole patches.
    exudyn_mesh : {'all', 'used'}
        Linear formulation: give Exudyn every mesh node ('all', the default: any node can
        carry your own markers and sensors, by its mesh index) or only the nodes the
        interface markers and the sensors use ('used'). Exudyn's super-element markers
        evaluate the mesh-node coordinates from the whole mode basis, so 'used' integrates
        several times faster (``benchmarks/bench_simulation.py``); the mesh indices then
        differ in Exudyn (``model.bodies[b].mesh_node_map``: mesh index -> Exudyn node)
        and there is no surface mesh for the renderer. Same linearised system.
    element : {'superelement', 'matrix'}
        Exudyn element of the linear formulation (see the module docstring); with
        'matrix', ``marker_nodes`` and ``exudyn_mesh`` do not apply (no mesh nodes in
        Exudyn).

    Returns
    -------
    Model
    """
    import exudyn as exu
    import exudyn.itemInterface as eii

    from exudyn_study.bodies.ffrf import add_flexible_body
    from exudyn_study.bodies.linear_body import add_linear_cms_body, add_linear_matrix_body, weighted_center

    _check_variant(variant)
    if formulation not in FORMULATIONS:
        raise InputError(f"formulation {formulation!r}; expected one of {list(FORMULATIONS)}")
    if "rear_foundation" not in bodies:
        raise InputError(f"bodies {sorted(bodies)}: the rear foundation ('rear_foundation') is missing")
    frame_name = "chassis" if "chassis" in bodies else "frame"
    if frame_name not in bodies:
        raise InputError(f"bodies {sorted(bodies)}: expected 'chassis' or 'frame'")
    sensor_list = SENSORS if sensors is None else tuple(lookup_sensor(s) for s in sensors)

    if exudyn_mesh not in ("all", "used"):
        raise InputError(f"exudyn_mesh {exudyn_mesh!r}; expected 'all' or 'used'")
    if exudyn_mesh == "used" and formulation != "linear":
        raise InputError("exudyn_mesh='used' needs formulation='linear'")
    if element not in ELEMENTS:
        raise InputError(f"element {element!r}; expected one of {list(ELEMENTS)}")
    if element == "matrix" and formulation != "linear":
        raise InputError(f"element='matrix' with formulation {formulation!r}; it is an element of "
                         "formulation='linear'")
    components = {n: (None if n == "chassis" else n) for n in bodies}
    chosen = _sensor_nodes(bodies, components, sensor_list)
    sc = exu.SystemContainer()
    mbs = sc.AddSystem()
    ground = mbs.AddObject(eii.ObjectGround(name="ground"))
    handles, ratios, components = {}, {}, {}
    colors = {
        "chassis": (0.2, 0.5, 0.9, 1), "frame": (0.2, 0.5, 0.9, 1), "rear_foundation": (0.6, 0.6, 0.6, 1),
    }
    for name, fb in bodies.items():
        comp = None if name == "chassis" else ("rear_foundation" if name == "rear_foundation" else name)
        components[name] = comp
        zeta = np.asarray(_damping_for(damping, name, comp)(fb.body.frequencies_hz), dtype=float)
        ratios[name] = zeta
        color = colors.get(name, (0.9, 0.5, 0.2, 1))
        if element == "matrix":
            fixed = FOUNDATION_GROUND_INTERFACES if name == "rear_foundation" else ()
            handles[name] = add_linear_matrix_body(mbs, fb.body, fb.ffrf, zeta, name=name,
                                                   fixed_interfaces=fixed)
        elif formulation == "linear":
            keep = [c[2] for c in chosen if c[1] == name] if exudyn_mesh == "used" else None
            handles[name] = add_linear_cms_body(mbs, fb.body, fb.ffrf, zeta, ground, name=name, color=color,
                                                marker_nodes=marker_nodes, mesh_nodes=keep)
        else:
            handles[name] = add_flexible_body(mbs, fb.body, fb.ffrf, zeta, name=name, color=color)
            handles[name].interface_positions_m = {
                n: weighted_center(fb.body, n) for n in fb.body.interface_names}
    interfaces = {
        f"{b}.{n}": InterfaceHandle(b, n, h.interface_markers[n], np.asarray(h.interface_positions_m[n]))
        for b, h in handles.items() for n in h.interface_markers
    }
    frame = handles[frame_name]
    rig_handles = add_rig(mbs, frame.interface_markers, frame.interface_positions_m,
                          handles["rear_foundation"], RigParameters() if rig is None else rig,
                          ground=ground, lie_group_nodes=element == "matrix")
    joints = dict(rig_handles.joints)

    if frame_name == "frame":  # Model 3: join the components to the frame
        k_mat, d_mat = bushing.matrices() if bushing is not None else (None, None)
        for comp in (c for c in MODEL3_COMPONENTS[1:] if c in handles):
            for itf in handles[comp].interface_markers:
                if itf not in frame.interface_markers:
                    raise InputError(f"component {comp!r} interface {itf!r} has no counterpart on the frame")
                m0, m1 = frame.interface_markers[itf], handles[comp].interface_markers[itf]
                if bushing is None:
                    joints[f"{comp}.{itf}"] = generic_joint(mbs, m0, m1, (1, 1, 1, 1, 1, 1), f"{comp}.{itf}")
                else:  # unloaded at the reference: the patch centres lie apart
                    p_frame = interfaces[f"{frame_name}.{itf}"].position_m
                    gap = interfaces[f"{comp}.{itf}"].position_m - p_frame
                    s0, s1, offset = unloaded_joint_markers(mbs, m0, m1, gap)
                    joints[f"{comp}.{itf}"] = mbs.AddObject(eii.ObjectConnectorRigidBodySpringDamper(
                        name=f"{comp}.{itf}", markerNumbers=[s0, s1], stiffness=k_mat.tolist(),
                        damping=d_mat.tolist(), offset=offset,
                        visualization=eii.VObjectConnectorRigidBodySpringDamper(show=False)))

    attachments = _attach_sensors(mbs, handles, chosen)
    meta = {
        "model": f"model{variant}",
        "variant": variant,
        "damping": _damping_label(damping),
        "formulation": formulation,
        "element": element if formulation == "linear" else "ffrf",
        "connection": ("bushing" if bushing is not None else "fixed") if variant == 3 else "single body",
    }
    return Model(
        variant=variant, system_container=sc, mbs=mbs, bodies=handles, body_components=components,
        interfaces=interfaces, joints=joints, rig=rig_handles, sensors=attachments, drive=rig_handles.drive,
        formulation=formulation, damping_ratios=ratios, metadata=meta, body_data=dict(bodies))


def _surface_nodes(body) -> np.ndarray:
    tris = np.asarray(body.surface_triangles)
    return np.unique(tris.ravel())


def _sensor_nodes(bodies: Mapping, components: dict, sensor_list) -> list:
    """(sensor, body name, mesh node, distance) per sensor: the nearest surface node of its component."""
    out = []
    # the candidate nodes depend on the body and the component only: computed once per pair, not per
    # sensor (a surface's node set is a sort of all its triangles' corners)
    nodes_of: dict[tuple[str, str], np.ndarray] = {}
    for s in sensor_list:
        body_name = None
        for b, comp in components.items():
            if comp == s.component:
                body_name = b
        if body_name is None and "chassis" in bodies:
            body_name = "chassis"
        if body_name is None:
            raise InputError(
                f"sensor {s.name!r} sits on {s.component!r}, which no body of this model carries"
            )
        body = bodies[body_name].body
        key = (body_name, s.component if components[body_name] is None else "")
        if key not in nodes_of:
            if components[body_name] is None:
                nodes_of[key] = np.intersect1d(body.component_nodes(s.component), _surface_nodes(body))
            else:
                nodes_of[key] = _surface_nodes(body)
        candidates = nodes_of[key]
        if candidates.size == 0:
            raise InputError(f"sensor {s.name!r}: body {body_name!r} has no surface node on {s.component!r}")
        d = np.linalg.norm(body.node_positions_m[candidates] - np.asarray(s.position_m), axis=1)
        i = int(np.argmin(d))
        out.append((s, body_name, int(candidates[i]), float(d[i])))
    return out


def _attach_sensors(mbs, handles: dict, chosen: list) -> dict:
    """Add one acceleration ``SensorSuperElement`` per sensor node (shared by sensors on one node).

    On a constant-matrix body (``MatrixBodyHandle``) one ``SensorBody`` stores the body's
    coordinate accelerations and each attachment has the node's ``coordinate_map``.
    """
    import exudyn as exu
    import exudyn.itemInterface as eii

    from exudyn_study.bodies.linear_body import MatrixBodyHandle

    out = {}
    node_sensor: dict[tuple[str, int], int] = {}
    for s, body_name, node, dist in chosen:
        if dist > 0.05:
            log.warning("sensor %s: nearest surface node of %s is %.0f mm away", s.name, s.component,
                        1e3 * dist)
        handle = handles[body_name]
        if isinstance(handle, MatrixBodyHandle):
            key = (body_name, None)
            if key not in node_sensor:
                node_sensor[key] = mbs.AddSensor(eii.SensorBody(
                    name=f"acc:{body_name}", bodyNumber=handle.object_number,
                    outputVariableType=exu.OutputVariableType.Coordinates_tt, storeInternal=True,
                    writeToFile=False))
            out[s.name] = SensorAttachment(s, body_name, node, dist, _DIRECTION[s.direction].copy(),
                                           node_sensor[key], handle.node_map([node]))
            continue
        key = (body_name, node)
        if key not in node_sensor:
            local = handles[body_name].__dict__.get("mesh_node_map", {}).get(node, node)
            node_sensor[key] = mbs.AddSensor(eii.SensorSuperElement(
                name=f"acc:{s.name}", bodyNumber=handles[body_name].object_number,
                meshNodeNumber=int(local), outputVariableType=exu.OutputVariableType.Acceleration,
                storeInternal=True, writeToFile=False))
        out[s.name] = SensorAttachment(
            s, body_name, node, dist, _DIRECTION[s.direction].copy(), node_sensor[key]
        )
    return out
