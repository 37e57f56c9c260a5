"""Chassis geometry: regions, interfaces, masses, Model-3 split, joint models.

Most checks load the committed coarse meshes (``meshes/*.vol.gz``, built by
``meshes/make_meshes.py``) and rebuild only the cheap OCC geometry for the
metadata; meshing from scratch is in the ``slow`` tests.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

ngs = pytest.importorskip("ngsolve")

from exudyn_study.bodies.fe.chassis import (  # noqa: E402
    COMPONENTS,
    ChassisDesign,
    chassis_geometry,
    mesh_parameters,
    rear_foundation_geometry,
)
from exudyn_study.bodies.materials import MATERIALS  # noqa: E402
from exudyn_study.errors import InputError  # noqa: E402

MESH_DIR = Path(__file__).resolve().parents[1] / "meshes"
# mesh vs CAD mass: straight-sided tets on planar solids are exact, only the
# bolt and connector cylinders are polygonal; 2 % is the brief's bound
MASS_RTOL = 0.02
# component interface centres on both sides of a Model-3 joint must coincide exactly
CENTER_ATOL_M = 1e-12

RIG = {"front_left_drive", "front_right_drive", "front_strut", "rear_left", "rear_right"}
COMPONENT_IFACES = {
    "frame": RIG | {"tank_left_front", "tank_left_rear", "tank_right_front", "tank_right_rear",
                    "bracket_left", "bracket_right"},
    "tank_left": {"tank_left_front", "tank_left_rear"},
    "tank_right": {"tank_right_front", "tank_right_rear"},
    "bracket_left": {"bracket_left"},
    "bracket_right": {"bracket_right"},
}


def _load(stem: str):
    path = MESH_DIR / f"{stem}_coarse.vol.gz"
    if not path.exists():
        pytest.skip(f"{path.name} not built; run python meshes/make_meshes.py")
    return ngs.Mesh(str(path))


def _geometry(stem: str):
    if stem.startswith("assembly_"):
        return chassis_geometry(ChassisDesign(joint_model=stem.split("_")[1]))
    if stem == "rear_foundation":
        return rear_foundation_geometry()
    return chassis_geometry(ChassisDesign(), stem)


STEMS = ["assembly_simple", "assembly_detailed", *COMPONENTS, "rear_foundation"]


def _mesh_mass(geo, mesh) -> float:
    total = 0.0
    for p in geo.parts:
        vol = ngs.Integrate(ngs.CF(1.0), mesh, definedon=mesh.Materials(p.region))
        assert vol > 0, f"region {p.region} is empty in the mesh"
        total += vol * MATERIALS[p.material].density_kg_m3 + p.added_mass_kg
    return total


@pytest.mark.parametrize("stem", STEMS)
def test_regions_and_interfaces_exist_in_mesh(stem):
    geo = _geometry(stem)
    mesh = _load(stem)
    regions = {p.region for p in geo.parts}
    assert len(regions) == len(geo.parts), "region labels must be unique"
    assert regions == set(mesh.GetMaterials())
    bnds = set(mesh.GetBoundaries())
    for iface in geo.interfaces:
        assert iface.boundary in bnds, iface.name
        area = ngs.Integrate(ngs.CF(1.0), mesh, ngs.BND, definedon=mesh.Boundaries(iface.boundary))
        assert area > 1e-4, f"interface {iface.name} has area {area} m^2"
    for p in geo.parts:
        vol = ngs.Integrate(ngs.CF(1.0), mesh, definedon=mesh.Materials(p.region))
        assert vol > 0, p.region


@pytest.mark.parametrize("stem", STEMS)
def test_mesh_mass_matches_cad_mass(stem):
    geo = _geometry(stem)
    mesh = _load(stem)
    assert _mesh_mass(geo, mesh) == pytest.approx(geo.expected_mass_kg(), rel=MASS_RTOL)


def test_water_included_and_assembly_mass_is_sum_of_components():
    design = ChassisDesign()
    full = chassis_geometry(design)
    water = sum(p.added_mass_kg for p in full.parts)
    assert water == pytest.approx(2 * design.water_mass_per_tank_kg)
    # the split removes only the hardware of the component joints (the frame keeps
    # its cross-member joints): every other region keeps its volume
    def structural(geo):
        return sum(geo.volumes_m3[p.region] * MATERIALS[p.material].density_kg_m3 + p.added_mass_kg
                   for p in geo.parts if not p.region.startswith("joint_"))

    comps = sum(structural(chassis_geometry(design, c)) for c in COMPONENTS)
    assert comps == pytest.approx(structural(full), rel=1e-9)


def test_rig_interfaces_of_assembly():
    from exudyn_study.virtual_rig import SURFACE_REGIONS

    for jm in ("simple", "detailed"):
        geo = chassis_geometry(ChassisDesign(joint_model=jm))
        assert {i.name for i in geo.interfaces} == RIG
        assert all(i.kind == "rig" for i in geo.interfaces)
        # the wide blind pool's places are parts of the assembly
        assert set(SURFACE_REGIONS) <= {p.region for p in geo.parts}


def test_component_interfaces_coincide_across_split():
    design = ChassisDesign()
    frame = {i.name: i for i in chassis_geometry(design, "frame").interfaces}
    assert set(frame) == COMPONENT_IFACES["frame"]
    assert len(frame) == 11  # thesis Sect. 4.5
    for comp in COMPONENTS[1:]:
        ifaces = {i.name: i for i in chassis_geometry(design, comp).interfaces}
        assert set(ifaces) == COMPONENT_IFACES[comp]
        for name, spec in ifaces.items():
            assert spec.kind == "component"
            np.testing.assert_allclose(spec.center_m, frame[name].center_m, atol=CENTER_ATOL_M)


def test_rear_foundation_meets_frame():
    frame = {i.name: i for i in chassis_geometry(ChassisDesign()).interfaces}
    rf = {i.name: i for i in rear_foundation_geometry().interfaces}
    assert {i.kind for i in rf.values()} == {"rig", "ground"}
    assert len(rf) == 4
    for side in ("left", "right"):
        np.testing.assert_allclose(rf[f"frame_{side}"].center_m, frame[f"rear_{side}"].center_m)


def test_joint_models_differ():
    simple = chassis_geometry(ChassisDesign(joint_model="simple"))
    detailed = chassis_geometry(ChassisDesign(joint_model="detailed"))
    rs = {p.region for p in simple.parts}
    rd = {p.region for p in detailed.parts}
    assert "joint_connectors" in rs and "joint_connectors" not in rd
    assert {"joint_bolts", "joint_washers", "joint_contact"} <= rd
    # the detailed joint clamps a larger area and adds washers: more hardware mass
    assert detailed.expected_mass_kg() > simple.expected_mass_kg()
    ms, md = _load("assembly_simple"), _load("assembly_detailed")
    assert ms.ne != md.ne


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"joint_model": "welded"}, "joint_model"),
        ({"outer_channel_thickness_m": 0.0}, "outer_channel_thickness_m"),
        ({"bolt_diameter_m": -0.01}, "bolt_diameter_m"),
        ({"water_mass_per_tank_kg": -1.0}, "water_mass_per_tank_kg"),
        ({"tank_x_m": (1.0, 0.5)}, "tank_x_m"),
        ({"cross_member_materials": ("steel",)}, "cross_member_materials"),
    ],
)
def test_bad_design_raises(kwargs, match):
    with pytest.raises(InputError, match=match):
        ChassisDesign(**kwargs)


def test_bad_component_and_maxh_raise():
    with pytest.raises(InputError, match="component"):
        chassis_geometry(ChassisDesign(), "engine")
    geo = chassis_geometry(ChassisDesign(), "bracket_right")
    with pytest.raises(InputError, match="maxh"):
        geo.generate_mesh(0.0)


def test_committed_meshes_are_current():
    manifest_path = MESH_DIR / "manifest.json"
    if not manifest_path.exists():
        pytest.skip("meshes not built")
    manifest = json.loads(manifest_path.read_text())
    for name, entry in manifest.items():
        if entry["size"] != "coarse" or entry["design"] is None:
            continue
        design = ChassisDesign(**{
            k: tuple(v) if isinstance(v, list) else v for k, v in entry["design"].items()})
        current = dataclasses.replace(ChassisDesign(), joint_model=design.joint_model)
        assert design == current, f"{name} was built from another design; rebuild the meshes"
        assert entry["mesh"] == mesh_parameters("coarse"), f"{name} was meshed with other settings; rebuild"


@pytest.mark.slow
@pytest.mark.parametrize("joint_model", ["simple", "detailed"])
def test_assembly_meshes_from_scratch(joint_model):
    geo = chassis_geometry(ChassisDesign(joint_model=joint_model))
    mesh = ngs.Mesh(geo.generate_mesh(**mesh_parameters("coarse")))
    assert set(mesh.GetMaterials()) == {p.region for p in geo.parts}
    assert _mesh_mass(geo, mesh) == pytest.approx(geo.expected_mass_kg(), rel=MASS_RTOL)
