"""Physics catalogue: registry and errors; each entry changes the model as its docstring says (mini frame)."""

from __future__ import annotations

import math
import sys

import numpy as np
import pytest

from exudyn_study.errors import InputError
from exudyn_study.physics import CATALOGUE, Parameter, PhysicsEntry, entry, register, unregister

sys.path.insert(0, __file__.rsplit("/", 1)[0])
from rig_fixtures import FRAME_SENSORS, mini_bodies  # noqa: E402

TWO_PI = 2 * math.pi


@pytest.fixture(scope="module")
def bodies():
    pytest.importorskip("exudyn")
    return mini_bodies()


def _model(bodies):
    from exudyn_study.model import build_model_from_bodies

    return build_model_from_bodies(bodies, 1, damping="constant-2", sensors=FRAME_SENSORS, exudyn_mesh="used")


@pytest.fixture(scope="module")
def nominal(bodies):
    from exudyn_study.model import linearise

    model = _model(bodies)
    return model, linearise(model)


def _undamped(lin):
    """Undamped frequencies (Hz) and mass-normalised shapes in the projected coordinates."""
    import scipy.linalg as sla

    w2, phi = sla.eigh(lin.stiffness, lin.mass)
    return np.sqrt(np.maximum(w2, 0.0)) / TWO_PI, phi


def test_catalogue_lists_the_implemented_entries():
    assert {"added_mass", "drive_linkage_compliance"} <= set(CATALOGUE)
    for e in CATALOGUE.values():
        assert "Signature" in e.doc and "Physics" in e.doc
        for p in e.parameters:
            assert p.lower <= p.default <= p.upper and p.unit


def test_unknown_entry_parameter_and_bounds():
    with pytest.raises(InputError,
                       match=r"physics entry 'sloshy' is unknown; the catalogue has \['added_mass'"):
        entry("sloshy")
    e = entry("added_mass")
    with pytest.raises(InputError, match=r"unknown parameter\(s\) \['mass'\]; expected \['mass_kg \[kg\]'\]"):
        e.resolve(mass=3.0)
    with pytest.raises(InputError,
                       match=r"parameter mass_kg = 900.0 kg; expected a value in \[0.01, 500\] kg"):
        e.resolve(mass_kg=900.0)
    with pytest.raises(InputError, match=r"parameter stiffness_n_per_m = nan N/m"):
        entry("drive_linkage_compliance").resolve(stiffness_n_per_m=float("nan"))
    with pytest.raises(InputError, match="has no parameter 'k'"):
        e.parameter("k")
    with pytest.raises(InputError, match="default"):
        Parameter("k", "N/m", 0.0, 1.0, 2.0)
    assert e.resolve() == {"mass_kg": 5.0}


def test_register_a_user_entry():
    """Users register their own physics: a grounded spring at a sensor node."""
    def add(model, location, params):
        import exudyn.itemInterface as eii

        from exudyn_study.physics.entries import location_point

        marker, pos = location_point(model, location)
        g = model.mbs.AddMarker(eii.MarkerBodyPosition(bodyNumber=model.rig.ground,
                                                       localPosition=pos.tolist()))
        return {"spring": model.mbs.AddObject(eii.ObjectConnectorCartesianSpringDamper(
            markerNumbers=[g, marker], stiffness=[0, 0, params["k_n_per_m"]], damping=[0, 0, 0]))}

    mine = PhysicsEntry("grounded_spring", "Physics: a support. Signature: stiffer modes.",
                        (Parameter("k_n_per_m", "N/m", 0.0, 1e9, 1e5),), add, locations="a sensor")
    register(mine)
    try:
        assert entry("grounded_spring") is mine
        with pytest.raises(InputError, match="already in the catalogue"):
            register(mine)
    finally:
        unregister("grounded_spring")
    assert "grounded_spring" not in CATALOGUE
    with pytest.raises(InputError, match="is not a physics entry"):
        register(object())


def test_bad_location_and_assembled_model(bodies):
    model = _model(bodies)
    with pytest.raises(InputError, match=r"location 'NOPE': expected a sensor name .* sensors \['ARFMZ'"):
        entry("added_mass").apply(model, "NOPE")
    with pytest.raises(InputError, match="location 'left'; expected None or 'drive_linkage'"):
        entry("drive_linkage_compliance").apply(model, "left")
    model.assemble()
    with pytest.raises(InputError, match="already assembled; apply physics before model.assemble"):
        entry("added_mass").apply(model, "ARFVZ")


def test_added_mass_adds_exactly_its_mass_and_lowers_the_modes_that_move_there(bodies, nominal):
    """Drive-shape mass grows by m |r_loc|^2 exactly; each mode drops by the Rayleigh estimate."""
    from exudyn_study.model import linearise
    from exudyn_study.model.linearisation import body_displacement_map

    model0, lin0 = nominal
    m = 0.5
    model = _model(bodies)
    applied = entry("added_mass").apply(model, "ARFVZ", mass_kg=m)
    assert applied.location == "ARFVZ" and applied.parameters["mass_kg"] == m
    lin = linearise(model)
    assert lin.size == lin0.size  # 3 coordinates, 3 constraints
    idx = np.asarray(model.mbs.systemData.GetNodeLTGODE2(applied.items["node"]), dtype=int)
    r0, r = lin0.drive_shape, lin.drive_shape
    gained = r @ lin.full_mass @ r - r0 @ lin0.full_mass @ r0
    assert gained == pytest.approx(m * float(r[idx] @ r[idx]), rel=1e-9)
    assert float(r[idx] @ r[idx]) == pytest.approx(1.0, abs=0.05)  # the lever ratio is 1

    f0, phi0 = _undamped(lin0)
    f1, _ = _undamped(lin)
    keep = (f0 > 1.0) & (f0 < 120.0)
    assert np.all(f1[keep] <= f0[keep] * (1 + 1e-9))  # added mass never raises a frequency
    # first-order (Rayleigh) shift from the nominal modes' motion at the sensor node
    att = model0.sensors["ARFVZ"]
    bidx, bmat = body_displacement_map(model0, att.body, np.array([att.node]))
    u = bmat @ (lin0.nullspace.T @ phi0)[bidx]  # (3, n_modes), phi mass-normalised
    predicted = -0.5 * m * np.sum(u**2, axis=0)
    shift = f1 / f0 - 1.0
    big = keep & (np.abs(predicted) > 1e-4)
    assert big.sum() >= 2
    np.testing.assert_allclose(shift[big], predicted[big], rtol=0.1)
    # modes that hardly move the location do not move
    small = keep & (np.abs(predicted) < 1e-6)
    assert np.all(np.abs(shift[small]) < 1e-5)


def test_added_mass_at_an_interface(bodies, nominal):
    from exudyn_study.model import linearise

    _, lin0 = nominal
    model = _model(bodies)
    applied = entry("added_mass").apply(model, "front_strut", mass_kg=10.0)
    assert applied.location == "chassis.front_strut"
    lin = linearise(model)
    f0, _ = _undamped(lin0)
    f1, _ = _undamped(lin)
    keep = (f0 > 1.0) & (f0 < 120.0)
    assert np.all(f1[keep] <= f0[keep] * (1 + 1e-9))
    assert np.max(1 - f1[keep] / f0[keep]) > 1e-3


def test_drive_linkage_compliance_adds_the_linkage_mode_the_frf_shows(bodies, nominal):
    """One more mode at ~sqrt(k / m_eff); the drive -> ARFVZ FRF has its peak there; static response kept."""
    from exudyn_study.linear.response import frf_linear
    from exudyn_study.model import linearise
    from exudyn_study.model.linearisation import system_modes

    _, lin0 = nominal
    mass = 20.0
    m_eff = float(lin0.drive_shape @ lin0.full_mass @ lin0.drive_shape) + mass  # mass the drive moves
    target_hz = 22.0  # between the mini frame's 13 Hz and 29 Hz modes
    k = (TWO_PI * target_hz) ** 2 * m_eff
    model = _model(bodies)
    applied = entry("drive_linkage_compliance").apply(model, stiffness_n_per_m=k, damping_n_s_per_m=2e3,
                                                      mass_kg=mass)
    assert applied.location == "drive_linkage"
    lin = linearise(model)
    assert lin.size == lin0.size + 1  # the lever's rotation is now a coordinate
    modes = system_modes(model, lin, max_frequency_hz=60.0)
    modes0 = system_modes(nominal[0], lin0, max_frequency_hz=60.0)
    new = [f for f in modes.frequency_hz if np.min(np.abs(modes0.frequency_hz - f)) > 0.5]
    assert len(new) >= 1
    f_new = min(new, key=lambda f: abs(f - target_hz))
    assert f_new == pytest.approx(target_hz, rel=0.05)

    f = np.arange(3.0, 60.0, 0.05)
    i = list(lin.sensor_names).index("ARFVZ")
    h = np.abs(frf_linear(lin, f)[i, 0])
    h0 = np.abs(frf_linear(lin0, f)[i, 0])
    ratio = h / h0
    assert f[np.argmax(ratio)] == pytest.approx(f_new, abs=0.3)
    assert ratio.max() > 5.0
    band = (f > 15) & (f < 27)
    assert f[band][np.argmax(h[band])] == pytest.approx(f_new, abs=0.3)
    assert ratio[f < 5.0] == pytest.approx(1.0, abs=0.1)  # the spring carries the static drive


def test_a_surface_place_is_a_surface_node_of_its_region(bodies):
    """'body@region:u' names the region's surface node at fraction u, on every model of the same body."""
    from exudyn_study.physics.entries import location_point, surface_node

    model = _model(bodies)
    flexible = model.bodies["chassis"].body
    region = sorted(flexible.region_nodes)[0]
    surface = set(np.asarray(flexible.surface_triangles).ravel().tolist())
    in_region = set(np.asarray(flexible.region_nodes[region]).tolist())
    nodes = [surface_node(model, f"chassis@{region}:{u}")[1] for u in (0.0, 0.3, 0.7, 0.999)]
    assert all(n in surface and n in in_region for n in nodes)
    assert len(set(nodes)) == 4  # fractions spread over the region
    assert surface_node(_model(bodies), f"chassis@{region}:0.3")[1] == nodes[1]
    _, pos = location_point(model, f"chassis@{region}:0.3")
    offset = model.bodies["chassis"].position_m
    assert np.allclose(pos, np.asarray(flexible.node_positions_m[nodes[1]]) + offset)
    for bad in (f"chassis@{region}:1.0", f"chassis@{region}:-0.1", "chassis@no_such_region:0.5",
                f"nobody@{region}:0.5", f"chassis@{region}:half"):
        assert surface_node(model, bad) is None
        with pytest.raises(InputError, match=r"location .*: expected .*'body@region:u'"):
            entry("added_mass").apply(_model(bodies), bad)
    applied = entry("added_mass").apply(model, f"chassis@{region}:0.3", mass_kg=2.0)
    assert applied.parameters["mass_kg"] == 2.0
