"""The rig diagnosis's worker pool: a fit whose finite differences run on worker processes gives the
serial fit's result bit for bit, and the fitted value is the truth's. Mini frame (Model 1)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from exudyn_study.errors import InputError
from exudyn_study.virtual_rig import Augment, Scenario, virtual_recording

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from rig_fixtures import FRAME_SENSORS, mini_bodies  # noqa: E402

REAR = {"vertical_stiffness_n_per_m": 5e6, "damping_time_s": 2e-4}


@pytest.fixture(scope="module")
def bodies():
    pytest.importorskip("exudyn")
    return mini_bodies()


def _rear_support(bodies):
    """A soft rear support (truth 5e6 N/m) as a recording, and its candidate started 40 % too stiff."""
    from exudyn_study.bodies.damping import parse_damping
    from exudyn_study.diagnose.rig_candidates import _rear_support_basis
    from exudyn_study.diagnose.rig_compare import prepare
    from exudyn_study.diagnose.rig_evaluate import Evaluator
    from exudyn_study.diagnose.rig_hypotheses import ConnectorHypothesis
    from exudyn_study.model import build_model_from_bodies
    from exudyn_study.physics import entry

    scenario = Scenario(
        "mini", "test", variant=1, damping="constant-2",
        augmentations=(Augment("rear_support_compliance", "rear_left", REAR),),
    ).with_seed(5)
    train = virtual_recording(scenario, "white-noise", 16.0, bodies=bodies, sensors=FRAME_SENSORS)

    def build():
        return build_model_from_bodies(
            bodies, 1, damping=parse_damping("constant-2"), sensors=FRAME_SENSORS, exudyn_mesh="used"
        )

    h = ConnectorHypothesis(
        "rear_support_compliance",
        "rear_left",
        entry("rear_support_compliance"),
        build,
        {"vertical_stiffness_n_per_m": 7e6, "damping_time_s": 1e-4},
        basis=_rear_support_basis,
        component="frame",
        interface="foundation_rear_left",
    )
    sensor_names = tuple(build().sensors)
    recs = [prepare(train, sensor_names, "train", 12.0)]
    return h, Evaluator(recs, sensor_names, 10.0, exact=True), recs[0].channels


def test_a_fit_on_two_worker_processes_is_the_serial_fit_bit_for_bit(bodies):
    from exudyn_study.diagnose.rig_evaluate import fit_hypothesis
    from exudyn_study.diagnose.rig_pool import evaluation_pool

    h, ev, channels = _rear_support(bodies)
    start = h.start.copy()
    info_serial, info_pool = {}, {}
    serial = fit_hypothesis(h, ev, channels, 12, info=info_serial)
    h.start = start
    with evaluation_pool(2) as pool:
        assert pool.parallel
        pooled = fit_hypothesis(h, ev, channels, 12, info=info_pool, pool=pool)
    for a, b in zip(serial, pooled, strict=True):
        assert np.array_equal(a, b)
    assert np.array_equal(info_serial["jac"], info_pool["jac"])
    # and it is the right fit: the support's stiffness within 5 % of the truth
    assert serial[0][0] == pytest.approx(REAR["vertical_stiffness_n_per_m"], rel=0.05)


def test_an_evaluator_is_resent_when_its_offsets_change(bodies):
    """The nonlinear findings' correction (``offset``) is part of what the workers evaluate: a changed one
    gives another residual there too."""
    from exudyn_study.diagnose.rig_hypotheses import to_params, to_x
    from exudyn_study.diagnose.rig_pool import evaluation_pool

    h, ev, channels = _rear_support(bodies)
    x = to_x(h, h.start)
    with evaluation_pool(2) as pool:
        before = pool.mapper(h, ev, channels, (1, 0.0))(None, [x])[0]
        ev.offset = [np.full((len(r.channels), r.measured.shape[1]), 0.1) for r in ev.recs]
        ev.version += 1
        after = pool.mapper(h, ev, channels, (1, 0.0))(None, [x])[0]
    ev._filtered = {}
    assert np.array_equal(after, ev.residual_vector(h.system(to_params(h, x))))
    assert not np.array_equal(before, after)


def test_a_serial_pool_sends_nothing_and_bad_worker_counts_are_refused():
    from exudyn_study.diagnose.rig_pool import EvaluationPool
    from exudyn_study.diagnose.rig_settings import RigDiagnosisSettings

    assert EvaluationPool(1).mapper(None, None, (), (1, 0.0)) is None
    for bad in (0, 1.5, True):
        with pytest.raises(InputError, match="workers"):
            EvaluationPool(bad)
        with pytest.raises(InputError, match="workers"):
            RigDiagnosisSettings(workers=bad)
    with pytest.raises(InputError, match="scheduler"):
        RigDiagnosisSettings(scheduler=8786)
    with pytest.raises(InputError, match="no scheduler reachable"):
        EvaluationPool(2, scheduler="tcp://127.0.0.1:9")


def test_a_diagnosis_on_two_workers_is_the_serial_diagnosis(bodies):
    """Both rear supports soft (5e6 and 8e6 N/m), two findings refitted together at the end on the shorter
    records (8 of 12 s): serially and on two worker processes the same findings with the same values, bit
    for bit; both stiffnesses within 10 % of the truth; the stages' wall times recorded."""
    from dataclasses import replace

    from exudyn_study.diagnose.rig import RigDiagnosisSettings, diagnose_rig

    truth = {"rear_left": 5e6, "rear_right": 8e6}
    sc = Scenario(
        "mini", "test", variant=1, damping="constant-2",
        augmentations=tuple(
            Augment("rear_support_compliance", side, {**REAR, "vertical_stiffness_n_per_m": k})
            for side, k in truth.items()
        ),
    ).with_seed(5)
    kw = {"bodies": bodies, "sensors": FRAME_SENSORS}
    train = virtual_recording(sc, "white-noise", 16.0, **kw)
    hold = virtual_recording(sc, "test", 16.0, **kw)
    st = RigDiagnosisSettings(train_duration_s=12.0, screen_duration_s=8.0, train_duration_nonlinear_s=8.0)
    runs = [
        diagnose_rig(
            1, [train], [hold], damping="constant-2", bodies=bodies, sensors=FRAME_SENSORS, settings=s,
            candidates=("rear_support_compliance",),
        )
        for s in (st, replace(st, workers=2))
    ]
    serial, pooled = ([(f.physics, f.location["interface"], f.parameters) for f in d.findings] for d in runs)
    assert serial == pooled
    assert runs[0].metadata["final_refit"]["parameters"] == runs[1].metadata["final_refit"]["parameters"]
    assert runs[0].metadata["final_holdout_error"] == runs[1].metadata["final_holdout_error"]
    assert "8 s per recording" in runs[0].metadata["final_refit"]["evaluator"]
    found = {f.location["interface"]: f for f in runs[0].findings}
    for side, k in truth.items():
        assert found[f"foundation_{side}"].parameters["vertical_stiffness_n_per_m"]["value"] == pytest.approx(
            k, rel=0.1
        )
    assert runs[1].metadata["workers"].startswith("2 local")
    assert runs[1].metadata["worker_evaluations"] > 0 and runs[0].metadata["worker_evaluations"] == 0
    assert runs[1].metadata["cpu_s"]["local_workers"] > 0 and runs[0].metadata["cpu_s"]["diagnosis"] > 0
    stages = runs[0].metadata["stage_s"]
    assert {"setup", "compare_nominal", "final_refit", "finish"} <= set(stages)
    assert stages["rounds"] and {"locate", "screen", "fit", "prove"} <= set(stages["rounds"][0])


def test_a_fit_on_a_dask_cluster_is_the_serial_fit_bit_for_bit(bodies):
    """The same fit through a Dask scheduler (a local cluster with one worker process): the serial result."""
    distributed = pytest.importorskip("distributed")
    from exudyn_study.diagnose.rig_evaluate import fit_hypothesis
    from exudyn_study.diagnose.rig_pool import evaluation_pool

    h, ev, channels = _rear_support(bodies)
    start = h.start.copy()
    serial = fit_hypothesis(h, ev, channels, 6)
    h.start = start
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, dashboard_address=None) as cluster:
        with evaluation_pool(scheduler=cluster.scheduler_address) as pool:
            assert pool.parallel and pool.describe().startswith("Dask at tcp://")
            pooled = fit_hypothesis(h, ev, channels, 6, pool=pool)
    for a, b in zip(serial, pooled, strict=True):
        assert np.array_equal(a, b)


def test_the_place_screen_on_two_workers_is_the_serial_screen(bodies):
    """A 12 kg point mass (a screened value) at a mesh node, its exact FRF as the measurement: the
    structure-wide place screen split over two worker processes ranks the same places, elements and
    grid values as the serial screen, with the same shares (1e-12), and its best point mass is the
    truth's place."""
    from types import SimpleNamespace

    from exudyn_study.diagnose.rig_hypotheses import project
    from exudyn_study.diagnose.rig_places import screen_places, structure_places
    from exudyn_study.diagnose.rig_pool import evaluation_pool
    from exudyn_study.linear.response import frf_linear
    from exudyn_study.model import build_model_from_bodies, linearise

    model = build_model_from_bodies(
        bodies, 1, damping="constant-2", sensors=FRAME_SENSORS, exudyn_mesh="used"
    )
    lin = linearise(model)
    places = structure_places(model, spacing_m=0.2)
    k = len(places.names) // 2
    ptp = places.maps[k].T @ places.maps[k]
    f = np.linspace(3.0, 60.0, 115)
    with_mass = project(lin.full_mass + 12.0 * ptp, lin.full_damping, lin.full_stiffness, lin)
    h_true = frf_linear(with_mass, f)[:, 0]
    ev = SimpleNamespace(
        recs=[SimpleNamespace(channels=tuple(lin.sensor_names))], f=f,
        log_h=[np.log(np.abs(h_true))], weight=[np.ones(h_true.shape)],
    )
    serial = screen_places(lin, places, ev)
    with evaluation_pool(2) as pool:
        pooled = screen_places(lin, places, ev, pool=pool)
        assert not pool._contexts  # the scorer sent for this screen only
    assert [(b["place"], b["kind"], b["values"]) for b in serial] == [
        (b["place"], b["kind"], b["values"]) for b in pooled
    ]
    np.testing.assert_allclose([b["share"] for b in pooled], [b["share"] for b in serial], rtol=0, atol=1e-12)
    best_mass = next(b for b in serial if b["kind"] == "added_mass")
    assert best_mass["place"] == places.names[k] and best_mass["share"] > 0.99


def test_the_candidate_screen_on_two_workers_is_the_serial_screen(bodies):
    """A soft rear support recorded; a screen of point candidates (a mass, a resonator, a spring-damper to
    ground at three mesh nodes) and the support's own candidate on two worker processes: the serial scores
    and screening starts to 1e-12, the support ranked first. A point candidate is sent without its dense
    matrices (its pickle smaller than one n_q x n_q matrix) and rebuilds the same system."""
    import pickle

    from exudyn_study.diagnose.rig_candidates import point_hypothesis
    from exudyn_study.diagnose.rig_places import structure_places
    from exudyn_study.diagnose.rig_pool import evaluation_pool
    from exudyn_study.diagnose.rig_screen import CandidateScorer, score_candidate_task
    from exudyn_study.model import build_model_from_bodies, linearise

    support, ev, channels = _rear_support(bodies)
    model = build_model_from_bodies(
        bodies, 1, damping="constant-2", sensors=FRAME_SENSORS, exudyn_mesh="used"
    )
    lin = linearise(model)
    places = structure_places(model, spacing_m=0.2)
    picks = np.linspace(0, len(places.names) - 1, 3).astype(int)
    values = {
        "added_mass": {"mass_kg": 2.0},
        "tuned_mass_damper": {"mass_kg": 1.0, "frequency_hz": 20.0, "damping_ratio": 0.05},
        "local_element": {"stiffness_n_per_m": 1e5, "damping_n_s_per_m": 50.0},
    }
    points = [
        point_hypothesis(kind, places.names[k], lin, places.maps[k], v)
        for k in picks
        for kind, v in values.items()
    ]
    for h in points:
        copy = pickle.loads(pickle.dumps(h))
        assert len(pickle.dumps(h)) - len(pickle.dumps(lin)) < lin.full_mass.nbytes
        p = h.start
        a, b = h.system(p), copy.system(p)
        np.testing.assert_array_equal(a.mass, b.mass)
        np.testing.assert_array_equal(a.stiffness, b.stiffness)
        np.testing.assert_array_equal(a.damping, b.damping)
    hyps = (support, *points)
    r0 = ev.residual_vector(lin, None)
    scorer = CandidateScorer(
        hyps=hyps, ev=ev, ev_gains=ev, channels=tuple(channels), r0=r0, r0_gains=r0, nfev=4
    )
    starts = [h.start.copy() for h in hyps]
    serial = [scorer.score(i) for i in range(len(hyps))]
    for h, s in zip(hyps, starts, strict=True):
        h.start = s
    with evaluation_pool(2) as pool:
        pooled = pool.map_shared(score_candidate_task, scorer, list(range(len(hyps))))
        assert not pool._contexts
    np.testing.assert_allclose([s for s, _ in pooled], [s for s, _ in serial], rtol=0, atol=1e-12)
    for (_, a), (_, b) in zip(pooled, serial, strict=True):
        np.testing.assert_allclose(a, b, rtol=1e-12)
    assert int(np.argmax([s for s, _ in serial])) == 0 and serial[0][0] > 0.5
