"""Joint fits on the rig path: the composite's bilinear damping, members judged one by one, the
level-dependent share that no linear error disturbs, explanations from the registry."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))


JOINTS = ("tank_left.tank_left_front", "tank_right.tank_right_front")
START = {"stiffness_n_per_m": 1e8, "rotational_stiffness_n_m_per_rad": 1e6, "damping_time_s": 1e-4}


def _modes(system):
    from exudyn_study.linear.system import state_space

    lam = np.linalg.eigvals(state_space(system)[0])
    lam = lam[(lam.imag > 0) & (np.abs(lam) < 2 * np.pi * 200)]
    order = np.argsort(np.abs(lam))
    return np.abs(lam[order]) / (2 * np.pi), -lam.real[order] / np.abs(lam[order])


def test_joint_fit_takes_a_free_damping_time_exactly(model3):
    """Two joints fitted together with their damping times free: at stiffnesses and damping times far from
    the start (damping = time x stiffness, bilinear) the composite has the system modes and damping ratios
    of a fresh build with both joints at those values. Taken affine (the product term dropped) the damping
    ratios are off by far more than the tolerance."""
    from exudyn_study.diagnose.rig_hypotheses import CompositeHypothesis, ConnectorHypothesis, model_system
    from exudyn_study.physics import entry

    members = [
        ConnectorHypothesis("joint_stiffness", key, entry("joint_stiffness"), model3, dict(START))
        for key in JOINTS
    ]
    comp = CompositeHypothesis(members, model3)
    assert len(comp.bilinear) == 2  # each joint's damping time scales its stiffness derivatives
    values = {
        JOINTS[0]: {
            "stiffness_n_per_m": 3e6,
            "rotational_stiffness_n_m_per_rad": 4e4,
            "damping_time_s": 2e-3,
        },
        JOINTS[1]: {
            "stiffness_n_per_m": 1e7,
            "rotational_stiffness_n_m_per_rad": 2e5,
            "damping_time_s": 6e-4,
        },
    }
    p = np.array([values[JOINTS[i]][n] for i, n in comp.specs])
    model = model3()
    for key in JOINTS:
        entry("joint_stiffness").apply(model, key, **values[key])
    (f_got, z_got), (f_ref, z_ref) = _modes(comp.system(p)), _modes(model_system(model))
    np.testing.assert_allclose(f_got, f_ref, rtol=1e-5)
    np.testing.assert_allclose(z_got, z_ref, rtol=2e-2, atol=1e-5)

    comp.bilinear = {}  # the affine interpolation the joint fit used before
    f_affine, z_affine = _modes(comp.system(p))
    # (modes lost to overdamping, or damping ratios far off)
    assert f_affine.size != f_ref.size or np.max(np.abs(z_affine - z_ref)) > 10 * 2e-2 * float(np.max(z_ref))


def test_a_held_hypothesis_fits_only_the_others():
    """HeldHypothesis: the held parameters stay at their values, the free ones come from ``p``."""
    from exudyn_study.diagnose.rig_hypotheses import HeldHypothesis, Hypothesis

    class Probe(Hypothesis):
        def system(self, p):
            return tuple(p)

    h = Probe(
        "x", "here", ("a", "b", "c"), ("1", "1", "1"), np.zeros(3), np.full(3, 10.0), np.array([1.0, 2, 3])
    )
    held = HeldHypothesis(h, {1: 7.0})
    assert held.names == ("a", "c")
    np.testing.assert_array_equal(held.start, [1.0, 3.0])
    assert held.system([4.0, 5.0]) == (4.0, 7.0, 5.0)


def test_the_level_dependent_share_is_blind_to_linear_model_errors():
    """One drive at 50 % and 100 % with a cubic channel: a model whose linear part is wrong (here 1.5x
    the truth's) leaves exactly the measured level-dependent share, as a linear model with the right
    linear part does; a model with the right cubic term leaves nothing."""
    from test_rig_level import _pair

    from exudyn_study.diagnose.rig_evaluate import DistortionEvaluator
    from exudyn_study.diagnose.rig_locate import level_pair

    cubic = 0.02
    lo, hi, lin = _pair(cubic)
    pair = level_pair([hi, lo])
    assert pair is not None and pair[1] is lo and pair[2] is hi and pair[0] == pytest.approx(2.0)
    ev = DistortionEvaluator(pair, ("A", "B", "C", "D"), pad_s=4.0)

    def responses(linear_factor, e):
        out = []
        for level in (0.5, 1.0):
            y = lin * level * linear_factor
            y[2] = y[2] + e * (lin[2] * level) ** 3
            out.append(y)
        return out

    residuals = {}
    for name, (factor, e) in {
        "right linear": (1.0, 0.0),
        "wrong linear": (1.5, 0.0),
        "cubic": (1.0, cubic),
        "cubic, wrong linear": (1.5, cubic),
    }.items():
        ev.ev.simulate_exact = lambda system, gains=None, f=factor, e=e: responses(f, e)
        residuals[name] = ev.residual_vector(None)
    r0 = residuals["right linear"]
    assert float(r0 @ r0) > 0
    np.testing.assert_allclose(residuals["wrong linear"], r0, atol=1e-12 * np.abs(r0).max())
    assert np.abs(residuals["cubic"]).max() < 1e-9 * np.abs(r0).max()
    # the cubic's share itself is computed on the truth's response at the pad, so a linear error there
    # scales it (first order): still far smaller than the share
    assert np.abs(residuals["cubic, wrong linear"]).max() < np.abs(r0).max()


def test_a_registered_explain_callable_writes_the_finding_text():
    """A candidate registered with ``explain`` gets its text from it; without, the values are listed."""
    from exudyn_study.diagnose.rig_candidates import (
        RIG_CANDIDATES,
        ExplainContext,
        register_rig_candidate,
    )
    from exudyn_study.diagnose.rig_explain import explain as explain_finding
    from exudyn_study.diagnose.rig_hypotheses import Hypothesis
    from exudyn_study.errors import InputError

    class Fixed(Hypothesis):
        def system(self, p):
            return None

    seen = []

    def explain(h, values, ctx):
        seen.append(ctx)
        return f"{h.location}: {values['mass_kg'][0]:.1f} kg"

    h = Fixed("added_mass", "ARHBZ", ("mass_kg",), ("kg",), np.zeros(1), np.ones(1), np.ones(1))
    original = RIG_CANDIDATES["added_mass"]
    import exudyn_study.diagnose.rig_explain as rig_explain

    rig_explain.shifted_modes, shifted = (lambda a, b: ([(10.0, 9.0)], [])), rig_explain.shifted_modes
    try:
        register_rig_candidate("added_mass", original.factory, explain=explain, replace=True)
        assert explain_finding(h, [3.25], [0.1], None, None, ["ARHBZ"]) == "ARHBZ: 3.2 kg"
        assert isinstance(seen[0], ExplainContext) and "10.00 -> 9.00 Hz" in seen[0].shifts
        register_rig_candidate("added_mass", original.factory, replace=True)
        assert (
            explain_finding(h, [3.25], [0.1], None, None, ["ARHBZ"])
            == "added_mass at ARHBZ: mass_kg = 3.25 +- 0.1 (10.00 -> 9.00 Hz)."
        )
        with pytest.raises(InputError, match="explain .* is not callable"):
            register_rig_candidate("added_mass", original.factory, explain="text", replace=True)
    finally:
        rig_explain.shifted_modes = shifted
        RIG_CANDIDATES["added_mass"] = original  # same place in the registry's order
    assert RIG_CANDIDATES["added_mass"].explain is not None


def _joint_fit_case(model3):
    """One soft tank mount (left front) in the truth; the joint-stiffness candidates of both front mounts
    (started at 1e6 N/m) with the evaluators of a joint fit: (truth, hyps, fit, hold0); ``fit(hyps,
    settings, say)`` runs the joint fit and returns (kept fits, meta)."""
    from rig_fixtures import MODEL3_SENSORS, mini_model3_bodies

    from exudyn_study.diagnose import rig_evaluate, rig_fit_together
    from exudyn_study.diagnose.rig_candidates import JOINT_RIGID
    from exudyn_study.diagnose.rig_compare import prepare, summary_error
    from exudyn_study.diagnose.rig_hypotheses import ConnectorHypothesis, model_system
    from exudyn_study.physics import entry
    from exudyn_study.virtual_rig import Augment, Scenario, virtual_recording

    truth = {"stiffness_n_per_m": 3e5, "rotational_stiffness_n_m_per_rad": 3e4, "damping_time_s": 1e-4}
    sc = Scenario(
        "mini3",
        "test",
        variant=3,
        damping="constant-2",
        augmentations=(Augment("joint_stiffness", JOINTS[0], truth),),
    ).with_seed(5)
    bodies = mini_model3_bodies()
    recs = [
        virtual_recording(sc, signal, 12.0, bodies=bodies, sensors=MODEL3_SENSORS)
        for signal in ("white-noise", "test")
    ]
    lin0 = model_system(model3())
    names = tuple(lin0.sensor_names)
    train, hold = (prepare(r, names, n) for r, n in zip(recs, ("train", "hold"), strict=True))
    pad = rig_evaluate.decay_time(lin0)
    ev_spectral = rig_evaluate.SpectralEvaluator([train], names)
    ev_train = rig_evaluate.Evaluator([train], names, pad, exact=True)
    ev_hold = rig_evaluate.Evaluator([hold], names, pad, exact=True)
    start = {"stiffness_n_per_m": 1e6, "rotational_stiffness_n_m_per_rad": 1e5, "damping_time_s": 1e-4}
    hyps = [
        ConnectorHypothesis(
            "joint_stiffness",
            key,
            entry("joint_stiffness"),
            model3,
            dict(start),
            component=key.split(".")[0],
            interface=key.split(".")[1],
            neutral=JOINT_RIGID,
            may_vanish=tuple(start),
        )
        for key in JOINTS
    ]
    r0 = ev_spectral.residual_vector(lin0)
    hold0 = float(np.mean([summary_error(e) for e in ev_hold.errors(ev_hold.simulate_exact(lin0))]))

    def fit(hyps, st, say):
        meta = {"candidates": []}
        ok = rig_fit_together.fit_together(
            hyps,
            [0.5, 0.4],
            model3,
            ev_spectral,
            ev_train,
            rig_evaluate.Evaluator([hold], names, pad),  # the members are judged on the convolution
            lin0,
            train.channels,
            [train],
            None,
            float(r0 @ r0),
            st,
            say,
            meta,
            0,
        )
        return ok, meta

    return truth, hyps, fit, hold0


def test_a_joint_fit_keeps_the_member_that_pays_and_drops_the_one_that_does_not(model3):
    """The truth has one soft tank mount (left front); a joint fit of it with a joint that is rigid in the
    truth (right front): taken out with the other refitted, the true mount costs most of the held-out
    error, the rigid one nothing, so the first is kept and the second rejected ('does not pay')."""
    from exudyn_study.diagnose.rig_settings import RigDiagnosisSettings

    truth, hyps, fit, hold0 = _joint_fit_case(model3)
    ok, meta = fit(hyps, RigDiagnosisSettings(), lambda text: None)
    verdict = {c["location"]: c for c in meta["candidates"]}
    assert verdict[JOINTS[0]]["member"]["pays"], verdict
    assert verdict[JOINTS[0]]["member"]["holdout_gain"] > 0.3
    assert not verdict[JOINTS[1]]["member"]["pays"], verdict
    assert verdict[JOINTS[1]]["rejected"] == "does not pay for itself in the joint fit"
    assert [f["h"].location for f in ok] == [JOINTS[0]]
    assert ok[0]["holdout_error"] < 0.5 * hold0
    assert ok[0]["p"][0] == pytest.approx(truth["stiffness_n_per_m"], rel=0.3)


def test_a_joint_fit_stuck_at_the_screening_optimum_is_restarted_at_the_prior(model3):
    """The best-screened member's screening optimum is a rigid mount (1e9 N/m, where the residual is flat
    in its stiffness: a fit started there stays); its prior start is 1e6 N/m. With the second start the
    soft mount is found (the lower training residual wins); without it the joint fit stays rigid and
    nothing is kept."""
    from exudyn_study.diagnose.rig_settings import RigDiagnosisSettings

    truth, hyps, fit, hold0 = _joint_fit_case(model3)
    rigid = np.array([1e9, 1e7, 1e-4])
    results = {}
    for second in (False, True):
        st = RigDiagnosisSettings(composite_prior_start=second)
        for h in hyps:
            h.start = rigid.copy()  # the screening optimum; h.prior keeps the candidate's start (1e6 N/m)
        said = []
        results[second] = fit(hyps, st, said.append)[0], said
    ok, said = results[True]
    assert any(t.strip().startswith("second start (joint_stiffness at its prior start)") for t in said), said
    assert [f["h"].location for f in ok] == [JOINTS[0]]
    assert ok[0]["p"][0] == pytest.approx(truth["stiffness_n_per_m"], rel=0.3)
    assert ok[0]["holdout_error"] < 0.5 * hold0
    stuck, _ = results[False]
    assert not any(f["h"].location == JOINTS[0] and f["p"][0] < 1e7 for f in stuck)


def test_the_pad_hardening_is_fitted_on_the_level_dependent_share_of_the_training_data():
    """Mini Model 3 whose left pad hardens (cubic), trained on the test signal at 50 % and 100 % (one drive
    at two levels inside the training data), white noise held out: no linear candidate explains the
    mismatch, the cubic is fitted on ``y_100 - 2 y_50`` and found with its value."""
    pytest.importorskip("exudyn")
    from rig_fixtures import MODEL3_SENSORS, mini_model3_bodies

    from exudyn_study.diagnose.rig import RigDiagnosisSettings, diagnose_rig
    from exudyn_study.virtual_rig import Augment, Scenario, virtual_recording

    k3 = 2e12
    sc = Scenario(
        "mini3-cubic",
        "test",
        variant=3,
        damping="constant-2",
        augmentations=(Augment("bushing_stiffening", "bracket_left", {"cubic_stiffness_n_per_m3": k3}),),
    ).with_seed(3)
    bodies = mini_model3_bodies()
    recs = {
        s: virtual_recording(sc, s, 11.0, bodies=bodies, sensors=MODEL3_SENSORS)
        for s in ("test-50", "test", "white-noise")
    }
    st = RigDiagnosisSettings(
        train_duration_s=8.0,
        screen_duration_s=8.0,
        train_duration_nonlinear_s=8.0,
        max_findings=1,
        n_fit_simulated=1,  # the best-screened nonlinear candidate only (each fit simulates in time)
    )
    d = diagnose_rig(
        3,
        [recs["test-50"], recs["test"]],
        [recs["white-noise"]],
        damping="constant-2",
        bodies=bodies,
        sensors=MODEL3_SENSORS,
        settings=st,
    )
    assert d.findings, d.unexplained
    f = d.findings[0]
    assert f.physics == "bushing_stiffening", [c for c in d.metadata["candidates"]]
    fitted = [c for c in d.metadata["candidates"] if c.get("fitted_on") == "level-dependent share"]
    assert fitted and fitted[0]["rejected"] is None
    assert f.parameters["cubic_stiffness_n_per_m3"]["value"] == pytest.approx(k3, rel=0.3)
    assert f.fit["holdout_after"] <= f.fit["holdout_before"]


#: where each member's composite is evaluated (and the second one built)
_THERE = {"rear_support_compliance": [5e6, 1e8, 2e-4], "joint_stiffness": [1e7, 3e7, 1e5, 1e-4]}


@pytest.mark.parametrize(
    "start, there",
    [
        # a rear support carried as rigid fore-aft (the entry has no longitudinal spring from 5e10 N/m on)
        ({"rear_support_compliance": [2e7, 1e11, 1e-4]}, _THERE),
        # a damping time of zero: the stiffness steps carry no damping, the composite's bilinear term is lost
        ({"rear_support_compliance": [2e7, 1e9, 0.0], "joint_stiffness": [1e8, 1e8, 1e6, 0.0]}, _THERE),
        # a joint far softer in-plane than vertically (ratio 5000), evaluated at 1e9 / 1e8 N/m: the ratio,
        # carried as the entry's stiffness_factor_z, was clipped to its bounds 1e-3..1e3 (0.9 % off)
        ({"joint_stiffness": [1e7, 5e10, 1e5, 1e-4]}, {"joint_stiffness": [1e9, 1e8, 1e6, 1e-4]}),
    ],
    ids=["rigid-support", "zero-damping-time", "clipped-ratio"],
)
def test_a_composite_built_where_an_entry_switches_equals_one_built_where_it_is_evaluated(
    model3, start, there
):
    """A joint fit's composite is affine in its members' parameters (bilinear in a connector's damping),
    so one built at any start must equal one built where it is evaluated. Built where a member's entry
    switches (a rear support carried as rigid, a damping time of zero) it did not: its modes were off by
    2.3 % in frequency and 8 points in damping ratio before the composite moved its linearisation point.
    Built where a carried value was clipped (the joint candidate's vertical/in-plane ratio) it was 0.9 %
    off before the entry's per-axis factors were bounded 1e-7..1e7."""
    from exudyn_study.diagnose.rig_candidates import joint_hypothesis, rear_support_hypothesis
    from exudyn_study.diagnose.rig_hypotheses import CompositeHypothesis
    from exudyn_study.physics import entry

    members = {
        "rear_support_compliance": rear_support_hypothesis(
            model3, entry("rear_support_compliance"), "rear_left", component="frame"
        ),
        "joint_stiffness": joint_hypothesis(
            model3, entry("joint_stiffness"), JOINTS[0], component="tank_left", interface="tank_left_front"
        ),
    }
    hs = [members[name] for name in start]
    for h in hs:
        h.start = np.array(start[h.physics], dtype=float)
    far = CompositeHypothesis(hs, model3)
    p = np.concatenate([there[h.physics] for h in hs])
    for h in hs:
        h.start = np.array(there[h.physics], dtype=float)
    here = CompositeHypothesis(hs, model3)
    f_far, z_far = _modes(far.system(p))
    f_here, z_here = _modes(here.system(p))
    n = min(f_far.size, f_here.size, 12)
    assert n >= 6
    np.testing.assert_allclose(f_far[:n], f_here[:n], rtol=1e-8)
    np.testing.assert_allclose(z_far[:n], z_here[:n], atol=1e-8)


def test_the_spectral_fit_refuses_a_model_with_an_indefinite_mass(model3):
    """A slosh mass is taken off its tank rigidly at one point (a negative-mass compensation); taken off
    beyond what the tank has there, the mass matrix is indefinite and the time response diverges, while
    an FRF still exists. The spectral residual must then count as unstable (None), or a fit goes there:
    on the per-axis thesis truth, round 1's joint fit ended with 300 + 250 kg of water sloshing and every
    member was rejected as switching the response off."""
    from rig_fixtures import MODEL3_SENSORS, mini_model3_bodies

    from exudyn_study.diagnose import rig_evaluate
    from exudyn_study.diagnose.rig_compare import prepare
    from exudyn_study.diagnose.rig_hypotheses import model_system
    from exudyn_study.physics import entry
    from exudyn_study.virtual_rig import Scenario, virtual_recording

    sc = Scenario("mini3", "test", variant=3, damping="constant-2").with_seed(5)
    rec = virtual_recording(sc, "white-noise", 8.0, bodies=mini_model3_bodies(), sensors=MODEL3_SENSORS)

    def system(slosh_mass_kg):
        model = model3()
        for tank in ("tank_left", "tank_right"):
            entry("sloshing").apply(model, tank, slosh_mass_kg=slosh_mass_kg, slosh_frequency_hz=1.5,
                                    slosh_damping_ratio=0.3, lateral_damping_factor=1.0)
        return model_system(model)

    heavy, light = system(300.0), system(50.0)  # the mini tanks have 281 kg each
    assert np.linalg.eigvalsh(0.5 * (heavy.mass + heavy.mass.T))[0] < 0.0
    names = tuple(light.sensor_names)
    ev = rig_evaluate.SpectralEvaluator([prepare(rec, names, "train")], names)

    class Fixed:
        def __init__(self, system):
            self._system = system

        def system(self, p):
            return self._system

        def gains(self, p, channels):
            return None

    assert rig_evaluate.safe_residual(Fixed(heavy), ev, rec.channels, None) is None
    r = rig_evaluate.safe_residual(Fixed(light), ev, rec.channels, None)
    assert r is not None and np.all(np.isfinite(r))


def test_the_joint_fits_further_starts_put_the_best_screened_physics_then_every_member_at_its_prior():
    """Second start: the best-screened member's physics at its prior start, the others at their screening
    optima; third (composite_all_prior_start): every member at its prior; a start equal to an earlier one
    is left out (and the next one takes its ordinal); values are clipped to the composite's bounds."""
    from types import SimpleNamespace

    from exudyn_study.diagnose.rig_fit_together import prior_starts

    members = [SimpleNamespace(physics="rear_support_compliance", prior={"k": 5.0}),
               SimpleNamespace(physics="joint_stiffness", prior={"c": 7.0, "d": 50.0}),
               SimpleNamespace(physics="rear_support_compliance", prior={"k": 6.0})]
    comp = SimpleNamespace(specs=[(0, "k"), (1, "c"), (1, "d"), (2, "k")],
                           lower=np.zeros(4), upper=np.array([10.0, 10.0, 10.0, 10.0]))
    start_a = np.array([1.0, 2.0, 3.0, 4.0])
    starts = prior_starts(comp, members, start_a, all_prior=True)
    assert [(o, w) for o, w, _ in starts] == [("second", "rear_support_compliance at its prior start"),
                                            ("third", "every member at its prior start")]
    np.testing.assert_array_equal(starts[0][2], [5.0, 2.0, 3.0, 6.0])
    np.testing.assert_array_equal(starts[1][2], [5.0, 7.0, 10.0, 6.0])  # 50 clipped to the upper bound
    np.testing.assert_array_equal(start_a, [1.0, 2.0, 3.0, 4.0])  # not changed in place
    assert [o for o, _, _ in prior_starts(comp, members, start_a, all_prior=False)] == ["second"]
    at_prior = np.array([5.0, 2.0, 3.0, 6.0])  # the top physics already at its prior: no second start
    starts = prior_starts(comp, members, at_prior, all_prior=True)
    assert [(o, w) for o, w, _ in starts] == [("second", "every member at its prior start")]
