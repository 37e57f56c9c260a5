"""The registry of rig-diagnosis candidates: a user's own catalogue entry is found without touching the
pipeline; the joint candidates' fast systems equal a fresh linearisation of the model with the entry
applied."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from exudyn_study.errors import InputError
from exudyn_study.virtual_rig import Augment, Scenario, virtual_recording

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from rig_fixtures import FRAME_SENSORS, mini_bodies  # noqa: E402

DURATION_S = 16.0


def _add_absorber(model, location, params):
    """A point mass on an isotropic spring at a sensor node (a cable clamp or bracket that resonates)."""
    import exudyn.itemInterface as eii

    from exudyn_study.physics.entries import location_point

    marker, pos = location_point(model, location)
    mbs = model.mbs
    node = mbs.AddNode(
        eii.NodePoint(name=f"absorber:{location}", referenceCoordinates=[float(v) for v in pos])
    )
    mbs.AddObject(eii.ObjectMassPoint(nodeNumber=node, mass=params["mass_kg"]))
    m_mass = mbs.AddMarker(eii.MarkerNodePosition(nodeNumber=node))
    k = params["stiffness_n_per_m"]
    spring = mbs.AddObject(
        eii.ObjectConnectorCartesianSpringDamper(
            markerNumbers=[marker, m_mass], stiffness=[k] * 3, damping=[params["damping_n_s_per_m"]] * 3
        )
    )
    return {"spring": int(spring)}


@pytest.fixture()
def absorber_entry():
    from exudyn_study.physics import Parameter, PhysicsEntry, register, unregister

    e = register(
        PhysicsEntry(
            name="test_absorber",
            doc="A mass on a spring at a sensor node (test entry).",
            parameters=(
                Parameter("mass_kg", "kg", 0.1, 100.0, 3.0),
                Parameter("stiffness_n_per_m", "N/m", 1e3, 1e8, 5e4),
                Parameter("damping_n_s_per_m", "N s/m", 0.0, 1e3, 5.0),
            ),
            add_items=_add_absorber,
            locations="a sensor name",
        )
    )
    yield e
    unregister("test_absorber")


def test_register_rig_candidate_rejects_bad_input(absorber_entry):
    from exudyn_study.diagnose.rig import register_rig_candidate

    with pytest.raises(InputError, match="not a catalogue entry"):
        register_rig_candidate("no_such_entry", lambda ctx: [])
    with pytest.raises(InputError, match="not callable"):
        register_rig_candidate("test_absorber", 42)
    with pytest.raises(InputError, match="kind"):
        register_rig_candidate("test_absorber", lambda ctx: [], kind="quantum")
    with pytest.raises(InputError, match="already has a rig candidate"):
        register_rig_candidate("added_mass", lambda ctx: [])


def test_builtin_candidates_are_registered_with_their_kind():
    from exudyn_study.diagnose.rig_candidates import RIG_CANDIDATES

    assert {
        "added_mass",
        "drive_linkage_compliance",
        "joint_stiffness",
        "modal_damping",
        "sensor_gain",
        "rear_support_compliance",
        "sloshing",
        "bushing_stiffening",
        "joint_friction",
    } <= set(RIG_CANDIDATES)
    for name in ("bushing_stiffening", "joint_friction"):
        assert RIG_CANDIDATES[name].kind == "simulated" and RIG_CANDIDATES[name].needs_level_dependence
    assert RIG_CANDIDATES["joint_stiffness"].kind == "linear"


def test_a_user_entry_registered_as_candidate_is_found_fitted_and_improves_held_out(absorber_entry):
    """The truth carries a 4 kg absorber tuned to 20 Hz at ARHBZ; only the user's candidate can explain it."""
    pytest.importorskip("exudyn")
    from exudyn_study.diagnose.rig import RigDiagnosisSettings, diagnose_rig, register_rig_candidate
    from exudyn_study.diagnose.rig_candidates import unregister_rig_candidate
    from exudyn_study.diagnose.rig_hypotheses import AffineHypothesis

    bodies = mini_bodies()
    k_true = 4.0 * (2 * np.pi * 20.0) ** 2
    truth = {"mass_kg": 4.0, "stiffness_n_per_m": k_true, "damping_n_s_per_m": 10.0}
    sc = Scenario(
        "mini",
        "test",
        variant=1,
        damping="constant-2",
        augmentations=(Augment("test_absorber", "ARHBZ", truth),),
    ).with_seed(3)
    train = virtual_recording(sc, "white-noise", DURATION_S, bodies=bodies, sensors=FRAME_SENSORS)
    hold = virtual_recording(sc, "test", DURATION_S, bodies=bodies, sensors=FRAME_SENSORS)
    calls = []

    def factory(ctx):
        calls.append(list(ctx.located))
        return [
            AffineHypothesis(
                "test_absorber",
                s,
                ctx.entry("test_absorber"),
                ctx.build,
                {"mass_kg": 2.0, "stiffness_n_per_m": 3e4, "damping_n_s_per_m": 5.0},
                {"mass_kg": 0.5, "stiffness_n_per_m": 1e3, "damping_n_s_per_m": 1.0},
                component="frame",
                sensors=(s,),
                # a resonator: scan its tuning (2 kg, 8-50 Hz) before fitting
                screen_grid=tuple(
                    (2.0, 2.0 * (2 * np.pi * f) ** 2, 5.0) for f in (8, 11, 15, 20, 27, 36, 50)
                ),
            )
            for s in ctx.located
        ]

    register_rig_candidate("test_absorber", factory, description="test: a mass on a spring at a sensor")
    try:
        st = RigDiagnosisSettings(train_duration_s=12.0, screen_duration_s=8.0, max_findings=1)
        d = diagnose_rig(
            1,
            [train],
            [hold],
            damping="constant-2",
            bodies=bodies,
            sensors=FRAME_SENSORS,
            settings=st,
            candidates=["test_absorber"],
        )
    finally:
        unregister_rig_candidate("test_absorber")
    assert calls, "the user's factory was never asked"
    f = d.findings[0]
    assert f.physics == "test_absorber" and f.location["sensors"] == ["ARHBZ"]
    assert f.parameters["mass_kg"]["value"] == pytest.approx(4.0, rel=0.1)
    assert f.parameters["stiffness_n_per_m"]["value"] == pytest.approx(k_true, rel=0.1)
    assert f.fit["holdout_after"] < 0.5 * f.fit["holdout_before"]


def _fresh(build, name, location, values):
    from exudyn_study.diagnose.rig_hypotheses import model_system
    from exudyn_study.physics import entry

    model = build()
    entry(name).apply(model, location, **values)
    return model_system(model)


CONNECTORS = {
    "joint_stiffness": (
        "tank_left.tank_left_front",
        {"stiffness_n_per_m": 1e9, "rotational_stiffness_n_m_per_rad": 1e7, "damping_time_s": 1e-4},
        {"stiffness_n_per_m": 3e7, "rotational_stiffness_n_m_per_rad": 2e5, "damping_time_s": 2e-3},
    ),
    # the diagnosis's pad candidate (rig_candidates.PAD_FREE: rocking about x free, rocking about z and
    # torsion tied to compression and shear)
    "bushing_stiffness": (
        "bracket_left",
        None,  # rig_candidates.PAD_START
        {
            "shear_modulus_increase_pa": 2.5e6,
            "compression_modulus_increase_pa": 1.2e7,
            "rocking_modulus_increase_about_x_pa": 5.4e6,
            "damping_time_s": 1.5e-3,
        },
    ),
    # all its moduli free (rig_candidates.PAD_NAMES), carried as the entry's factors and torsion change:
    # rocking unlike compression about each axis, torsion softer than the rubber (no damping on that part)
    "bushing_stiffness:all": (
        "bracket_left",
        None,
        {
            "shear_modulus_increase_pa": 2.5e6,
            "compression_modulus_increase_pa": 1.2e7,
            "rocking_modulus_increase_about_x_pa": 9e6,
            "rocking_modulus_increase_about_z_pa": 2.6e7,
            "torsion_modulus_increase_pa": -1.2e6,
            "damping_time_s": 1.5e-3,
        },
    ),
    "rear_support_compliance": (
        "rear_left",
        {"vertical_stiffness_n_per_m": 2e7, "damping_time_s": 1e-4},
        {"vertical_stiffness_n_per_m": 6e6, "damping_time_s": 1.5e-3},
    ),
    # the diagnosis's candidate: vertical and fore-aft springs, the fore-aft one fitted as a stiffness and
    # carried as the entry's compliance
    # the diagnosis's joint candidate: the vertical stiffness apart, carried as the entry's
    # stiffness_factor_z (a tank mount soft vertically, stiff in its plane)
    "joint_stiffness:axes": ("tank_right.tank_right_front", None, {
        "stiffness_n_per_m": 1.6e8, "vertical_stiffness_n_per_m": 2e7,
        "rotational_stiffness_n_m_per_rad": 2e5, "damping_time_s": 2e-4}),
    "rear_support_compliance:xz": ("rear_left", None, {
        "vertical_stiffness_n_per_m": 6e6, "longitudinal_stiffness_n_per_m": 8e7, "damping_time_s": 1.5e-3}),
}
#: the candidates' stiffness bases (default: the joint's 6-DOF one)
BASES = {"rear_support_compliance": "_rear_support_basis"}


@pytest.mark.parametrize("physics", sorted(CONNECTORS))
def test_connector_candidate_equals_the_model_with_the_entry_applied(model3, physics):
    """The one-build candidate (stiffness and damping set on the assembled model) against a fresh build at
    other values: the same system modes and damping ratios (damping is bilinear in stiffness and damping
    time), so the same FRFs; and the entry really changes the system."""
    from exudyn_study.diagnose import rig_candidates
    from exudyn_study.diagnose.rig_hypotheses import ConnectorHypothesis, model_system
    from exudyn_study.linear.response import frf_linear
    from exudyn_study.linear.system import state_space
    from exudyn_study.physics import entry

    key, start, values = CONNECTORS[physics]
    basis = {"basis": getattr(rig_candidates, BASES[physics])} if physics in BASES else {}
    if physics.startswith("bushing_stiffness"):
        free = rig_candidates.PAD_NAMES if physics.endswith(":all") else rig_candidates.PAD_FREE
        physics = "bushing_stiffness"
        h = rig_candidates.pad_hypothesis(model3, entry(physics), free)
        assert h.names == tuple(values)
        carried = h.entry_values(values)
        if "torsion_modulus_increase_pa" in values:
            assert carried["rocking_factor_about_z"] == pytest.approx(2.6e7 / 1.2e7)
            assert carried["torsion_modulus_change_pa"] == pytest.approx(-1.2e6 - 2.5e6)
        else:  # rocking about x free; the others tied as in a bonded block: the entry's defaults
            assert carried["rocking_factor_about_x"] == pytest.approx(5.4e6 / 1.2e7)
            assert carried["rocking_factor_about_z"] == 1.0
            assert carried["torsion_modulus_change_pa"] == 0.0
    elif physics.endswith(":xz"):
        physics = "rear_support_compliance"
        h = rig_candidates.rear_support_hypothesis(model3, entry(physics), key)
        carried = h.entry_values(values)
        assert carried["longitudinal_compliance_m_per_n"] == pytest.approx(1 / 8e7)
        # the stiff end is the nominal rigid support
        assert h.entry_values({**values, "longitudinal_stiffness_n_per_m": 1e11})[
            "longitudinal_compliance_m_per_n"] == 0.0
    elif physics.endswith(":axes"):
        physics = "joint_stiffness"
        h = rig_candidates.joint_hypothesis(model3, entry(physics), key)
        carried = h.entry_values(values)
        assert carried["stiffness_factor_z"] == pytest.approx(2e7 / 1.6e8)
    else:
        h = ConnectorHypothesis(physics, key, entry(physics), model3, start, **basis)
        carried = values
    # the fitted values back from the carried entry values (the inverse of entry_values)
    np.testing.assert_allclose(h.fit_values(carried), [values[n] for n in h.names])
    ref = _fresh(model3, physics, key, carried)
    got = h.system([values[n] for n in h.names])

    def modes(system):
        lam = np.linalg.eigvals(state_space(system)[0])
        lam = lam[(lam.imag > 0) & (np.abs(lam) < 2 * np.pi * 200)]
        order = np.argsort(np.abs(lam))
        return np.abs(lam[order]) / (2 * np.pi), -lam.real[order] / np.abs(lam[order])

    (f_got, z_got), (f_ref, z_ref) = modes(got), modes(ref)
    assert f_got.size == f_ref.size > 3
    np.testing.assert_allclose(f_got, f_ref, rtol=1e-5)  # system frequencies below 200 Hz
    np.testing.assert_allclose(z_got, z_ref, rtol=1e-2, atol=1e-5)  # and damping ratios
    f = np.linspace(3.0, 60.0, 300)
    h_ref = frf_linear(ref, f)
    assert np.abs(frf_linear(got, f) - h_ref).max() <= 1e-3 * np.abs(h_ref).max()
    h_nominal = frf_linear(model_system(model3()), f)
    assert np.abs(h_nominal - h_ref).max() > 0.02 * np.abs(h_ref).max()


def test_sloshing_candidate_equals_the_model_with_the_water_at_other_values(model3):
    """Four builds give the sloshing candidate's matrices exactly: at a mass, damping ratio (overdamped,
    above the old 0.5 bound) and lateral factor far from its start, the same system modes, damping ratios
    and FRFs as a fresh build with the entry at those values (frequency fixed); and the water changes the
    response of the tank's horizontal sensors."""
    from exudyn_study.diagnose.rig_candidates import SLOSH_FREQUENCY_HZ, SLOSH_START
    from exudyn_study.diagnose.rig_hypotheses import SloshingHypothesis, model_system
    from exudyn_study.linear.response import frf_linear
    from exudyn_study.linear.system import state_space
    from exudyn_study.physics import entry

    h = SloshingHypothesis("tank_left", entry("sloshing"), model3, SLOSH_FREQUENCY_HZ, dict(SLOSH_START))
    values = {"slosh_mass_kg": 120.0, "slosh_damping_ratio": 0.9, "lateral_damping_factor": 0.4}
    carried = h.carried([values[n] for n in h.names])
    assert carried[:2] == ("sloshing", "tank_left")
    assert carried[2] == {**values, "slosh_frequency_hz": SLOSH_FREQUENCY_HZ}
    ref = _fresh(model3, "sloshing", "tank_left", carried[2])
    got = h.system([values[n] for n in h.names])
    np.testing.assert_allclose(got.mass, ref.mass, rtol=0, atol=1e-9 * np.abs(ref.mass).max())
    lam_got, lam_ref = (np.sort_complex(np.linalg.eigvals(state_space(s)[0])) for s in (got, ref))
    low = np.abs(lam_ref) < 2 * np.pi * 200
    np.testing.assert_allclose(lam_got[low], lam_ref[low], rtol=1e-5)
    f = np.linspace(3.0, 60.0, 300)
    h_ref = frf_linear(ref, f)
    assert np.abs(frf_linear(got, f) - h_ref).max() <= 1e-3 * np.abs(h_ref).max()
    h_nominal = frf_linear(model_system(model3()), f)
    x = list(ref.sensor_names).index("ATVBX")
    assert np.abs(h_nominal[x] - h_ref[x]).max() > 0.05 * np.abs(h_ref[x]).max()


def test_a_joint_fit_with_the_water_takes_its_trilinear_dampers_exactly(model3):
    """A joint fit (CompositeHypothesis) of the water in the left tank and the left rear support, both moved
    far from their starts (the slosh damper 2 zeta m omega (U_x + factor U_y) is trilinear in mass, ratio
    and factor; the support's damping bilinear): the same system poles as a fresh build with both entries."""
    from exudyn_study.diagnose import rig_candidates as rc
    from exudyn_study.diagnose.rig_hypotheses import CompositeHypothesis, SloshingHypothesis, model_system
    from exudyn_study.linear.system import state_space
    from exudyn_study.physics import entry

    slosh = SloshingHypothesis("tank_left", entry("sloshing"), model3, rc.SLOSH_FREQUENCY_HZ,
                               dict(rc.SLOSH_START))
    rear = rc.rear_support_hypothesis(model3, entry("rear_support_compliance"), "rear_left")
    comp = CompositeHypothesis([slosh, rear], model3)
    values = {
        "sloshing@tank_left:slosh_mass_kg": 90.0,
        "sloshing@tank_left:slosh_damping_ratio": 1.4,
        "sloshing@tank_left:lateral_damping_factor": 0.3,
        "rear_support_compliance@rear_left:vertical_stiffness_n_per_m": 8e6,
        "rear_support_compliance@rear_left:longitudinal_stiffness_n_per_m": 5e7,
        "rear_support_compliance@rear_left:damping_time_s": 8e-4,
    }
    p = np.array([values[n] for n in comp.names])
    model = model3()
    for h, v in zip(comp.members, comp.member_values(p), strict=True):
        name, loc, carried = h.carried(v)
        entry(name).apply(model, loc, **carried)
    ref = model_system(model)
    lam_got, lam_ref = (np.sort_complex(np.linalg.eigvals(state_space(s)[0])) for s in (comp.system(p), ref))
    low = np.abs(lam_ref) < 2 * np.pi * 200
    np.testing.assert_allclose(lam_got[low], lam_ref[low], rtol=1e-5)


def test_joint_friction_candidate_equals_the_model_with_friction(model3):
    """The friction candidate at (stuck stiffness, slip force) against a fresh build with the entry at those
    values:
    the same tangent system, element directions and Jenkins laws, hence the same time response."""
    from exudyn_study.diagnose.rig_candidates import FRICTION_START, _jenkins_laws
    from exudyn_study.diagnose.rig_hypotheses import LocalElementHypothesis
    from exudyn_study.linear.nonlinear import simulate_local_nonlinear
    from exudyn_study.model.rig import Drive
    from exudyn_study.physics import entry
    from exudyn_study.physics.entries_more import contact_normal

    key = "tank_left.tank_left_front"
    probe = model3()
    normal = contact_normal(probe, key)
    h = LocalElementHypothesis(
        "joint_friction",
        key,
        entry("joint_friction"),
        model3,
        dict(FRICTION_START),
        _jenkins_laws,
        tangent=("spring", "stiffness", lambda p: [0.0 if a == normal else float(p[0]) for a in range(3)]),
    )
    values = {"stuck_stiffness_n_per_m": 2e7, "slip_force_n": 50.0}
    ref = _fresh(model3, "joint_friction", key, values)
    got = h.system([values[n] for n in h.names])
    assert np.abs(got.lin.stiffness - ref.lin.stiffness).max() <= 1e-9 * np.abs(ref.lin.stiffness).max()
    np.testing.assert_allclose(got.gather, ref.gather, atol=1e-12)
    rng = np.random.default_rng(1)
    drive = Drive()
    drive.set_signal(np.convolve(rng.standard_normal(1500), np.ones(20) / 20, "same") * 2e-3, 1000.0)
    y_got = simulate_local_nonlinear(got.lin, drive, got.gather, got.laws, 2)
    y_ref = simulate_local_nonlinear(ref.lin, drive, ref.gather, ref.laws, 2)
    assert np.abs(y_got - y_ref).max() <= 1e-6 * np.abs(y_ref).max()
    # the contact does slip at this level: the response is not that of the stuck joint
    from exudyn_study.linear.response import simulate_linear

    y_stuck = simulate_linear(ref.lin, drive)
    assert np.abs(y_stuck - y_ref).max() > 0.01 * np.abs(y_ref).max()


def test_the_pad_finding_text_names_the_moduli_fitted_free_and_only_those():
    """The pad candidate may fit any subset of its moduli (``PAD_FREE``): the finding's text names the
    rocking and torsion moduli that were fitted and leaves out the tied ones (a KeyError before)."""
    from exudyn_study.diagnose.rig_candidates import ExplainContext, _explain_bushing_stiffness

    ctx = ExplainContext(shifts="15.0 -> 15.6 Hz", new_modes_hz=(), where="ASVZ")
    base = {"shear_modulus_increase_pa": (2.3e6, 1e5), "compression_modulus_increase_pa": (1.0e7, 4e5),
            "damping_time_s": (1.5e-3, 1e-4)}
    text = _explain_bushing_stiffness(None, dict(base, rocking_modulus_increase_about_x_pa=(4.5e6, 3e5)), ctx)
    assert "rocking modulus about x +4.5e+06" in text
    assert "about z" not in text and "torsion" not in text
    assert "rocking" not in _explain_bushing_stiffness(None, base, ctx)
