"""Parametric Netgen OCC solid model of the chassis assembly of the thesis.

The test object of the thesis (Sections 3.1 and 4, Appendix A) is a part of a
truck chassis frame in a uni-axial test rig: two side members (an outer
C-channel with an inner C-channel fitted inside it), a front plate welded to the
side members, four cross members (two sheet steel, two cast iron), two 400 L
steel fuel tanks on two brackets each, a right mudguard bracket (steel) and a
left one mounted through a rubber bushing.  This module builds that assembly as
a set of solids in the thesis's local coordinate system, in metres:

* ``x`` rearwards from the front (the front plate is near ``x = -0.53``),
* ``y`` to the right (left side negative),
* ``z`` upwards.

Everything is solid-meshed (second-order tetrahedra downstream).  The thin walls
get one element through their thickness at the coarse and production sizes (see
:data:`MESH_SIZES`); second-order tetrahedra represent plate bending with one
layer reasonably, and the parts whose stiffness sets the low modes (brackets,
bolted joints, rubber) carry a finer local mesh size.

Bolted joints (thesis Sections 4.3 and 4.4) are modelled two ways, chosen by
:attr:`ChassisDesign.joint_model`:

``"simple"`` (Model 1)
    The two parts are separated by a small gap and each bolt is a short steel
    connector cylinder bridging the gap, glued to both faces: the beam element
    with kinematic couplings of the thesis's Figure 10.
``"detailed"`` (Model 2)
    The same gap, but each bolt is a shank through holes in both parts, a
    washer under the head and under the nut, and a clamped contact patch: an
    annulus of fused contact around the bolt filling the gap (the pressure
    cone of the preloaded joint), as in the thesis's Figure 11.  The bolt head
    and nut are lumped into the washers.

The nested channels of a side member are glued over their whole contact
surface (many bolts and friction make them act together at test amplitudes),
and welded connections (front plate, rig attachment pads, tank brackets to the
tank, bracket arms to their plates) are fused, so the mesh is conforming there.
The two parts of a bolted joint never touch except through the joint
representation.

Model 3 (thesis Section 4.5) needs the components as separate bodies:
``chassis_geometry(design, component="tank_left")`` builds one component alone.
The frame carries the five rig interfaces and six component interfaces (two per
tank, one per mudguard bracket); a component carries the matching interface.
Both sides of a component interface have the same name and the same nominal
centre (the centre of the bolt pattern in the mid-plane of the joint gap), so a
fixed joint or a bushing element can join them.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import TYPE_CHECKING

from exudyn_study.bodies.materials import MATERIALS
from exudyn_study.errors import InputError

if TYPE_CHECKING:  # pragma: no cover
    import netgen.meshing
    import netgen.occ

__all__ = [
    "ChassisDesign",
    "Part",
    "InterfaceSpec",
    "ChassisGeometry",
    "chassis_geometry",
    "rear_foundation_geometry",
    "COMPONENTS",
    "JOINT_MODELS",
    "MESH_SIZES",
    "MESH_REFINEMENT",
    "mesh_parameters",
]

#: Global mesh sizes (``maxh`` in m) for :meth:`ChassisGeometry.generate_mesh`; each
#: named size also sets Netgen's local refinement (:data:`MESH_REFINEMENT`).
#:
#: ``production`` (0.12 m, Netgen's default refinement at edges and a curvature safety of
#: 1 at the 36 mm bolt circles) is what every study, the virtual rig and the CLI use by
#: default. Measured (second-order, 3 DOF per node): assembly with simple joints 160 617
#: DOF, detailed joints 262 635 DOF. Its first ten mounted modes are tank and bracket
#: modes governed by local plate bending at the joints, resolved only through the local
#: refinement (``segmentsperedge`` at the 8-10 mm edges of ribs and connectors, curvature
#: at the bolt circles); ``maxh`` alone hardly changes the DOF (0.2 m: ~144 k DOF).
#:
#: ``coarse`` (0.2 m, curvature safety 0.5, 0.2 segments per edge) halves the DOF (simple
#: joints ~81 k) and the build time, for tests and quick looks; it is *not* converged: the
#: tank and bracket modes come out several per cent high (measured against production in
#: ``python meshes/check_modes.py --size coarse``; see ``meshes/README.md``). Coarser
#: still fails to mesh the bolt circles.
MESH_SIZES = MappingProxyType({"coarse": 0.2, "production": 0.12})

#: Netgen local refinement per named mesh size: ``curvature_safety`` (elements per radius
#: at curved faces, Netgen's ``curvaturesafety``; default 2) and ``segments_per_edge``
#: (Netgen's ``segmentsperedge``, elements along short edges; None: Netgen's default 1).
#: A size given as a number in m uses the production refinement.
MESH_REFINEMENT = MappingProxyType({
    "coarse": MappingProxyType({"curvature_safety": 0.5, "segments_per_edge": 0.2}),
    "production": MappingProxyType({"curvature_safety": 1.0, "segments_per_edge": None}),
})


def mesh_parameters(mesh_size) -> dict:
    """``maxh`` and refinement for a named mesh size or an element size in m.

    Parameters
    ----------
    mesh_size : {'coarse', 'production'} or float
        A key of :data:`MESH_SIZES`, or a maximum element size (m, > 0; refined like 'production').

    Returns
    -------
    dict
        ``maxh`` (m), ``curvature_safety``, ``segments_per_edge``: the keyword arguments of
        :meth:`ChassisGeometry.generate_mesh` (besides ``grading``).
    """
    if isinstance(mesh_size, str):
        if mesh_size not in MESH_SIZES:
            raise InputError(f"mesh size {mesh_size!r}: expected one of {sorted(MESH_SIZES)} or a size in m")
        return {"maxh": float(MESH_SIZES[mesh_size]), **MESH_REFINEMENT[mesh_size]}
    if not (isinstance(mesh_size, (int, float)) and math.isfinite(mesh_size) and mesh_size > 0):
        raise InputError(f"mesh size {mesh_size!r}: expected 'coarse', 'production' or a positive size in m")
    return {"maxh": float(mesh_size), **MESH_REFINEMENT["production"]}

#: Netgen mesh grading: the element size may grow by this factor per element away
#: from small features (joint hardware); Netgen's default 0.3 spreads the bolt
#: refinement over the whole side members.
MESH_GRADING = 0.8


#: Component bodies of Model 3 (thesis Section 4.5).
COMPONENTS = ("frame", "tank_left", "tank_right", "bracket_left", "bracket_right")

#: Bolted-joint representations: Model 1 and Model 2 of the thesis.
JOINT_MODELS = ("simple", "detailed")

_SIDES = {"left": -1.0, "right": 1.0}


# --------------------------------------------------------------------------- design
@dataclass(frozen=True)
class ChassisDesign:
    """Dimensions and options of the chassis assembly; lengths in m, masses in kg.

    Positions are in the thesis's local coordinates (``x`` rearwards, ``y`` to
    the right, ``z`` up).  Lateral positions are given as distances ``|y|`` from
    the centre plane; the assembly is mirror-symmetric except for the mudguard
    brackets (the left one sits on a rubber bushing).

    Parameters
    ----------
    joint_model : str
        ``"simple"`` (Model 1: connector cylinders across a gap) or
        ``"detailed"`` (Model 2: bolt shank, washers, clamped contact patch).
    water_mass_per_tank_kg : float
        Water in each fuel tank (222 L in the test), smeared over the tank shell.
    side_member_front_x_m, side_member_rear_x_m : float
        Longitudinal extent of the side members.
    side_member_web_y_m : float
        ``|y|`` of the outer face of the outer channel's web.
    side_member_bottom_z_m, side_member_height_m : float
        Bottom ``z`` and overall height of the outer channel.
    outer_channel_flange_width_m, outer_channel_thickness_m : float
        Flange width (from the web's outer face) and wall thickness of the outer
        channel; the flanges point inwards.
    inner_channel_flange_width_m, inner_channel_thickness_m : float
        The same for the inner channel, fitted inside the outer one.
    inner_channel_front_x_m, inner_channel_rear_x_m : float
        Longitudinal extent of the inner channel.
    front_plate_thickness_m, front_plate_top_z_m : float
        Front plate (welded to the side members' front ends), thickness along
        ``x`` and top edge height; it spans the frame width and starts at the
        side members' bottom.
    drive_pad_x_m, drive_pad_z_m, drive_pad_size_m, drive_pad_thickness_m : float
        Front drive attachment pads on the webs' outer faces, where the rig's
        linkage struts attach (near sensors ARFVZ/ARFHZ): centre, square edge
        length, thickness.
    strut_pad_y_m, strut_pad_z_m, strut_pad_width_m, strut_pad_height_m, strut_pad_thickness_m : float
        Pad on the front face of the front plate where the y-restraining front
        strut attaches.
    rear_attachment_x_m, rear_attachment_z_m : float
        Centre of the rear attachment blocks (to the rig's rear foundation).
    rear_attachment_length_m, rear_attachment_height_m : float
        Their extent along ``x`` and ``z``.
    rear_attachment_outer_y_m : float
        ``|y|`` of their outer (interface) face.
    cross_member_x_m : tuple of float
        Positions of the four cross members (front to rear).
    cross_member_materials : tuple of str
        Their materials (keys of :data:`exudyn_study.bodies.materials.MATERIALS`).
    cross_member_top_z_m : float
        Top of the cross members.
    sheet_cross_member_height_m, sheet_cross_member_flange_m, sheet_cross_member_thickness_m : float
        I-section of the sheet-steel cross members: height, flange width (along
        ``x``), wall thickness.
    cast_cross_member_height_m, cast_cross_member_flange_m, cast_cross_member_thickness_m : float
        The same for the cast-iron cross members.
    cross_member_end_plate_width_m, cross_member_end_plate_thickness_m : float
        End plates of the cross members, bolted to the side members' webs.
    tank_x_m, tank_y_m, tank_z_m : tuple of float
        Outer extents of each fuel tank (``|y|`` for ``tank_y_m``); the defaults
        give about 400 L.
    tank_wall_thickness_m : float
        Tank wall thickness.
    tank_baffles : int
        Number of transverse anti-slosh baffles inside each tank (they stiffen
        the walls, which carry the smeared water mass).
    tank_baffle_thickness_m : float
        Baffle thickness.
    tank_bracket_x_m : tuple of float
        Positions of the two brackets of each tank.
    tank_bracket_plate_width_m, tank_bracket_plate_z_m, tank_bracket_plate_thickness_m : float
        Mounting plate of a tank bracket, bolted to the web's outer face:
        width along ``x``, ``(bottom, top)`` in ``z``, thickness.
    tank_bracket_rib_thickness_m, tank_bracket_rib_bottom_z_m : float
        Vertical rib (normal ``x``) from the mounting plate to the tank's inner
        wall; thickness and bottom ``z`` (its top is the plate's top).
    mudguard_x_m, mudguard_z_m : float
        Centre of the mudguard brackets' mounting plates and arms.
    mudguard_plate_width_m, mudguard_plate_height_m, mudguard_plate_thickness_m : float
        Mounting plate of each mudguard bracket (bolted to the web).
    mudguard_arm_width_m, mudguard_arm_height_m : float
        Solid arm cross-section (along ``x`` and ``z``).
    mudguard_tip_y_m : float
        ``|y|`` of the arm's outer end.
    mudguard_tip_plate_width_m, mudguard_tip_plate_height_m, mudguard_tip_plate_thickness_m : float
        Mudguard holder plate at the arm's tip.
    rubber_width_m, rubber_height_m, rubber_thickness_m : float
        Rubber bushing of the left bracket: a rubber pad between the bracket's
        base plate and its frame mounting plate.
    bracket_base_plate_thickness_m : float
        Base plate of the left bracket on the rubber pad.
    bolt_diameter_m : float
        Bolt (shank) diameter.
    connector_diameter_m : float
        Diameter of the connector cylinder of a simple joint.
    washer_diameter_m, washer_thickness_m : float
        Washers of a detailed joint (head and nut lumped in).
    clamp_diameter_m : float
        Outer diameter of the clamped contact annulus of a detailed joint.
    joint_gap_m : float
        Gap between bolted parts (both joint models).
    bolt_pitch_x_m, bolt_pitch_z_m : float
        Spacing of the 2 x 2 bolt pattern of a tank-bracket or cross-member joint.
    mudguard_bolt_pitch_x_m, mudguard_bolt_pitch_z_m : float
        Spacing of the 2 x 2 bolt pattern of a mudguard bracket.
    joint_maxh_m : float
        Local mesh size of the joint hardware (connectors, washers, shanks,
        contact patches).
    rubber_maxh_m : float
        Local mesh size of the rubber pad.
    bracket_maxh_m : float
        Local mesh size of tank-bracket and mudguard-bracket parts.
    """

    joint_model: str = "simple"
    water_mass_per_tank_kg: float = 222.0
    # side members
    side_member_front_x_m: float = -0.52
    side_member_rear_x_m: float = 2.60
    side_member_web_y_m: float = 0.44
    side_member_bottom_z_m: float = 0.03
    side_member_height_m: float = 0.27
    outer_channel_flange_width_m: float = 0.09
    outer_channel_thickness_m: float = 0.008
    inner_channel_flange_width_m: float = 0.075
    inner_channel_thickness_m: float = 0.006
    inner_channel_front_x_m: float = -0.52
    inner_channel_rear_x_m: float = 1.90
    # front plate and rig attachments
    front_plate_thickness_m: float = 0.015
    front_plate_top_z_m: float = 0.30
    drive_pad_x_m: float = -0.315
    drive_pad_z_m: float = 0.17
    drive_pad_size_m: float = 0.12
    drive_pad_thickness_m: float = 0.015
    strut_pad_y_m: float = 0.0
    strut_pad_z_m: float = 0.165
    strut_pad_width_m: float = 0.15
    strut_pad_height_m: float = 0.10
    strut_pad_thickness_m: float = 0.010
    rear_attachment_x_m: float = 2.48
    rear_attachment_z_m: float = 0.19
    rear_attachment_length_m: float = 0.12
    rear_attachment_height_m: float = 0.14
    rear_attachment_outer_y_m: float = 0.535
    # cross members
    cross_member_x_m: tuple[float, ...] = (0.125, 0.865, 1.475, 2.15)
    cross_member_materials: tuple[str, ...] = ("steel", "steel", "cast_iron", "cast_iron")
    cross_member_top_z_m: float = 0.27
    sheet_cross_member_height_m: float = 0.20
    sheet_cross_member_flange_m: float = 0.08
    sheet_cross_member_thickness_m: float = 0.006
    cast_cross_member_height_m: float = 0.20
    cast_cross_member_flange_m: float = 0.09
    cast_cross_member_thickness_m: float = 0.014
    cross_member_end_plate_width_m: float = 0.12
    cross_member_end_plate_thickness_m: float = 0.010
    # fuel tanks
    tank_x_m: tuple[float, float] = (0.19, 1.09)
    tank_y_m: tuple[float, float] = (0.54, 1.16)
    tank_z_m: tuple[float, float] = (-0.415, 0.305)
    tank_wall_thickness_m: float = 0.004
    tank_baffles: int = 2
    tank_baffle_thickness_m: float = 0.003
    tank_bracket_x_m: tuple[float, float] = (0.40, 1.00)
    tank_bracket_plate_width_m: float = 0.14
    tank_bracket_plate_z_m: tuple[float, float] = (0.06, 0.28)
    tank_bracket_plate_thickness_m: float = 0.006
    tank_bracket_rib_thickness_m: float = 0.008
    tank_bracket_rib_bottom_z_m: float = -0.05
    # mudguard brackets
    mudguard_x_m: float = -0.10
    mudguard_z_m: float = 0.15
    mudguard_plate_width_m: float = 0.34
    mudguard_plate_height_m: float = 0.20
    mudguard_plate_thickness_m: float = 0.010
    mudguard_arm_width_m: float = 0.04
    mudguard_arm_height_m: float = 0.06
    mudguard_tip_y_m: float = 1.15
    mudguard_tip_plate_width_m: float = 0.25
    mudguard_tip_plate_height_m: float = 0.15
    mudguard_tip_plate_thickness_m: float = 0.006
    rubber_width_m: float = 0.20
    rubber_height_m: float = 0.08
    rubber_thickness_m: float = 0.008
    bracket_base_plate_thickness_m: float = 0.010
    # bolted joints
    bolt_diameter_m: float = 0.016
    connector_diameter_m: float = 0.036
    washer_diameter_m: float = 0.030
    washer_thickness_m: float = 0.008
    clamp_diameter_m: float = 0.048
    joint_gap_m: float = 0.010
    bolt_pitch_x_m: float = 0.07
    bolt_pitch_z_m: float = 0.12
    mudguard_bolt_pitch_x_m: float = 0.29
    mudguard_bolt_pitch_z_m: float = 0.14
    # local mesh sizes
    joint_maxh_m: float = 0.03
    rubber_maxh_m: float = 0.04
    bracket_maxh_m: float = 0.08

    def __post_init__(self) -> None:
        if self.joint_model not in JOINT_MODELS:
            raise InputError(
                f"joint_model = {self.joint_model!r}; expected one of {list(JOINT_MODELS)}"
            )
        if not (math.isfinite(self.water_mass_per_tank_kg) and self.water_mass_per_tank_kg >= 0):
            raise InputError(
                f"water_mass_per_tank_kg = {self.water_mass_per_tank_kg!r}; "
                "expected a finite non-negative mass"
            )
        signed = {
            "side_member_front_x_m", "side_member_rear_x_m", "side_member_bottom_z_m",
            "inner_channel_front_x_m", "inner_channel_rear_x_m", "drive_pad_x_m",
            "strut_pad_y_m", "mudguard_x_m", "tank_bracket_rib_bottom_z_m",
        }
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if not f.name.endswith("_m") or f.name in signed:
                continue
            values = value if isinstance(value, tuple) else (value,)
            ranged = f.name in {"tank_x_m", "tank_z_m", "cross_member_x_m", "tank_bracket_x_m"}
            for v in values:
                if not isinstance(v, (int, float)) or not math.isfinite(v):
                    raise InputError(f"{f.name} = {value!r}; expected finite numbers")
                if not ranged and v <= 0:
                    raise InputError(f"{f.name} = {value!r}; expected a positive size")
        for name in ("tank_x_m", "tank_y_m", "tank_z_m", "tank_bracket_plate_z_m"):
            lo, hi = getattr(self, name)
            if not hi > lo:
                raise InputError(f"{name} = {(lo, hi)!r}; expected (low, high) with high > low")
        if len(self.cross_member_x_m) != len(self.cross_member_materials):
            raise InputError(
                f"cross_member_materials has {len(self.cross_member_materials)} entries for "
                f"{len(self.cross_member_x_m)} cross members; expected one per cross member"
            )
        for m in self.cross_member_materials:
            if m not in MATERIALS:
                raise InputError(
                    f"cross_member_materials entry {m!r}; expected one of {sorted(MATERIALS)}"
                )
        if not isinstance(self.tank_baffles, int) or self.tank_baffles < 0:
            raise InputError(f"tank_baffles = {self.tank_baffles!r}; expected an integer >= 0")
        if self.side_member_rear_x_m <= self.side_member_front_x_m:
            raise InputError(
                f"side member x range ({self.side_member_front_x_m}, "
                f"{self.side_member_rear_x_m}); expected front < rear"
            )
        if self.washer_diameter_m <= self.bolt_diameter_m:
            raise InputError(
                f"washer_diameter_m = {self.washer_diameter_m}; expected > bolt_diameter_m "
                f"= {self.bolt_diameter_m}"
            )
        if self.clamp_diameter_m <= self.bolt_diameter_m:
            raise InputError(
                f"clamp_diameter_m = {self.clamp_diameter_m}; expected > bolt_diameter_m "
                f"= {self.bolt_diameter_m}"
            )
        if self.tank_y_m[0] <= self.side_member_web_y_m + self.joint_gap_m + (
            self.tank_bracket_plate_thickness_m
        ):
            raise InputError(
                f"tank_y_m = {self.tank_y_m!r}; the tank must clear the bracket plate "
                f"(|y| > {self.side_member_web_y_m + self.joint_gap_m:.3f} + plate thickness)"
            )


# --------------------------------------------------------------------------- results
@dataclass(frozen=True)
class Part:
    """One material region (one or more solids) of the mesh.

    Parameters
    ----------
    region : str
        Unique material label of the solids in the mesh.
    component : str
        Component the part belongs to: ``'frame'``, ``'tank_left'``,
        ``'tank_right'``, ``'bracket_left'``, ``'bracket_right'`` or
        ``'rear_foundation'``.  Joint hardware counts as ``'frame'``.
    material : str
        Key of :data:`exudyn_study.bodies.materials.MATERIALS`.
    added_mass_kg : float
        Non-structural mass smeared over the part by raising its density (the
        tank water, thesis Section 4.3): density = rho + added_mass / volume.
    """

    region: str
    component: str
    material: str
    added_mass_kg: float = 0.0

    def __post_init__(self) -> None:
        if self.material not in MATERIALS:
            raise InputError(
                f"part {self.region!r}: material {self.material!r}; "
                f"expected one of {sorted(MATERIALS)}"
            )
        if not (math.isfinite(self.added_mass_kg) and self.added_mass_kg >= 0):
            raise InputError(
                f"part {self.region!r}: added_mass_kg = {self.added_mass_kg!r}; "
                "expected a finite non-negative mass"
            )


@dataclass(frozen=True)
class InterfaceSpec:
    """A rigid (RBE2) interface patch of a body.

    Parameters
    ----------
    name : str
        Interface name, e.g. ``'front_left_drive'``, ``'tank_left_front'``.
    boundary : str
        Boundary (face) label in the mesh; the nodes on these faces form the patch.
    kind : str
        ``'rig'`` (attached to the test rig), ``'component'`` (joins Model-3
        component bodies) or ``'ground'`` (rear foundation to ground).
    center_m : tuple of float
        Nominal patch centre in m.  For component interfaces it is the centre of
        the bolt pattern in the mid-plane of the joint gap, identical on the
        frame side and the component side.
    """

    name: str
    boundary: str
    kind: str
    center_m: tuple[float, float, float]


@dataclass(frozen=True)
class ChassisGeometry:
    """A meshable body: OCC geometry with named regions and interface faces.

    Parameters
    ----------
    geometry : netgen.occ.OCCGeometry
        The glued geometry; local ``maxh`` is set on joint hardware, rubber and
        brackets.
    parts : tuple of Part
        One entry per material region.
    interfaces : tuple of InterfaceSpec
        Interface patches of the body.
    volumes_m3 : Mapping[str, float]
        Exact (CAD) volume of each region in m^3.
    component : str or None
        The Model-3 component, or None for the whole assembly.
    """

    geometry: "netgen.occ.OCCGeometry"
    parts: tuple[Part, ...]
    interfaces: tuple[InterfaceSpec, ...]
    volumes_m3: Mapping[str, float] = field(default_factory=dict)
    component: str | None = None

    def generate_mesh(
        self,
        maxh: float,
        grading: float = MESH_GRADING,
        curvature_safety: float = 1.0,
        segments_per_edge: float | None = None,
    ) -> "netgen.meshing.Mesh":
        """Generate the first-order tetrahedral volume mesh.

        Parameters
        ----------
        maxh : float
            Global maximum element size in m (see :data:`MESH_SIZES`;
            :func:`mesh_parameters` gives all arguments of a named size).
        grading : float
            Netgen mesh grading in (0, 1]: how fast the element size may grow
            away from small features (default :data:`MESH_GRADING`).
        curvature_safety : float
            Netgen's ``curvaturesafety``: elements per radius on curved faces (the bolt
            circles); 1 (default, production) is half Netgen's own refinement.
        segments_per_edge : float or None
            Netgen's ``segmentsperedge`` (elements along short edges); None: Netgen's default.

        Returns
        -------
        netgen.meshing.Mesh
            First-order mesh; materials are the part regions, boundary labels
            include the interface boundaries.

        Raises
        ------
        InputError
            If ``maxh`` is not a positive finite number.
        """
        if not (isinstance(maxh, (int, float)) and math.isfinite(maxh) and maxh > 0):
            raise InputError(f"maxh = {maxh!r}; expected a positive mesh size in m")
        # closeedgefac off: thin walls would otherwise be refined to their thickness
        if not (isinstance(grading, (int, float)) and 0 < grading <= 1):
            raise InputError(f"grading = {grading!r}; expected a number in (0, 1]")
        if not (math.isfinite(curvature_safety) and curvature_safety > 0):
            raise InputError(f"curvature_safety = {curvature_safety!r}; expected a positive number")
        options = {}
        if segments_per_edge is not None:
            if not (math.isfinite(segments_per_edge) and segments_per_edge > 0):
                raise InputError(
                    f"segments_per_edge = {segments_per_edge!r}; expected a positive number or None")
            options["segmentsperedge"] = float(segments_per_edge)
        return self.geometry.GenerateMesh(
            maxh=float(maxh), grading=float(grading), closeedgefac=None,
            curvaturesafety=float(curvature_safety), **options)

    def expected_mass_kg(self, component: str | None = None) -> float:
        """Exact mass in kg (CAD volumes times density, plus smeared mass).

        Parameters
        ----------
        component : str, optional
            Restrict to the parts of this component.
        """
        total = 0.0
        for p in self.parts:
            if component is None or p.component == component:
                total += self.volumes_m3[p.region] * MATERIALS[p.material].density_kg_m3
                total += p.added_mass_kg
        return total

    def densities_kg_m3(self) -> dict[str, float]:
        """Density per region in kg/m^3, the smeared added mass included (exact volumes)."""
        return {
            p.region: MATERIALS[p.material].density_kg_m3 + p.added_mass_kg / self.volumes_m3[p.region]
            for p in self.parts
        }


# --------------------------------------------------------------------------- builder
class _Builder:
    """Collects solids with their part labels, joint hardware and interfaces."""

    def __init__(self, design: ChassisDesign, component: str | None) -> None:
        import netgen.occ as occ

        self.occ = occ
        self.d = design
        self.component = component
        self.solids: list = []
        self.parts: dict[str, Part] = {}
        self.volumes: dict[str, float] = {}
        self.interfaces: list[InterfaceSpec] = []
        self.shanks: list = []  # detailed joints: cylinders cut out of the clamped parts

    # ---- primitives
    def box(self, x, y, z):
        """Axis-aligned box from (lo, hi) ranges."""
        occ = self.occ
        return occ.Box(occ.Pnt(x[0], y[0], z[0]), occ.Pnt(x[1], y[1], z[1]))

    def ycyl(self, x, y0, z, radius, length):
        """Cylinder along +y starting at y0."""
        occ = self.occ
        return occ.Cylinder(occ.Pnt(x, y0, z), occ.Y, r=radius, h=length)

    @staticmethod
    def yrange(sign, a, b):
        """Signed y range of the |y| range (a, b) on side ``sign``."""
        lo, hi = sorted((sign * a, sign * b))
        return (lo, hi)

    def wants(self, component: str) -> bool:
        return self.component is None or self.component == component

    def add(self, shape, region: str, component: str, material: str, maxh=None,
            added_mass_kg: float = 0.0):
        shape.mat(region)
        if maxh is not None:
            shape.maxh = maxh
        self.solids.append(shape)
        part = Part(region, component, material, added_mass_kg)
        old = self.parts.get(region)
        if old is not None and (old.component, old.material) != (component, material):
            raise AssertionError(f"region {region!r} defined twice with different data")
        if old is not None:
            part = dataclasses.replace(part, added_mass_kg=old.added_mass_kg + added_mass_kg)
        self.parts[region] = part
        self.volumes[region] = self.volumes.get(region, 0.0) + shape.mass
        return shape

    # ---- joints
    def wall_inner_y(self, x: float) -> float:
        """|y| of the inner face of a side member's web at x (inner channel included)."""
        d = self.d
        y = d.side_member_web_y_m - d.outer_channel_thickness_m
        if d.inner_channel_front_x_m <= x <= d.inner_channel_rear_x_m:
            y -= d.inner_channel_thickness_m
        return y

    def bolted_joint(self, sign, x_c, z_c, pitch_x, pitch_z, face_y, direction,
                     plate_thickness, frame_thickness):
        """Joint hardware between a frame web face and a component plate.

        Parameters
        ----------
        sign : float
            -1 left, +1 right.
        x_c, z_c : float
            Centre of the 2 x 2 bolt pattern.
        face_y : float
            |y| of the frame face the component is bolted to.
        direction : float
            +1 if the component lies at larger |y| than the face, -1 otherwise.
        plate_thickness : float
            Thickness of the component's clamped plate.
        frame_thickness : float
            Thickness of the clamped frame wall (both channels where nested).
        """
        d = self.d
        g = d.joint_gap_m
        centres = [(x_c + i * pitch_x / 2, z_c + k * pitch_z / 2) for i in (-1, 1) for k in (-1, 1)]
        for xb, zb in centres:
            if d.joint_model == "simple":
                a, b = face_y, face_y + direction * g
                y0 = min(sign * a, sign * b)
                c = self.ycyl(xb, y0, zb, d.connector_diameter_m / 2, g)
                self.add(c, "joint_connectors", "frame", "steel", d.joint_maxh_m)
            else:
                rb = d.bolt_diameter_m / 2
                # contact annulus in the gap
                a, b = face_y, face_y + direction * g
                y0 = min(sign * a, sign * b)
                ring = self.ycyl(xb, y0, zb, d.clamp_diameter_m / 2, g) - self.ycyl(xb, y0, zb, rb, g)
                self.add(ring, "joint_contact", "frame", "steel", d.joint_maxh_m)
                # washers on both outer faces
                tw = d.washer_thickness_m
                outer_comp = face_y + direction * (g + plate_thickness)
                outer_frame = face_y - direction * frame_thickness
                for y_face, dirn in ((outer_comp, direction), (outer_frame, -direction)):
                    a, b = y_face, y_face + dirn * tw
                    y0 = min(sign * a, sign * b)
                    w = self.ycyl(xb, y0, zb, d.washer_diameter_m / 2, tw) - self.ycyl(xb, y0, zb, rb, tw)
                    self.add(w, "joint_washers", "frame", "steel", d.joint_maxh_m)
                # shank from washer to washer
                a = outer_frame - direction * tw
                b = outer_comp + direction * tw
                y0 = min(sign * a, sign * b)
                shank = self.ycyl(xb, y0, zb, rb, abs(b - a))
                self.shanks.append(self.ycyl(xb, y0, zb, rb, abs(b - a)))
                self.add(shank, "joint_bolts", "frame", "steel", d.joint_maxh_m)

    def component_interface(self, name, sign, x_c, z_c, face_y, direction):
        """Nominal centre of a component interface (bolt pattern centre, mid-gap)."""
        y = sign * (face_y + direction * self.d.joint_gap_m / 2)
        return InterfaceSpec(name, name, "component", (x_c, y, z_c))


def _build(design: ChassisDesign, component: str | None) -> ChassisGeometry:
    import netgen.occ as occ

    d = design
    B = _Builder(design, component)
    assembly = component is None
    web_y = d.side_member_web_y_m
    g = d.joint_gap_m
    frame_patches: list[tuple[str, float, tuple[float, float], tuple[float, float]]] = []
    component_ifaces: list[InterfaceSpec] = []

    def frame_thickness(x):
        return web_y - B.wall_inner_y(x)

    # ---------------------------------------------------------------- frame
    if B.wants("frame"):
        x0, x1 = d.side_member_front_x_m, d.side_member_rear_x_m
        z0 = d.side_member_bottom_z_m
        z1 = z0 + d.side_member_height_m
        for side, s in _SIDES.items():
            t = d.outer_channel_thickness_m
            w = d.outer_channel_flange_width_m
            outer = (
                B.box((x0, x1), B.yrange(s, web_y - t, web_y), (z0, z1))
                + B.box((x0, x1), B.yrange(s, web_y - w, web_y), (z0, z0 + t))
                + B.box((x0, x1), B.yrange(s, web_y - w, web_y), (z1 - t, z1))
            )
            B.add(outer, f"side_member_{side}_outer", "frame", "steel")
            ti = d.inner_channel_thickness_m
            wi = d.inner_channel_flange_width_m
            yo = web_y - t
            zi0, zi1 = z0 + t, z1 - t
            xi = (d.inner_channel_front_x_m, d.inner_channel_rear_x_m)
            inner = (
                B.box(xi, B.yrange(s, yo - ti, yo), (zi0, zi1))
                + B.box(xi, B.yrange(s, yo - wi, yo), (zi0, zi0 + ti))
                + B.box(xi, B.yrange(s, yo - wi, yo), (zi1 - ti, zi1))
            )
            B.add(inner, f"side_member_{side}_inner", "frame", "steel")
            # front drive attachment pad (rig interface)
            h = d.drive_pad_size_m / 2
            pad = B.box(
                (d.drive_pad_x_m - h, d.drive_pad_x_m + h),
                B.yrange(s, web_y, web_y + d.drive_pad_thickness_m),
                (d.drive_pad_z_m - h, d.drive_pad_z_m + h),
            )
            name = f"front_{side}_drive"
            (pad.faces.Max(occ.Y) if s > 0 else pad.faces.Min(occ.Y)).name = name
            B.add(pad, f"drive_pad_{side}", "frame", "steel")
            B.interfaces.append(InterfaceSpec(
                name, name, "rig",
                (d.drive_pad_x_m, s * (web_y + d.drive_pad_thickness_m), d.drive_pad_z_m)))
            # rear attachment block (rig interface)
            hx, hz = d.rear_attachment_length_m / 2, d.rear_attachment_height_m / 2
            blk = B.box(
                (d.rear_attachment_x_m - hx, d.rear_attachment_x_m + hx),
                B.yrange(s, web_y, d.rear_attachment_outer_y_m),
                (d.rear_attachment_z_m - hz, d.rear_attachment_z_m + hz),
            )
            name = f"rear_{side}"
            (blk.faces.Max(occ.Y) if s > 0 else blk.faces.Min(occ.Y)).name = name
            B.add(blk, f"rear_attachment_{side}", "frame", "steel")
            B.interfaces.append(InterfaceSpec(
                name, name, "rig",
                (d.rear_attachment_x_m, s * d.rear_attachment_outer_y_m, d.rear_attachment_z_m)))
        # front plate, welded to the side members' front ends
        tp = d.front_plate_thickness_m
        fp = B.box((x0 - tp, x0), (-web_y, web_y), (z0, d.front_plate_top_z_m))
        B.add(fp, "front_plate", "frame", "steel")
        ts = d.strut_pad_thickness_m
        sp = B.box(
            (x0 - tp - ts, x0 - tp),
            (d.strut_pad_y_m - d.strut_pad_width_m / 2, d.strut_pad_y_m + d.strut_pad_width_m / 2),
            (d.strut_pad_z_m - d.strut_pad_height_m / 2, d.strut_pad_z_m + d.strut_pad_height_m / 2),
        )
        sp.faces.Min(occ.X).name = "front_strut"
        B.add(sp, "strut_pad", "frame", "steel")
        B.interfaces.append(InterfaceSpec(
            "front_strut", "front_strut", "rig", (x0 - tp - ts, d.strut_pad_y_m, d.strut_pad_z_m)))

        # cross members, bolted to the inner faces of the webs
        cms = zip(d.cross_member_x_m, d.cross_member_materials, strict=True)
        for i, (xc, mat) in enumerate(cms, start=1):
            if mat == "cast_iron":
                hgt, fl, tw = (d.cast_cross_member_height_m, d.cast_cross_member_flange_m,
                               d.cast_cross_member_thickness_m)
            else:
                hgt, fl, tw = (d.sheet_cross_member_height_m, d.sheet_cross_member_flange_m,
                               d.sheet_cross_member_thickness_m)
            zt = d.cross_member_top_z_m
            zb = zt - hgt
            y_in = B.wall_inner_y(xc)
            te = d.cross_member_end_plate_thickness_m
            ye = y_in - g - te  # |y| of the end plates' inner faces
            we = d.cross_member_end_plate_width_m / 2
            cm = (
                B.box((xc - tw / 2, xc + tw / 2), (-ye, ye), (zb, zt))
                + B.box((xc - fl / 2, xc + fl / 2), (-ye, ye), (zb, zb + tw))
                + B.box((xc - fl / 2, xc + fl / 2), (-ye, ye), (zt - tw, zt))
                + B.box((xc - we, xc + we), (-y_in + g, -ye), (zb, zt))
                + B.box((xc - we, xc + we), (ye, y_in - g), (zb, zt))
            )
            B.add(cm, f"cross_member_{i}", "frame", mat)
            for s in _SIDES.values():
                B.bolted_joint(s, xc, (zb + zt) / 2, d.bolt_pitch_x_m, d.bolt_pitch_z_m,
                               y_in, -1.0, te, frame_thickness(xc))

        if not assembly:
            # frame-side patches of the component interfaces are imprinted below
            pass

    # ---------------------------------------------------------------- tanks
    for side, s in _SIDES.items():
        comp = f"tank_{side}"
        tb_z = d.tank_bracket_plate_z_m
        tb_zc = 0.5 * (tb_z[0] + tb_z[1])
        for label, xb in zip(("front", "rear"), d.tank_bracket_x_m, strict=True):
            iname = f"{comp}_{label}"
            hw = d.tank_bracket_plate_width_m / 2
            if B.wants(comp):
                tp = d.tank_bracket_plate_thickness_m
                plate = B.box((xb - hw, xb + hw), B.yrange(s, web_y + g, web_y + g + tp), tb_z)
                if not assembly:
                    (plate.faces.Min(occ.Y) if s > 0 else plate.faces.Max(occ.Y)).name = iname
                tr = d.tank_bracket_rib_thickness_m
                rib = B.box((xb - tr / 2, xb + tr / 2),
                            B.yrange(s, web_y + g + tp, d.tank_y_m[0]),
                            (d.tank_bracket_rib_bottom_z_m, tb_z[1]))
                B.add(plate + rib, f"{comp}_brackets", comp, "steel", d.bracket_maxh_m)
            if assembly:
                B.bolted_joint(s, xb, tb_zc, d.bolt_pitch_x_m, d.bolt_pitch_z_m, web_y, 1.0,
                               d.tank_bracket_plate_thickness_m, frame_thickness(xb))
            else:
                spec = B.component_interface(iname, s, xb, tb_zc, web_y, 1.0)
                if B.wants(comp):
                    component_ifaces.append(spec)
                if B.wants("frame"):
                    component_ifaces.append(spec)
                    frame_patches.append((iname, s, (xb - hw, xb + hw), tb_z))
        if B.wants(comp):
            tw = d.tank_wall_thickness_m
            (xa, xe), (ya, ye), (za, ze) = d.tank_x_m, d.tank_y_m, d.tank_z_m
            shell = B.box((xa, xe), B.yrange(s, ya, ye), (za, ze)) - B.box(
                (xa + tw, xe - tw), B.yrange(s, ya + tw, ye - tw), (za + tw, ze - tw))
            B.add(shell, f"{comp}_shell", comp, "steel", added_mass_kg=d.water_mass_per_tank_kg)
            nb = d.tank_baffles
            tbf = d.tank_baffle_thickness_m
            for k in range(1, nb + 1):
                xk = xa + (xe - xa) * k / (nb + 1)
                baffle = B.box((xk - tbf / 2, xk + tbf / 2), B.yrange(s, ya + tw, ye - tw),
                               (za + tw, ze - tw))
                B.add(baffle, f"{comp}_baffles", comp, "steel")

    # ---------------------------------------------------------------- mudguard brackets
    for side, s in _SIDES.items():
        comp = f"bracket_{side}"
        xc, zc = d.mudguard_x_m, d.mudguard_z_m
        hw, hh = d.mudguard_plate_width_m / 2, d.mudguard_plate_height_m / 2
        tp = d.mudguard_plate_thickness_m
        if B.wants(comp):
            plate = B.box((xc - hw, xc + hw), B.yrange(s, web_y + g, web_y + g + tp),
                          (zc - hh, zc + hh))
            if not assembly:
                (plate.faces.Min(occ.Y) if s > 0 else plate.faces.Max(occ.Y)).name = comp
            y_arm = web_y + g + tp
            if side == "left":
                # rubber bushing: frame mounting plate | rubber pad | base plate | arm
                B.add(plate, f"{comp}_mount", comp, "steel", d.bracket_maxh_m)
                rw, rh, rt = d.rubber_width_m / 2, d.rubber_height_m / 2, d.rubber_thickness_m
                rub = B.box((xc - rw, xc + rw), B.yrange(s, y_arm, y_arm + rt), (zc - rh, zc + rh))
                B.add(rub, f"{comp}_rubber", comp, "rubber", d.rubber_maxh_m)
                tbp = d.bracket_base_plate_thickness_m
                base = B.box((xc - rw, xc + rw), B.yrange(s, y_arm + rt, y_arm + rt + tbp),
                             (zc - rh, zc + rh))
                y_arm += rt + tbp
                arm_parts = [base]
            else:
                arm_parts = [plate]
            aw, ah = d.mudguard_arm_width_m / 2, d.mudguard_arm_height_m / 2
            ttp = d.mudguard_tip_plate_thickness_m
            y_tip = d.mudguard_tip_y_m
            arm = B.box((xc - aw, xc + aw), B.yrange(s, y_arm, y_tip - ttp), (zc - ah, zc + ah))
            tw2, th2 = d.mudguard_tip_plate_width_m / 2, d.mudguard_tip_plate_height_m / 2
            tip = B.box((xc - tw2, xc + tw2), B.yrange(s, y_tip - ttp, y_tip), (zc - th2, zc + th2))
            solid = arm_parts[0] + arm + tip
            B.add(solid, f"{comp}_arm", comp, "steel", d.bracket_maxh_m)
        if assembly:
            B.bolted_joint(s, xc, zc, d.mudguard_bolt_pitch_x_m, d.mudguard_bolt_pitch_z_m,
                           web_y, 1.0, tp, frame_thickness(xc))
        else:
            spec = B.component_interface(comp, s, xc, zc, web_y, 1.0)
            if B.wants(comp):
                component_ifaces.append(spec)
            if B.wants("frame"):
                component_ifaces.append(spec)
                frame_patches.append((comp, s, (xc - hw, xc + hw), (zc - hh, zc + hh)))

    # ---------------------------------------------------------------- assemble
    solids = B.solids
    if B.shanks:
        holes = occ.Glue(B.shanks) if len(B.shanks) > 1 else B.shanks[0]
        hw_regions = {"joint_bolts", "joint_washers", "joint_contact", "joint_connectors"}
        cut = []
        for sh in solids:
            region = sh.solids[0].name if sh.solids else None
            if region in hw_regions:
                cut.append(sh)
            else:
                bb = sh.bounding_box
                cut.append(sh - holes if _overlaps(bb, holes.bounding_box) else sh)
        solids = cut
    if frame_patches:
        solids = _imprint_patches(occ, B, solids, frame_patches)
    shape = occ.Glue(solids)
    geo = occ.OCCGeometry(shape)
    ifaces = tuple(B.interfaces) + tuple(component_ifaces)
    return ChassisGeometry(
        geometry=geo,
        parts=tuple(B.parts.values()),
        interfaces=ifaces,
        volumes_m3=MappingProxyType(dict(B.volumes)),
        component=component,
    )


def _overlaps(bb1, bb2) -> bool:
    (a0, a1), (b0, b1) = bb1, bb2
    return all(a0[i] <= b1[i] and b0[i] <= a1[i] for i in range(3))


def _imprint_patches(occ, B: _Builder, solids, patches):
    """Split the outer channels so each component footprint is a separate named face."""
    d = B.d
    web_y = d.side_member_web_y_m
    t = d.outer_channel_thickness_m
    out = []
    for sh in solids:
        region = sh.solids[0].name
        mine = [p for p in patches if region == f"side_member_{'left' if p[1] < 0 else 'right'}_outer"]
        if not mine:
            out.append(sh)
            continue
        rest = sh
        pieces = []
        for name, s, xr, zr in mine:
            cutter = B.box(xr, B.yrange(s, web_y - t, web_y), zr)
            piece = sh * cutter
            (piece.faces.Max(occ.Y) if s > 0 else piece.faces.Min(occ.Y)).name = name
            piece.mat(region)
            pieces.append(piece)
            rest = rest - cutter
        rest.mat(region)
        out.extend([rest, *pieces])
    return out


def chassis_geometry(design: ChassisDesign = ChassisDesign(),
                     component: str | None = None) -> ChassisGeometry:
    """Build the chassis assembly, or one of its Model-3 components, as OCC geometry.

    Parameters
    ----------
    design : ChassisDesign
        Dimensions and joint model.
    component : str, optional
        None for the whole glued assembly (Models 1 and 2; interfaces: the five
        rig interfaces), or one of :data:`COMPONENTS` for that component alone
        (Model 3): the frame carries the rig interfaces plus the six component
        interfaces; a tank carries ``'<tank>_front'`` and ``'<tank>_rear'``; a
        mudguard bracket carries one interface named like the component.

    Returns
    -------
    ChassisGeometry

    Raises
    ------
    InputError
        If ``component`` is not None and not one of :data:`COMPONENTS`.
    """
    if component is not None and component not in COMPONENTS:
        raise InputError(f"component = {component!r}; expected None or one of {list(COMPONENTS)}")
    if not isinstance(design, ChassisDesign):
        raise InputError(f"design = {design!r}; expected a ChassisDesign")
    return _build(design, component)


# --------------------------------------------------------------------------- rear foundation
@dataclass(frozen=True)
class RearFoundationDesign:
    """Dimensions of the rig's rear foundation (thesis Section 4.2, Figure 9b), in m.

    A steel pedestal per side: a base plate bolted to the floor (``'ground'``
    interface on its underside), a vertical box-section post and a head plate
    that meets the frame's rear attachment (``'rig'`` interface, coinciding with
    the frame's ``rear_left``/``rear_right`` centres), the two posts tied by a
    cross beam.
    """

    x_m: float = 2.48
    head_y_m: float = 0.535
    head_z_m: float = 0.19
    head_size_m: float = 0.14
    head_thickness_m: float = 0.02
    post_width_m: float = 0.12
    post_wall_m: float = 0.010
    post_length_y_m: float = 0.20
    floor_z_m: float = -0.60
    base_size_m: float = 0.30
    base_thickness_m: float = 0.025
    tie_height_m: float = 0.12
    tie_width_m: float = 0.10
    tie_wall_m: float = 0.008


def rear_foundation_geometry(design: RearFoundationDesign = RearFoundationDesign()) -> ChassisGeometry:
    """Build the rig's rear foundation as a separate steel body.

    Parameters
    ----------
    design : RearFoundationDesign
        Its dimensions.

    Returns
    -------
    ChassisGeometry
        Interfaces ``'ground_left'``, ``'ground_right'`` (kind ``'ground'``, the
        base plates' undersides) and ``'frame_left'``, ``'frame_right'`` (kind
        ``'rig'``, the head plates' inner faces, centred on the frame's
        ``rear_left`` and ``rear_right`` interface centres).
    """
    import netgen.occ as occ

    d = design
    B = _Builder(ChassisDesign(), "rear_foundation")
    interfaces = []
    x = d.x_m
    for side, s in _SIDES.items():
        # head plate: its inner face at |y| = head_y touches the frame's rear attachment
        h = d.head_size_m / 2
        head = B.box((x - h, x + h), B.yrange(s, d.head_y_m, d.head_y_m + d.head_thickness_m),
                     (d.head_z_m - h, d.head_z_m + h))
        name = f"frame_{side}"
        (head.faces.Min(occ.Y) if s > 0 else head.faces.Max(occ.Y)).name = name
        interfaces.append(InterfaceSpec(name, name, "rig", (x, s * d.head_y_m, d.head_z_m)))
        # post: a square tube from the base plate up to the head's top, welded to its outer face
        pw = d.post_width_m / 2
        y_post = d.head_y_m + d.head_thickness_m + pw
        z_top = d.head_z_m + h
        z_bot = d.floor_z_m + d.base_thickness_m
        post = B.box((x - pw, x + pw), B.yrange(s, y_post - pw, y_post + pw), (z_bot, z_top)) - B.box(
            (x - pw + d.post_wall_m, x + pw - d.post_wall_m),
            B.yrange(s, y_post - pw + d.post_wall_m, y_post + pw - d.post_wall_m),
            (z_bot, z_top))
        bs = d.base_size_m / 2
        base = B.box((x - bs, x + bs), B.yrange(s, y_post - bs, y_post + bs),
                     (d.floor_z_m, d.floor_z_m + d.base_thickness_m))
        gname = f"ground_{side}"
        base.faces.Min(occ.Z).name = gname
        interfaces.append(InterfaceSpec(gname, gname, "ground", (x, s * y_post, d.floor_z_m)))
        B.add(head + post + base, f"foundation_{side}", "rear_foundation", "steel")
    # tie beam between the posts, near the floor
    th, tw, tt = d.tie_height_m, d.tie_width_m / 2, d.tie_wall_m
    z0 = d.floor_z_m + d.base_thickness_m
    y_in = d.head_y_m + d.head_thickness_m
    tie = B.box((x - tw, x + tw), (-y_in, y_in), (z0, z0 + th)) - B.box(
        (x - tw + tt, x + tw - tt), (-y_in, y_in), (z0 + tt, z0 + th - tt))
    B.add(tie, "foundation_tie", "rear_foundation", "steel")
    shape = occ.Glue(B.solids)
    return ChassisGeometry(
        geometry=occ.OCCGeometry(shape),
        parts=tuple(B.parts.values()),
        interfaces=tuple(interfaces),
        volumes_m3=MappingProxyType(dict(B.volumes)),
        component="rear_foundation",
    )
