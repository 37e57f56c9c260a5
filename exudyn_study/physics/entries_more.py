"""More built-in catalogue entries (registered on import of :mod:`exudyn_study.physics`).

- ``joint_stiffness``: a Model-3 bolted joint as a 6-DOF spring-damper instead of rigid;
- ``joint_friction``: micro-slip (Jenkins elements) in the contact plane of a Model-3 joint;
- ``bushing_stiffening``: the left mudguard bracket's rubber stiffens with amplitude (cubic);
- ``sloshing``: water in a fuel tank as a slosh mass on horizontal springs (Housner/Abramson);
- ``tank_wall_mode``: a tank's water-loaded side walls breathing across it (a damped internal resonator);
- ``modal_damping``: a flexible body's modal damping ratios scaled (in a frequency band);
- ``sensor_gain``: a sensor's true sensitivity differs from the stated one.

The nonlinear entries add their linear tangent as Exudyn items and append
:class:`~exudyn_study.linear.nonlinear.LocalNonlinearity` elements to
``model.local_nonlinearities`` (simulate with ``method='linear'``).

References
----------
Abramson, H. N. (1966). The dynamic behavior of liquids in moving containers. NASA SP-106.
Housner, G. W. (1963). The dynamic behavior of water tanks. Bull. Seism. Soc. Am. 53(2).
Ibrahim, R. A. (2005). Liquid sloshing dynamics. Cambridge University Press.
"""

from __future__ import annotations

import numpy as np

from exudyn_study.errors import InputError
from exudyn_study.linear.nonlinear import CubicStiffening, JenkinsFriction, LocalNonlinearity
from exudyn_study.physics.catalogue import Parameter, PhysicsEntry, register
from exudyn_study.physics.mesh import _node_set_marker, require_super_element
from exudyn_study.physics.rubber import (
    _pad_quadrants,
    _rubber_face_nodes,
    _rubber_faces,
    rubber_body,
    rubber_pad_location_check,
)

__all__ = ["JOINT_STIFFNESS", "JOINT_FRICTION", "BUSHING_STIFFENING", "SLOSHING", "TANK_WALL_MODE",
           "MODAL_DAMPING", "SENSOR_GAIN", "component_joints"]

_COMPONENTS = ("tank_left", "tank_right", "bracket_left", "bracket_right")
_AXES = "xyz"


# --------------------------------------------------------------------------------------- helpers
def component_joints(model) -> dict:
    """Model-3 joints between a component and the frame: ``'component.interface'`` -> Exudyn object.

    Parameters
    ----------
    model : object
        Rig model with a ``joints`` mapping (joint name -> Exudyn object).

    Returns
    -------
    dict
        The joints whose names have the form ``'component.interface'`` with a known component.
    """
    return {k: v for k, v in model.joints.items() if "." in k and k.split(".", 1)[0] in _COMPONENTS}


def _check_joint_location(who: str):
    def check(model, location) -> str:
        if getattr(model, "variant", None) != 3:
            variant = getattr(model, "variant", None)
            raise InputError(f"{who}: model {variant} joins its components inside one "
                             "flexible body and has no separate bolted joints; use model 3")
        joints = component_joints(model)
        if isinstance(location, str):
            if location in joints:
                return location
            hits = [k for k in joints if k.split(".", 1)[1] == location]
            if len(hits) == 1:
                return hits[0]
        raise InputError(f"{who}: location {location!r}; expected a component joint of model 3, one of "
                         f"{sorted(joints)} (or its interface name)")
    return check


def _joint_markers(model, key: str) -> tuple[int, int, int, str]:
    """(joint object, frame-side marker, component-side marker, Exudyn object type) of a component joint."""
    joint = int(model.joints[key])
    obj = model.mbs.GetObject(joint)
    m0, m1 = (int(m) for m in obj["markerNumbers"])
    return joint, m0, m1, str(obj["objectType"])


def contact_normal(model, key: str) -> int:
    """Global axis (0, 1, 2) closest to the normal of the joint's contact patch (least patch extent)."""
    comp, itf = key.split(".", 1)
    body = model.bodies[comp].body
    i = body.interface_index(itf)
    x = np.asarray(body.node_positions_m)[np.asarray(body.interface_nodes[i], dtype=int)]
    return int(np.argmin(np.ptp(x, axis=0)))


# --------------------------------------------------------------------------------------- joint_stiffness
def _mid_point_markers(model, m0: int, m1: int) -> tuple[int, int, list[float]]:
    """Markers for a spring-damper across a joint whose two patch centres lie apart, and its offset.

    See :func:`exudyn_study.model.variants.unloaded_joint_markers` (the patch centres are the
    model's interface positions).

    Returns
    -------
    (marker 0, marker 1, offset [dx, dy, dz, 0, 0, 0])
    """
    from exudyn_study.model.variants import unloaded_joint_markers

    positions = {int(h.marker): np.asarray(h.position_m, dtype=float) for h in model.interfaces.values()}
    if m0 not in positions or m1 not in positions:
        raise InputError(f"joint markers {m0}, {m1}: not interface markers of the model; a component joint "
                         "joins two interface patches")
    return unloaded_joint_markers(model.mbs, m0, m1, positions[m1] - positions[m0])


def _add_joint_stiffness(model, location: str, params: dict) -> dict:
    import exudyn.itemInterface as eii

    mbs = model.mbs
    joint, m0, m1, kind = _joint_markers(model, location)
    k_t, k_r = params["stiffness_n_per_m"], params["rotational_stiffness_n_m_per_rad"]
    k_axes = [k_t * params[f"stiffness_factor_{axis}"] for axis in "xyz"]
    k = np.diag(k_axes + [k_r] * 3)
    tau = params["damping_time_s"]
    d = np.diag([tau * k_a for k_a in k_axes] + [tau * params["rotational_damping_factor"] * k_r] * 3)
    s0, s1, offset = _mid_point_markers(model, m0, m1)
    if "RigidBodySpringDamper" in kind:  # a bushing model: change the element
        mbs.SetObjectParameter(joint, "markerNumbers", [s0, s1])
        mbs.SetObjectParameter(joint, "stiffness", k.tolist())
        mbs.SetObjectParameter(joint, "damping", d.tolist())
        mbs.SetObjectParameter(joint, "offset", offset)
        return {"joint": joint, "spring": joint}
    mbs.SetObjectParameter(joint, "constrainedAxes", [0] * 6)
    mbs.SetObjectParameter(joint, "activeConnector", False)
    spring = mbs.AddObject(eii.ObjectConnectorRigidBodySpringDamper(
        name=f"joint_stiffness:{location}", markerNumbers=[s0, s1], stiffness=k.tolist(), damping=d.tolist(),
        offset=offset, visualization=eii.VObjectConnectorRigidBodySpringDamper(show=False)))
    return {"joint": joint, "spring": int(spring)}


JOINT_STIFFNESS = register(PhysicsEntry(
    name="joint_stiffness",
    doc="""A bolted joint between a component and the frame as a spring-damper instead of rigid (Model 3).

Physics: Model 3 joins each tank bracket and mudguard bracket to the frame by a fixed joint
at the interface patches. A real bolted joint is compliant (contact, bolt stretch, plate
bending around the bolts). The fixed joint is released and a 6-DOF linear spring-damper
joins the same two patch markers: translational ``stiffness_n_per_m`` and rotational
``rotational_stiffness_n_m_per_rad`` on the diagonal (global axes; the translational one times
``stiffness_factor_x``/``_y``/``_z`` per axis, default 1: a bolted bracket is stiffer in the
plane of its clamped plates than across them, where the plates bend around the bolts), damping
``damping_time_s`` times the stiffness (stiffness-proportional, ``zeta ~ pi f t``), in the
rotations ``rotational_damping_factor`` times that: a joint dissipates differently in
translation (shear and compression of the clamped contact and the bolts) and in rotation
(rocking of the clamped plates about the bolt pattern, where the contact opens and
micro-slips at the patch edges); the default 1 damps both alike. The spring-damper acts at
the mid-point between the two patch centres (1 cm apart across the web), unloaded at the
reference. On a model built with bushings the bushing's values are replaced (and its
markers moved to that mid-point: unloaded too).

Signature: modes that load the joint drop in frequency, to first order
``d(omega^2) = -sum_j lambda_j^2 / k_j`` (Rayleigh; ``lambda_j`` the force or moment the rigid
joint carries in the mass-normalised mode); mostly the component's modes; modes that do not
load the joint (frame-only modes) barely move; the component's sensors (``ATV*``/``ATH*`` for
a tank, ``ASV*``/``ASH*`` for a bracket) show the lowered resonances. The damping a mode gets is
``zeta = (t sum_a k_a delta_a^2 + f t k_r |delta_r|^2) / (2 omega)`` (first order; ``delta`` the
joint's relative translation and rotation in the mass-normalised mode, ``k_a`` the translational
stiffness along axis ``a`` with its factor, ``f`` the rotational factor): the factor scales the
damping of the modes that rock the joint and leaves the modes that shear or compress it.
""",
    parameters=(
        Parameter("stiffness_n_per_m", "N/m", 1e4, 1e11, 5e7,
                  "translational joint stiffness (each axis, times its stiffness_factor)"),
        Parameter("rotational_stiffness_n_m_per_rad", "N m/rad", 1e2, 1e9, 5e5,
                  "rotational joint stiffness (each axis)"),
        Parameter("damping_time_s", "s", 0.0, 1e-2, 1e-4, "stiffness-proportional damping factor"),
        Parameter("rotational_damping_factor", "1", 0.0, 100.0, 1.0,
                  "damping time in the rotations / damping_time_s (rocking vs shear of the joint)"),
        Parameter("stiffness_factor_x", "1", 1e-7, 1e7, 1.0,
                  "translational stiffness along global x / stiffness_n_per_m"),
        Parameter("stiffness_factor_y", "1", 1e-7, 1e7, 1.0,
                  "translational stiffness along global y / stiffness_n_per_m"),
        Parameter("stiffness_factor_z", "1", 1e-7, 1e7, 1.0,
                  "translational stiffness along global z / stiffness_n_per_m"),
    ),
    add_items=_add_joint_stiffness,
    locations="a model-3 component joint 'component.interface' (e.g. 'tank_left.tank_left_front', "
              "'bracket_left.bracket_left') or its unique interface name",
    check_location=_check_joint_location("joint_stiffness"),
))


# --------------------------------------------------------------------------------------- joint_friction
def _add_joint_friction(model, location: str, params: dict) -> dict:
    import exudyn.itemInterface as eii

    mbs = model.mbs
    joint, m0, m1, kind = _joint_markers(model, location)
    if "JointGeneric" not in kind:
        raise InputError(f"joint_friction: joint {location!r} is a {kind}, not a fixed joint; build model 3 "
                         "without bushings")
    normal = contact_normal(model, location)
    tangential = [a for a in range(3) if a != normal]
    axes = [1] * 6
    for a in tangential:
        axes[a] = 0
    mbs.SetObjectParameter(joint, "constrainedAxes", axes)
    k, f_slip = params["stuck_stiffness_n_per_m"], params["slip_force_n"]
    stiffness = [k if a in tangential else 0.0 for a in range(3)]
    spring = mbs.AddObject(eii.ObjectConnectorCartesianSpringDamper(
        name=f"joint_friction:{location}", markerNumbers=[m0, m1], stiffness=stiffness, damping=[0.0] * 3,
        visualization=eii.VObjectConnectorCartesianSpringDamper(show=False)))
    law = JenkinsFriction(stiffness_n_per_m=k, slip_force_n=f_slip)
    for a in tangential:
        model.local_nonlinearities.append(LocalNonlinearity(
            name=f"joint_friction:{location}:{_AXES[a]}", marker_a=m0, marker_b=m1, direction=np.eye(3)[a],
            law=law, description=f"micro-slip of joint {location} along {_AXES[a]}"))
    return {"joint": joint, "spring": int(spring)}


JOINT_FRICTION = register(PhysicsEntry(
    name="joint_friction",
    doc="""Micro-slip in the contact plane of a bolted component joint (Model 3, Jenkins elements).

Physics: a preloaded bolted joint sticks at small load and slips partially once the
tangential load approaches the friction limit. In the contact plane of the joint (the two
global axes along the patch; on the side-member webs the contact normal is ``y`` and the
plane is ``x``-``z``) the fixed joint is released and each tangential direction becomes a
Jenkins element: a stuck spring ``stuck_stiffness_n_per_m`` (added as a linear
``ObjectConnectorCartesianSpringDamper``, the small-amplitude tangent) in series with a
Coulomb slider of ``slip_force_n`` (a ``LocalNonlinearity``; simulate with
``method='linear'``). The normal direction and the three rotations stay rigid.

Signature: amplitude dependent. Below slip the response is exactly that of the stiff joint
(the linearised model and the modes contain only the stuck spring). Above slip the modes
that load the joint in shear (a tank's vertical modes on a side-member web) drop in
frequency and gain damping: each element dissipates ``4 F (a - F / k)`` per cycle of
relative amplitude ``a > F / k``. Sine responses show a softening, flattened resonance.
""",
    parameters=(
        Parameter("stuck_stiffness_n_per_m", "N/m", 1e4, 1e11, 5e7,
                  "tangential stiffness of the stuck contact (each direction)"),
        Parameter("slip_force_n", "N", 0.1, 1e6, 2e3, "friction force at which the contact slips"),
    ),
    add_items=_add_joint_friction,
    locations="a model-3 component joint 'component.interface' (e.g. 'tank_left.tank_left_front') or its "
              "unique interface name",
    check_location=_check_joint_location("joint_friction"),
))


def _add_bushing_stiffening(model, location, params: dict) -> dict:
    body_name = rubber_body(model)
    body = model.bodies[body_name].body
    added = {}
    k3 = params["cubic_stiffness_n_per_m3"]
    if k3 > 0.0:
        inner, outer = _rubber_faces(body)
        m_frame, _ = _node_set_marker(model, body_name, inner, rigid=False)
        m_bracket, _ = _node_set_marker(model, body_name, outer, rigid=False)
        law = CubicStiffening(k3)
        for axis in (2, 0):
            model.local_nonlinearities.append(LocalNonlinearity(
                name=f"bushing_stiffening:{_AXES[axis]}", marker_a=m_frame, marker_b=m_bracket,
                direction=np.eye(3)[axis], law=law,
                description=f"cubic stiffening of the left bracket's rubber bushing along {_AXES[axis]}"))
        added.update(frame_side_marker=m_frame, bracket_side_marker=m_bracket)
    k3c = params["compression_cubic_stiffness_n_per_m3"]
    if k3c > 0.0:
        inner, outer, normal = _rubber_face_nodes(body)
        law = CubicStiffening(k3c)
        quads = zip(_pad_quadrants(body, inner, normal, 6), _pad_quadrants(body, outer, normal, 6),
                    strict=True)
        for q, (a, b) in enumerate(quads):
            m_a, _ = _node_set_marker(model, body_name, a, rigid=False)
            m_b, _ = _node_set_marker(model, body_name, b, rigid=False)
            model.local_nonlinearities.append(LocalNonlinearity(
                name=f"bushing_stiffening:compression{q}", marker_a=m_a, marker_b=m_b,
                direction=np.eye(3)[normal], law=law,
                description=f"cubic compression hardening of the left bracket's rubber pad, quadrant {q}"))
            added[f"compression_markers_{q}"] = (m_a, m_b)
    return added


BUSHING_STIFFENING = register(PhysicsEntry(
    name="bushing_stiffening",
    doc="""The left mudguard bracket's rubber bushing stiffens with amplitude (cubic spring).

Physics: rubber in shear and compression hardens at large strain. The nominal bodies carry
the rubber pad as linear elastic (its small-strain modulus, the linear tangent). A cubic
residual force ``k3 delta^3`` (``cubic_stiffness_n_per_m3``) acts across the pad in the
vertical (``z``) and longitudinal (``x``) shear directions: ``delta`` is the relative
displacement of the pad's two faces, each the mean of eight well-spread mesh nodes of the
rubber region ``'bracket_left_rubber'`` on the frame side (mounting plate) and on the
bracket side (base plate). This works on every variant: in Model 3 the pad is inside the
``bracket_left`` body, in Models 1 and 2 inside the chassis body (the real geometry; a body
without that region is an error). Simulate with ``method='linear'``.

``compression_cubic_stiffness_n_per_m3`` (default 0: off) adds the hardening of the
rubber in compression: four cubic elements across the pad along its normal (``y``), one per
quadrant of the pad (each between the means of six frame-side and six bracket-side face nodes
of that quadrant). Bonded rubber hardens most in compression, and the four quadrants carry
the pad's rocking too (a tilt compresses two quadrants and opens the other two): the modes of
the bracket on a pad whose rocking is stiff relative to its shear (the thesis scenario) feel
the compression term, not the shear one. Each term is only added where its coefficient is
positive.

Signature: at small drive level nothing changes; with rising level the left bracket's
modes (``ASV*`` sensors) rise in frequency (equivalent stiffness ``k0 + 3/4 k3 a^2`` by
harmonic balance), and a sine drive produces odd harmonics (3f, 5f) at the bracket whose
third-harmonic ratio grows as the square of the level; no even harmonics.
""",
    parameters=(
        Parameter("cubic_stiffness_n_per_m3", "N/m^3", 0.0, 1e16, 1e11,
                  "cubic coefficient of the bushing force in each shear direction"),
        Parameter("compression_cubic_stiffness_n_per_m3", "N/m^3", 0.0, 1e16, 0.0,
                  "cubic coefficient of the bushing force in compression, per quadrant of the pad"),
    ),
    add_items=_add_bushing_stiffening,
    locations="None or 'bracket_left' (the left mudguard bracket's rubber bushing)",
    check_location=rubber_pad_location_check("bushing_stiffening"),
))


# --------------------------------------------------------------------------------------- sloshing
_TANKS = ("tank_left", "tank_right")


def _tank_body(model, tank: str, entry_name: str = "sloshing") -> tuple[str, np.ndarray]:
    """(body carrying the tank, the tank's mesh nodes): its shell region if it has one, else the component."""
    for name, handle in model.bodies.items():
        body = handle.body
        if tank not in set(body.region_components.values()):
            continue
        shell = f"{tank}_shell"
        nodes = body.region_nodes[shell] if shell in body.region_nodes else body.component_nodes(tank)
        return name, np.asarray(nodes, dtype=int)
    raise InputError(f"{entry_name}: no body of this model carries {tank!r}; bodies {sorted(model.bodies)}")


def _tank_location_check(entry_name: str):
    def check(model, location):
        if location not in _TANKS:
            raise InputError(f"{entry_name}: location {location!r}; expected one of {list(_TANKS)}")
        _tank_body(model, location, entry_name)
        return location

    return check


_check_tank_location = _tank_location_check("sloshing")


def _add_tank_resonator(model, entry_name: str, location: str, mass_kg: float, stiffness, damping) -> dict:
    """Add a mass inside ``location``'s tank on spring-dampers (N/m, N s/m along x, y, z); take it off again.

    Its Exudyn items are named ``'{entry_name}:{location}...'``.

    The mass sits at the tank's centre (a rigid marker averaging the shell's mesh nodes nearest
    its bounding-box corners); along an axis of zero stiffness and in rotation it follows the
    tank (a generic joint). The bodies already carry the water, so the same mass (and the
    resonator's small rotary inertia) is taken off rigidly at that point by an
    ``ObjectGenericODE2`` with a negative mass matrix (Exudyn rejects a negative mass on
    ``ObjectMassPoint``/``RigidBody``): the total mass is unchanged.
    """
    import exudyn as exu
    import exudyn.itemInterface as eii
    import exudyn.utilities as eu

    mbs = model.mbs
    tag = f"{entry_name}:{location}"
    body_name, nodes = _tank_body(model, location, entry_name)
    handle = model.bodies[body_name]
    x = np.asarray(handle.body.node_positions_m)[nodes]
    # shell-like tanks: the nodes nearest the eight bounding-box corners span the tank
    corners = np.array([[a, b, c] for a in (0, 1) for b in (0, 1) for c in (0, 1)], dtype=float)
    lo, hi = x.min(axis=0), x.max(axis=0)
    picks = [int(nodes[np.argmin(np.linalg.norm(x - (lo + cc * (hi - lo)), axis=1))]) for cc in corners]
    picks = list(dict.fromkeys(picks))
    m_tank, centre = _node_set_marker(model, body_name, picks, rigid=True)
    r_g = 0.05  # m, radius of gyration of the resonator's body: its rotations follow the tank (joint)
    mass = mbs.CreateRigidBody(name=tag, referencePosition=centre.tolist(),
                               inertia=eu.RigidBodyInertia(mass_kg, np.eye(3) * mass_kg * r_g**2),
                               gravity=[0.0, 0.0, 0.0])
    mass_node = int(mbs.GetObject(mass)["nodeNumber"])
    m_mass = mbs.AddMarker(eii.MarkerBodyRigid(bodyNumber=mass, localPosition=[0.0, 0.0, 0.0]))
    joint = mbs.AddObject(eii.ObjectJointGeneric(
        name=f"{tag}:follows_tank", markerNumbers=[m_tank, m_mass],
        constrainedAxes=[int(k == 0.0) for k in stiffness] + [1, 1, 1],
        visualization=eii.VObjectJointGeneric(show=False)))
    spring = mbs.AddObject(eii.ObjectConnectorCartesianSpringDamper(
        name=f"{tag}:spring", markerNumbers=[m_tank, m_mass], stiffness=[float(k) for k in stiffness],
        damping=[float(c) for c in damping],
        visualization=eii.VObjectConnectorCartesianSpringDamper(show=False)))
    items = {"tank_marker": m_tank, "mass_body": int(mass), "mass_node": mass_node, "joint": int(joint),
             "spring": int(spring)}
    comp_node = mbs.AddNode(eii.NodeRigidBodyRxyz(name=f"{tag}:compensation", referenceCoordinates=[
        float(v) for v in centre] + [0.0, 0.0, 0.0]))
    zero = exu.MatrixContainer(np.zeros((6, 6)))
    neg = -np.diag([mass_kg] * 3 + [mass_kg * r_g**2] * 3)
    comp = mbs.AddObject(eii.ObjectGenericODE2(name=f"{tag}:compensation", nodeNumbers=[comp_node],
                                               massMatrix=exu.MatrixContainer(neg), stiffnessMatrix=zero,
                                               dampingMatrix=zero))
    m_comp = mbs.AddMarker(eii.MarkerNodeRigid(nodeNumber=comp_node))
    comp_joint = mbs.AddObject(eii.ObjectJointGeneric(
        name=f"{tag}:compensation_joint", markerNumbers=[m_tank, m_comp], constrainedAxes=[1] * 6,
        visualization=eii.VObjectJointGeneric(show=False)))
    items.update(compensation_node=int(comp_node), compensation=int(comp), compensation_joint=int(comp_joint))
    return items


def _add_sloshing(model, location: str, params: dict) -> dict:
    m_s = params["slosh_mass_kg"]
    omega = 2.0 * np.pi * params["slosh_frequency_hz"]
    k, c = m_s * omega**2, 2.0 * params["slosh_damping_ratio"] * m_s * omega
    c_y = c * params["lateral_damping_factor"]  # across the tank (y): the baffles damp that flow differently
    items = _add_tank_resonator(model, "sloshing", location, m_s, (k, k, 0.0), (c, c_y, 0.0))
    items["slosh_body"], items["slosh_node"] = items["mass_body"], items["mass_node"]
    return items


SLOSHING = register(PhysicsEntry(
    name="sloshing",
    doc="""Water sloshing in a partly filled fuel tank (equivalent mechanical model).

Physics: the nominal models smear the tank's water over its shell (it moves rigidly with
the tank). In a partly filled tank the free surface sloshes. The equivalent mechanical model
of Housner (1963) and Abramson (1966) replaces the first sloshing mode by a mass
``slosh_mass_kg`` on horizontal springs (``x`` and ``y``, ``k = m (2 pi f_s)^2``) tuned to
``slosh_frequency_hz``, with viscous damping ``slosh_damping_ratio`` along the tank (x) and
``lateral_damping_factor`` times that across it (y: baffles across the tank's length drag the
water's flow along it, not the flow across it, so the two dissipate differently); vertically and in
rotation it follows the tank (a generic joint). It sits at the tank's centre (Housner puts
it at a height depending on the fill level; the centre is the simple choice): a rigid
marker averaging the tank shell's mesh nodes nearest the shell's bounding-box corners. The total mass is
unchanged: the same mass (and the slosh body's small rotary inertia) is taken off rigidly
at that point by a negative-mass ``ObjectGenericODE2`` (Exudyn refuses negative masses on
mass points and rigid bodies). The slosh mass must stay below the tank's own mass.

Signature: two new, lightly damped horizontal modes at ``f_s`` (x and y; exactly ``f_s``
for a rigid, fixed tank, slightly shifted by the tank's own compliance) seen by the tank's
``X``/``Y`` sensors (the vertical drive hardly excites them: they show in the mode shapes
and in horizontal excitation); the vertical (``Z``) response and the tank's vertical modes
are unchanged; below ``f_s`` the horizontal response is unchanged (the compensation keeps the
mass the drive moves exactly); above ``f_s`` the slosh mass no longer follows the tank, so
the modes in which the tank moves horizontally rise (as if the tank lost ``slosh_mass_kg``),
and the slosh damper, ``c = 2 zeta m_s (2 pi f_s)`` along x and ``lateral_damping_factor``
times that along y, then acts between the tank and the nearly still water: those modes gain
``zeta ~ c phi^2 / (2 omega)`` (``phi`` the tank's mass-normalised horizontal motion), the
tank's vertical modes nothing. Below the analysed band (a half-full tank's first slosh frequency is
near 1-1.5 Hz) only the damper and the mass show, so frequency and damping ratio trade against each
other there; the ratio may exceed 1 (an overdamped slosh mass: the equivalent damper of baffles
dragging the water), up to 2.
""",
    parameters=(
        Parameter("slosh_frequency_hz", "Hz", 0.2, 20.0, 1.5, "first sloshing frequency"),
        Parameter("slosh_damping_ratio", "1", 0.0, 2.0, 0.02,
                  "damping ratio of the slosh mode (above 1: overdamped, an equivalent damper for baffles)"),
        Parameter("slosh_mass_kg", "kg", 0.1, 300.0, 80.0, "mass taking part in the first sloshing mode"),
        Parameter("lateral_damping_factor", "1", 0.0, 10.0, 1.0,
                  "damping ratio across the tank (y) / slosh_damping_ratio (along it, x)"),
    ),
    add_items=_add_sloshing,
    locations=f"a fuel tank, one of {list(_TANKS)}",
    check_location=_check_tank_location,
))


# --------------------------------------------------------------------------------------- tank_wall_mode
def _add_tank_wall_mode(model, location: str, params: dict) -> dict:
    m_w = params["wall_mass_kg"]
    omega = 2.0 * np.pi * params["wall_frequency_hz"]
    k, c = m_w * omega**2, 2.0 * params["wall_damping_ratio"] * m_w * omega
    return _add_tank_resonator(model, "tank_wall_mode", location, m_w, (0.0, k, 0.0), (0.0, c, 0.0))


TANK_WALL_MODE = register(PhysicsEntry(
    name="tank_wall_mode",
    doc="""The water-loaded side walls of a fuel tank breathe across the tank (a damped internal resonator).

Physics: the nominal models make the tank a shell whose water is smeared over it, so the walls
and the water move with the tank. A large tank's flat side walls (the long sides, normal to y)
are flexible; full of water they have a low breathing mode in which the walls bend and the
water between them is pushed to and fro, the water's mass on the walls' bending stiffness. A
lateral motion of the tank drives it (the walls lag the tank's frame and its straps), and it
dissipates strongly (the wall material's loss and the water's flow past the baffles and the
straps' liners). Its equivalent model is one mass ``wall_mass_kg`` (the walls and the water
they move) on a spring-damper across the tank (y), tuned to ``wall_frequency_hz`` with the
damping ratio ``wall_damping_ratio``; along x, z and in rotation the mass follows the tank. It
sits at the tank's centre (as the ``sloshing`` mass does) and the same mass is taken off the
tank there (it is already in the tank's smeared water): the total mass is unchanged.

Signature: a new heavily damped mode at about ``wall_frequency_hz`` (above ``~10 %``
damping it hardly shows as a peak) that acts as a tuned-mass damper on the modes that move the
tank across (y) near that frequency: they gain damping, most those closest to the tuning and
with the tank's largest lateral motion, and they shift (below the tuning down, above it up);
modes far below it see the mass as moving with the tank (nothing changes), modes far above it
see the tank lighter by ``wall_mass_kg`` across and a damper ``2 zeta m (2 pi f_w)`` between the
tank and the nearly still walls. The tank's fore-aft (x) and vertical (z) motion and every mode
that does not move the tank across are unchanged.

The diagnosis has no candidate for this entry yet (the ``thesis`` truth uses it on the right tank; the
diagnosis explains that mode's damping with the water and the joints it has).
""",
    parameters=(
        Parameter("wall_frequency_hz", "Hz", 5.0, 60.0, 20.0,
                  "breathing frequency of the water-loaded walls"),
        Parameter("wall_damping_ratio", "1", 0.0, 1.0, 0.1, "damping ratio of the wall mode"),
        Parameter("wall_mass_kg", "kg", 0.1, 100.0, 10.0, "mass of the walls and the water they move"),
    ),
    add_items=_add_tank_wall_mode,
    locations=f"a fuel tank, one of {list(_TANKS)}",
    check_location=_tank_location_check("tank_wall_mode"),
))


# --------------------------------------------------------------------------------------- modal_damping
def _check_body_location(model, location):
    if not (isinstance(location, str) and location in model.bodies):
        raise InputError(f"modal_damping: location {location!r}; expected a flexible body of the model, "
                         f"one of {sorted(model.bodies)}")
    return location


def _add_modal_damping(model, location: str, params: dict) -> dict:
    import exudyn as exu

    from exudyn_study.bodies.ffrf import modal_damping_matrix

    lo, hi = params["min_frequency_hz"], params["max_frequency_hz"]
    if lo > hi:
        raise InputError(f"modal_damping: min_frequency_hz = {lo:g} Hz above max_frequency_hz = {hi:g} Hz")
    handle = model.bodies[location]
    require_super_element(handle, location, "dampingMatrixReduced to scale")
    freq = np.asarray(handle.body.frequencies_hz, dtype=float)
    zeta = np.array(handle.damping_ratios, dtype=float)
    band = (freq >= lo) & (freq <= hi)
    zeta[band] *= params["factor"]
    if np.any(zeta >= 1.0):
        raise InputError(f"modal_damping: factor {params['factor']:g} gives damping ratios up to "
                         f"{zeta.max():g} on body {location!r}; expected ratios below 1")
    diag = np.diag(modal_damping_matrix(freq, zeta))
    if model.formulation == "linear":
        diag = np.concatenate([np.zeros(6), diag])  # the six rigid-body modes are undamped
    mc = exu.MatrixContainer()
    mc.SetWithDenseMatrix(np.diag(diag), useDenseMatrix=False)
    model.mbs.SetObjectParameter(handle.object_number, "dampingMatrixReduced", mc)
    handle.damping_ratios = zeta  # a second application scales these
    return {"body": int(handle.object_number)}


MODAL_DAMPING = register(PhysicsEntry(
    name="modal_damping",
    doc="""Wrong modal damping of a flexible body: its modal damping ratios scaled by a factor.

Physics: the damping each flexible body carries is a modelling choice (a function of the
body's free-free mode frequency, thesis Section 3.3); the truth may dissipate more or
less (joints, coatings, the water). The body's reduced damping matrix
``diag(2 zeta_i omega_i)`` is rebuilt with ``zeta_i`` times ``factor`` for the body modes
with free-free frequency in ``[min_frequency_hz, max_frequency_hz]`` (the default band
covers all). The body handle's ``damping_ratios`` take the new values (applications
compose); ``model.damping_ratios`` keeps the nominal choice.

Signature: the system modes' natural frequencies are unchanged (undamped: identical); the
damping of system modes dominated by that body scales by ``factor`` (a mode whose energy
sits partly elsewhere scales by the body's share of its dissipation); modes of other
bodies keep their damping; resonance peaks at that body's sensors change height by about
``1 / factor``.
""",
    parameters=(
        Parameter("factor", "1", 0.1, 10.0, 2.0, "scale of the body's modal damping ratios"),
        Parameter("min_frequency_hz", "Hz", 0.0, 1e5, 0.0, "lowest body-mode frequency scaled"),
        Parameter("max_frequency_hz", "Hz", 0.0, 1e5, 1e5, "highest body-mode frequency scaled"),
    ),
    add_items=_add_modal_damping,
    locations="a flexible body of the model ('chassis', 'frame', 'tank_left', ..., 'rear_foundation')",
    check_location=_check_body_location,
))


# --------------------------------------------------------------------------------------- sensor_gain
def _check_sensor_location(model, location):
    if not (isinstance(location, str) and location in model.sensors):
        raise InputError(f"sensor_gain: location {location!r}; expected a sensor of the model, one of "
                         f"{list(model.sensors)}")
    return location


def _add_sensor_gain(model, location: str, params: dict) -> dict:
    model.output_gains[location] = float(model.output_gains.get(location, 1.0)) * params["gain"]
    return {}


SENSOR_GAIN = register(PhysicsEntry(
    name="sensor_gain",
    doc="""A sensor's true sensitivity differs from the stated one (a calibration error).

Physics: the recording converts volts with the stated sensitivity (Appendix A); if the
accelerometer's true sensitivity is ``gain`` times that, the recorded channel is ``gain``
times the true acceleration. Sets ``model.output_gains[sensor]`` (multiplying an existing
gain); adds no Exudyn item, so the modes and the linearised system are unchanged.

Signature: one channel scaled by the same real constant at all frequencies and levels
(its FRF magnitude by ``gain``, phase unchanged; its mode-shape coefficient in every mode
by ``gain``, so MAC with the other channels drops only slightly); no other channel changes.
""",
    parameters=(Parameter("gain", "1", 0.5, 2.0, 1.1, "true / stated sensitivity"),),
    add_items=_add_sensor_gain,
    locations="a sensor of the model (e.g. 'ARFVZ')",
    check_location=_check_sensor_location,
))
