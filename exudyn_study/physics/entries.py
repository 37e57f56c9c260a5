"""Built-in catalogue entries (registered on import of :mod:`exudyn_study.physics`).

- ``added_mass``: a point mass rigidly attached at a sensor node or an interface patch;
- ``drive_linkage_compliance``: compliance (and mass) between the piston and the linkage,
  the thesis's unexplained ~28 Hz resonance of the connection between cylinder and
  chassis (Section 7.1);
- ``rear_support_compliance``: the frame's rear attachment on the rear foundation is
  compliant (spring-dampers instead of the rigid spherical joint: z, optionally x and y);
- ``tuned_mass_damper``: a mass on a spring-damper at a sensor node or an interface patch;
- ``ground_spring_damper``: a spring-damper from a sensor node or an interface patch to ground.
"""

from __future__ import annotations

import numpy as np

from exudyn_study.errors import InputError
from exudyn_study.physics.catalogue import Parameter, PhysicsEntry, register

__all__ = [
    "ADDED_MASS",
    "DRIVE_LINKAGE_COMPLIANCE",
    "REAR_SUPPORT_COMPLIANCE",
    "TUNED_MASS_DAMPER",
    "GROUND_SPRING_DAMPER",
    "location_point",
    "surface_node",
]

_EXPECTED = ("a sensor name of the model (e.g. 'ARFVZ'), an interface 'body.interface' "
             "(e.g. 'chassis.front_strut'), a mesh node 'body#node' (e.g. 'chassis#1234') or a surface "
             "place 'body@region:u' (e.g. 'chassis@cross_member_3:0.42')")


def _mesh_node(model, location: str):
    """(body, node) of a location ``'body#node'`` naming a mesh node of a flexible body, else None."""
    body, sep, node = location.partition("#")
    if not sep or body not in model.bodies or not node.isdigit():
        return None
    n_nodes = len(model.bodies[body].body.node_positions_m)
    return (body, int(node)) if int(node) < n_nodes else None


def surface_node(model, location: str):
    """(body, node) of a surface place ``'body@region:u'``, else None.

    The place is the surface node of the body's mesh region ``region`` at fraction ``u`` (in
    [0, 1)) of that region's surface nodes in index order: a reproducible way to name "somewhere
    on this part" without knowing the mesh, so a drawn ``u`` picks a node uniformly over the
    region's surface. The same place names the same node on every model built from the same body.

    Parameters
    ----------
    model : exudyn_study.model.Model
    location : str
        ``'body@region:u'``.

    Returns
    -------
    tuple (str, int) or None
        The body name and its mesh node; None when ``location`` is not of that form or names no
        surface node.
    """
    body, sep, rest = location.partition("@")
    region, sep2, fraction = rest.rpartition(":")
    if not (sep and sep2) or body not in model.bodies:
        return None
    try:
        u = float(fraction)
    except ValueError:
        return None
    if not 0.0 <= u < 1.0:
        return None
    flexible = model.bodies[body].body
    nodes = getattr(flexible, "region_nodes", {}).get(region)
    if nodes is None:
        return None
    on_surface = np.intersect1d(np.asarray(nodes), np.asarray(flexible.surface_triangles).ravel())
    if on_surface.size == 0:
        return None
    return body, int(on_surface[int(u * on_surface.size)])


def _find_interface(model, location: str):
    if location in model.interfaces:
        return location
    hits = [k for k in model.interfaces if k.split(".", 1)[1] == location]
    return hits[0] if len(hits) == 1 else None


def _check_point_location(model, location) -> str:
    if isinstance(location, str):
        if location in model.sensors:
            return location
        key = _find_interface(model, location)
        if key is not None:
            return key
        if _mesh_node(model, location) is not None:
            return location
        node = surface_node(model, location)
        if node is not None:
            return f"{node[0]}#{node[1]}"
    raise InputError(f"location {location!r}: expected {_EXPECTED}; this model has sensors "
                     f"{list(model.sensors)} "
                     f"and interfaces {sorted(model.interfaces)}")


def location_point(model, location: str) -> tuple[int, np.ndarray]:
    """(position marker, global position in m) of a sensor node or an interface patch centre.

    Parameters
    ----------
    model : exudyn_study.model.Model
    location : str
        A sensor name (its mesh node), an interface key ``'body.interface'``, a mesh node
        ``'body#node'`` or a surface place ``'body@region:u'`` (:func:`surface_node`).

    Returns
    -------
    marker : int
        ``MarkerSuperElementPosition`` at the sensor's node, or the interface's rigid marker.
    position_m : ndarray, shape (3,)
    """
    location = _check_point_location(model, location)
    if location in model.sensors:
        att = model.sensors[location]
        handle = model.bodies[att.body]
        local = handle.__dict__.get("mesh_node_map", {}).get(att.node, att.node)
        pos = np.asarray(handle.body.node_positions_m[att.node], dtype=float) + np.asarray(handle.position_m)
        return handle.node_marker(model.mbs, int(local)), pos
    node = _mesh_node(model, location)
    if node is not None:
        from exudyn_study.physics.mesh import exudyn_mesh_nodes

        handle = model.bodies[node[0]]
        local = exudyn_mesh_nodes(model, node[0], [node[1]])[0]  # added to a body built with only the used
        pos = np.asarray(handle.body.node_positions_m[node[1]], dtype=float) + np.asarray(handle.position_m)
        return handle.node_marker(model.mbs, int(local)), pos
    itf = model.interfaces[location]
    return itf.marker, np.asarray(itf.position_m, dtype=float)


def _mass_point(mbs, name: str, position, mass_kg: float) -> tuple[int, int, int]:
    """Add a point mass at ``position``; return (node, object, position marker)."""
    import exudyn.itemInterface as eii

    node = mbs.AddNode(eii.NodePoint(name=f"{name}:node", referenceCoordinates=[float(v) for v in position]))
    obj = mbs.AddObject(eii.ObjectMassPoint(name=name, nodeNumber=node, mass=float(mass_kg),
                                            visualization=eii.VObjectMassPoint(show=False)))
    marker = mbs.AddMarker(eii.MarkerNodePosition(nodeNumber=node))
    return int(node), int(obj), int(marker)


def _add_mass(model, location: str, params: dict) -> dict:
    import exudyn.itemInterface as eii

    mbs = model.mbs
    marker, pos = location_point(model, location)
    tag = f"added_mass:{location}"
    node, obj, m_mass = _mass_point(mbs, tag, pos, params["mass_kg"])
    joint = mbs.AddObject(eii.ObjectJointSpherical(name=f"{tag}:joint", markerNumbers=[marker, m_mass],
                                                   visualization=eii.VObjectJointSpherical(show=False)))
    return {"node": node, "mass_point": obj, "marker": m_mass, "joint": int(joint),
            "body_marker": int(marker)}


ADDED_MASS = register(PhysicsEntry(
    name="added_mass",
    doc="""A point mass rigidly attached at a sensor node or an interface patch.

Physics: mass the nominal model does not carry (a sensor cube and cable clamp, a bracket,
fluid, a tool) or carries elsewhere. The point mass has no rotary inertia and is joined
to the location by a spherical joint (three translations rigid).

Signature: every mode that moves the location drops in frequency, by about
``df / f = -m |phi_loc|^2 / (2 phi^T M phi)`` for a small mass (Rayleigh); modes with a node
there do not move; the low-frequency (rigid drive) response is unchanged; the sensors at
and near the location see it most. The linearised system mass grows by exactly ``m`` times
the squared motion of the location.
""",
    parameters=(Parameter("mass_kg", "kg", 0.01, 500.0, 5.0, "the added point mass"),),
    add_items=_add_mass,
    locations=_EXPECTED,
    check_location=_check_point_location,
))



def _add_tuned_mass_damper(model, location: str, params: dict) -> dict:
    import exudyn.itemInterface as eii

    mbs = model.mbs
    marker, pos = location_point(model, location)
    tag = f"tuned_mass_damper:{location}"
    m = params["mass_kg"]
    omega = 2.0 * np.pi * params["frequency_hz"]
    k, c = m * omega**2, 2.0 * params["damping_ratio"] * m * omega
    node, obj, m_mass = _mass_point(mbs, tag, pos, m)
    spring = mbs.AddObject(eii.ObjectConnectorCartesianSpringDamper(
        name=f"{tag}:spring", markerNumbers=[marker, m_mass], stiffness=[k, k, k], damping=[c, c, c],
        visualization=eii.VObjectConnectorCartesianSpringDamper(show=False)))
    return {
        "node": node, "mass_point": obj, "marker": m_mass, "spring": int(spring), "body_marker": int(marker)
    }


TUNED_MASS_DAMPER = register(PhysicsEntry(
    name="tuned_mass_damper",
    doc="""A tuned mass-damper: a point mass on a spring-damper at a sensor node or an interface patch.

Physics: a device (or a part that acts as one: a loosely held battery, a tool box, a cable drum
on a soft bracket) of mass ``mass_kg`` joined to the structure by a spring and a viscous damper,
the same in all three translations, tuned to ``frequency_hz`` (``k = m (2 pi f)^2``) with damping
ratio ``damping_ratio`` (``c = 2 zeta m 2 pi f``) on a rigid support. The mass is added (the
structure keeps its own): below the tuning frequency it follows the structure, so the drive moves
the nominal mass plus ``mass_kg``.

Signature: a structural mode near the tuning frequency that moves the location splits into two
(Den Hartog): with the mode's mass-normalised motion ``phi`` at the location and the mass ratio
``mu = m |phi|^2``, a tuned absorber on that mode alone gives
``f_1,2^2 = f^2 (1 + mu / 2 -+ sqrt(mu + mu^2 / 4))``, so ``f_1 f_2 = f^2`` and
``f_2 - f_1 ~ f sqrt(mu)``; the FRF at the location gets an antiresonance at the tuning frequency
between the two peaks (damped: one flattened peak). Across the mode's motion at the location the
absorber's two other directions stay modes at the tuning frequency that the structure hardly
feels. Modes well below the tuning frequency drop as
for an added mass (Rayleigh: ``df / f = -m |phi|^2 / 2``), modes well above rise slightly (the mass
no longer follows); with damping, the modes near the tuning frequency gain damping.
""",
    parameters=(
        Parameter("mass_kg", "kg", 0.1, 200.0, 5.0, "the damper's moving mass"),
        Parameter("frequency_hz", "Hz", 1.0, 200.0, 20.0, "tuning frequency on a rigid support"),
        Parameter("damping_ratio", "1", 0.0, 1.0, 0.05, "damping ratio on a rigid support"),
    ),
    add_items=_add_tuned_mass_damper,
    locations=_EXPECTED,
    check_location=_check_point_location,
))



def _add_ground_spring_damper(model, location: str, params: dict) -> dict:
    import exudyn.itemInterface as eii

    mbs = model.mbs
    marker, pos = location_point(model, location)
    tag = f"ground_spring_damper:{location}"
    ground = mbs.AddObject(eii.ObjectGround(name=f"{tag}:ground", referencePosition=[float(v) for v in pos],
                                            visualization=eii.VObjectGround(show=False)))
    m_ground = mbs.AddMarker(eii.MarkerBodyPosition(bodyNumber=ground, localPosition=[0.0, 0.0, 0.0]))
    k, c = params["stiffness_n_per_m"], params["damping_n_s_per_m"]
    spring = mbs.AddObject(eii.ObjectConnectorCartesianSpringDamper(
        name=f"{tag}:spring", markerNumbers=[m_ground, marker], stiffness=[k, k, k], damping=[c, c, c],
        visualization=eii.VObjectConnectorCartesianSpringDamper(show=False)))
    return {"ground": int(ground), "ground_marker": int(m_ground), "spring": int(spring),
            "body_marker": int(marker)}


GROUND_SPRING_DAMPER = register(PhysicsEntry(
    name="ground_spring_damper",
    doc="""A spring-damper from a point of the structure to ground, the same in all three translations.

Physics: a load path the nominal model lacks between the structure and the fixed world: a cable
or hose clamped to the rig's frame, a support touching the floor, a damper (``stiffness_n_per_m``
zero) left connected. The rig diagnosis has no candidate of its own for it: its generic local
element (a dynamic stiffness to ground at any place) stands in and reports it as outside the
catalogue.

Signature: the modes that move the point rise (``d(omega^2) = k |phi|^2``, Rayleigh, ``phi`` the
mode's mass-normalised motion at the point) and gain damping ``zeta ~ c |phi|^2 / (2 omega)``;
the quasi-static response near the point drops (the drive now loads the spring); modes with a
node there stay.
""",
    parameters=(
        Parameter("stiffness_n_per_m", "N/m", 0.0, 1e9, 1e5, "stiffness to ground"),
        Parameter("damping_n_s_per_m", "N s/m", 0.0, 1e6, 500.0, "viscous damping to ground"),
    ),
    add_items=_add_ground_spring_damper,
    locations=_EXPECTED,
    check_location=_check_point_location,
))


def _check_linkage_location(model, location):
    if location not in (None, "drive_linkage", "piston_linkage"):
        raise InputError(f"drive_linkage_compliance: location {location!r}; expected None or 'drive_linkage' "
                         "(the rig has one drive linkage)")
    if "piston_linkage" not in model.rig.joints:
        raise InputError("drive_linkage_compliance: the model's rig has no 'piston_linkage' joint")
    return "drive_linkage"


def _add_linkage_compliance(model, location, params: dict) -> dict:
    import exudyn.itemInterface as eii

    mbs = model.mbs
    joint = model.rig.joints["piston_linkage"]
    m_piston, m_linkage = (int(m) for m in mbs.GetObject(joint)["markerNumbers"])
    # the pin stays rigid along x; z (the drive direction) becomes the spring
    mbs.SetObjectParameter(joint, "constrainedAxes", [1, 0, 0, 0, 0, 0])
    items = {"piston_linkage": int(joint)}
    target = m_linkage
    if params["mass_kg"] > 0:
        pin = _marker_position(model, m_linkage)
        node, obj, m_mass = _mass_point(mbs, "drive_linkage:mass", pin, params["mass_kg"])
        items.update(mass_node=node, mass_point=obj)
        items["mass_joint"] = int(mbs.AddObject(eii.ObjectJointSpherical(
            name="drive_linkage:mass_joint", markerNumbers=[m_linkage, m_mass],
            visualization=eii.VObjectJointSpherical(show=False))))
        target = m_mass
    k, c = params["stiffness_n_per_m"], params["damping_n_s_per_m"]
    items["spring"] = int(mbs.AddObject(eii.ObjectConnectorCartesianSpringDamper(
        name="drive_linkage:spring", markerNumbers=[m_piston, target], stiffness=[0.0, 0.0, k],
        damping=[0.0, 0.0, c], visualization=eii.VObjectConnectorCartesianSpringDamper(show=False))))
    return items


def _marker_position(model, marker: int) -> np.ndarray:
    """Global reference position of a ``MarkerBodyRigid`` on a rigid body (before assembly)."""
    mbs = model.mbs
    m = mbs.GetMarker(marker)
    body = mbs.GetObject(int(m["bodyNumber"]))
    node = mbs.GetNode(int(body["nodeNumber"]))
    ref = np.asarray(node["referenceCoordinates"][:3], dtype=float)
    return ref + np.asarray(m["localPosition"], dtype=float)


DRIVE_LINKAGE_COMPLIANCE = register(PhysicsEntry(
    name="drive_linkage_compliance",
    doc="""Compliance and mass in the drive linkage between the piston and the lever.

Physics: the nominal rig joins the piston rod to the linkage by a rigid pin. In the truth,
the rod end, clevis and bearing are a spring (``stiffness_n_per_m``, with viscous
``damping_n_s_per_m``) along the drive direction (z), and the lever carries an extra mass
at the pin (``mass_kg``; zero: none). The pin stays rigid along x. This is the thesis's
suspect for the ~28 Hz resonance "in the connection between the hydraulic cylinder and the
chassis assembly" that no model contained (Section 7.1, Figure 20) and for the drive
drop-off at 26 Hz (Section 5.1).

Signature: one additional system mode in which the linkage, the struts and the frame front
move together in z against the piston (``f ~ sqrt(k / m_eff) / 2 pi``, ``m_eff`` the mass
the pin carries: linkage, struts, ``mass_kg`` and the frame front's modal mass); the FRF
from the drive to every frame sensor, the front attachments ``ARFVZ``/``ARFHZ`` most, shows a
resonance there (preceded by an antiresonance at the drive point), and below it the frame
still follows the drive statically (the spring carries the static load).
""",
    parameters=(
        Parameter("stiffness_n_per_m", "N/m", 1e5, 1e10, 2e7,
                  "axial stiffness of the piston-linkage connection"),
        Parameter("damping_n_s_per_m", "N s/m", 0.0, 1e6, 2e3, "viscous damping of that connection"),
        Parameter("mass_kg", "kg", 0.0, 500.0, 20.0, "extra mass of the linkage at the pin"),
    ),
    add_items=_add_linkage_compliance,
    locations="None or 'drive_linkage' (the rig has one drive linkage)",
    check_location=_check_linkage_location,
))


_REAR_SIDES = ("rear_left", "rear_right")


def _check_rear_location(model, location) -> str:
    if location not in _REAR_SIDES:
        raise InputError(f"rear_support_compliance: location {location!r}; expected one of "
                         f"{list(_REAR_SIDES)} (the frame's rear attachments on the rear foundation)")
    if f"foundation_{location}" not in model.rig.joints:
        raise InputError(f"rear_support_compliance: the model's rig has no 'foundation_{location}' joint")
    return location


def _add_rear_support_compliance(model, location: str, params: dict) -> dict:
    import exudyn.itemInterface as eii

    mbs = model.mbs
    joint = model.rig.joints[f"foundation_{location}"]
    m_foundation, m_frame = (int(m) for m in mbs.GetObject(joint)["markerNumbers"])
    compliance = (params["longitudinal_compliance_m_per_n"], params["lateral_compliance_m_per_n"])
    # z becomes a spring; x and y too where their compliance is not zero (zero: they stay rigid)
    mbs.SetObjectParameter(joint, "constrainedAxes", [int(v == 0.0) for v in compliance] + [0])
    k = np.array([1.0 / v if v > 0 else 0.0 for v in compliance] + [params["vertical_stiffness_n_per_m"]])
    c = params["damping_time_s"] * k
    spring = mbs.AddObject(eii.ObjectConnectorCartesianSpringDamper(
        name=f"rear_support_compliance:{location}", markerNumbers=[m_foundation, m_frame],
        stiffness=k.tolist(), damping=c.tolist(),
        visualization=eii.VObjectConnectorCartesianSpringDamper(show=False)))
    return {"joint": int(joint), "spring": int(spring)}


REAR_SUPPORT_COMPLIANCE = register(PhysicsEntry(
    name="rear_support_compliance",
    doc="""The frame's rear attachment on the rear foundation is compliant vertically.

Physics: the nominal rig joins each rear attachment of the frame (``rear_left``,
``rear_right``) to the flexible rear foundation by a spherical joint, rigid in all three
translations (thesis Section 4.2: the frame may rotate about y there). The real load path
from the frame's side member down to the floor has compliance the foundation body leaves
out: the rear attachment bracket bolted to the side member's web, its bearing, the
foundation's bolted base plate and its anchorage in the floor (the thesis modelled the rear
foundation and attachment from tape measurements, Section 4.1). Here the joint's z
constraint is released and a spring ``vertical_stiffness_n_per_m`` joins the same two
points; along x and y the joint stays rigid unless ``longitudinal_compliance_m_per_n`` or
``lateral_compliance_m_per_n`` is not zero, then that constraint is released too and a spring
of the inverse stiffness joins them. Every spring has the viscous damping ``damping_time_s``
times its stiffness (the bracket's bolted and bearing contacts dissipate).

Signature: the modes that load the rear support vertically drop in frequency, to first
order ``d(omega^2) = -lambda_z^2 / k`` (Rayleigh; ``lambda_z`` the vertical force the rigid
support carries in the mass-normalised mode): the frame's vertical bending (about y) with
the front held by the drive, seen by the frame's rear z sensors most; a soft support adds a
mode in which the frame pitches about the drive points on it. Modes that do not load the
support (the component modes) stay. A longitudinal or lateral compliance lowers, the same way
(``-lambda_x^2 c_x``, ``-lambda_y^2 c_y``), the modes that move the frame's rear along x or y on
the foundation (the frame's and components' fore-aft mode near 21 Hz, Table 1's "frame bending
about z"). With ``damping_time_s > 0`` those modes gain ``zeta ~ damping_time_s * omega / 2``
times the springs' share of their strain energy.
""",
    parameters=(
        Parameter("vertical_stiffness_n_per_m", "N/m", 1e5, 1e10, 2e7,
                  "vertical stiffness of the rear attachment (frame to foundation)"),
        Parameter("longitudinal_compliance_m_per_n", "m/N", 0.0, 1e-5, 0.0,
                  "longitudinal (x) compliance of the rear attachment (0: rigid)"),
        Parameter("lateral_compliance_m_per_n", "m/N", 0.0, 1e-5, 0.0,
                  "lateral (y) compliance of the rear attachment (0: rigid)"),
        Parameter("damping_time_s", "s", 0.0, 1e-2, 1e-4, "stiffness-proportional damping time"),
    ),
    add_items=_add_rear_support_compliance,
    locations=f"one of the frame's rear attachments {list(_REAR_SIDES)}",
    check_location=_check_rear_location,
))
