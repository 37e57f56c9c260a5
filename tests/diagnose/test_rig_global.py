"""A modal damping finding must show that the damping change is body-wide: its factors per band of the
body's modes agree, and no local element explains as much (:mod:`exudyn_study.diagnose.rig_global`)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from rig_fixtures import FRAME_SENSORS, mini_bodies  # noqa: E402


@pytest.fixture(scope="module")
def bodies():
    pytest.importorskip("exudyn")
    return mini_bodies()


def _modal_hypothesis(bodies):
    from exudyn_study.diagnose.rig_candidates import MODAL_DAMPING_MAX_HZ
    from exudyn_study.diagnose.rig_hypotheses import ModalDampingHypothesis
    from exudyn_study.model import build_model_from_bodies, linearise

    model = build_model_from_bodies(
        bodies, 1, damping="constant-2", sensors=FRAME_SENSORS, exudyn_mesh="used"
    )
    lin = linearise(model)
    handle = model.bodies["chassis"]
    idx = np.asarray(model.mbs.systemData.GetNodeLTGODE2(handle.modal_node), dtype=int)
    freq = np.asarray(handle.body.frequencies_hz, dtype=float)
    scaled = freq <= MODAL_DAMPING_MAX_HZ
    idx = idx[idx.size - freq.size:][scaled]
    return ModalDampingHypothesis("chassis", lin, idx, frequencies_hz=freq[scaled], component="chassis")


def test_the_factor_per_band_scales_each_band_of_modes_and_equals_one_factor_when_they_agree(bodies):
    """All factors equal: the body's damping exactly that of the single factor. Factors (0.5, 1, 3): each
    mode's own damping (the diagonal of the body's damping block in its modal coordinates) scaled by its
    band's factor, the coupling between two bands by the root of their product (S C S keeps C positive
    semi-definite)."""
    from exudyn_study.diagnose.rig_global import band_groups
    from exudyn_study.diagnose.rig_hypotheses import ModalDampingBandsHypothesis

    h = _modal_hypothesis(bodies)
    groups = band_groups(h.frequencies_hz)
    assert len(groups) == 3
    assert sorted(np.concatenate(groups).tolist()) == list(range(h.frequencies_hz.size))  # each mode once
    hb = ModalDampingBandsHypothesis(h, groups, [(0.0, 1.0)] * 3)
    np.testing.assert_allclose(
        hb.system([2.0, 2.0, 2.0]).full_damping, h.system([2.0]).full_damping, rtol=1e-12, atol=1e-12
    )
    factors = np.array([0.5, 1.0, 3.0])
    c0 = h.nominal.full_damping[np.ix_(h.body_indices, h.body_indices)]
    sys_b = hb.system(factors)
    c1 = sys_b.full_damping[np.ix_(h.body_indices, h.body_indices)]
    f_mode = np.empty(h.body_indices.size)
    for g, f in zip(groups, factors, strict=True):
        f_mode[g] = f
    np.testing.assert_allclose(
        c1, np.sqrt(np.outer(f_mode, f_mode)) * c0, rtol=1e-12, atol=1e-12 * np.abs(c0).max()
    )
    assert np.abs(np.diag(c0)).min() > 0.0  # every mode has damping of its own to scale
    np.testing.assert_allclose(sys_b.full_stiffness, h.nominal.full_stiffness)


def test_band_groups_and_their_verdict():
    """Modes below the band join the lowest group and those above the highest; fewer than two modes in
    the band give no groups to compare. The verdict asks a ratio and a gap in standard deviations, of
    determined factors only."""
    from exudyn_study.diagnose.rig_global import band_groups, bands_disagree

    g = band_groups([1.0, 10.0, 20.0, 30.0, 40.0, 50.0, 300.0], band_hz=(3.0, 60.0))
    assert [x.tolist() for x in g] == [[0, 1, 2], [3, 4], [5, 6]]
    assert band_groups([1.0, 10.0, 300.0], band_hz=(3.0, 60.0)) == []
    no = np.zeros(3, dtype=bool)
    assert bands_disagree([1.0, 1.2, 3.0], [0.05, 0.05, 0.1], no, 0.3) == (0, 2)
    assert bands_disagree([1.0, 1.2, 1.4], [0.01, 0.01, 0.01], no, 0.3) is None  # within the ratio
    assert bands_disagree([1.0, 2.0, 1.0], [0.2, 0.5, 0.2], no, 0.3) is None  # 2.0 +- 25 %: not 3 sigma
    assert bands_disagree([1.0, 3.0, 1.0], [0.05, 1.2, 0.05], no, 0.3) is None  # 3.0 not determined
    assert bands_disagree([0.1, 3.0, 1.0], [0.0, 0.1, 0.05], [True, False, False], 0.3) == (2, 1)


def _diagnose(bodies, augment, monkeypatch=None):
    from exudyn_study.diagnose.rig import RigDiagnosisSettings, diagnose_rig
    from exudyn_study.virtual_rig import Scenario, virtual_recording

    sc = Scenario("mini", "test", variant=1, damping="constant-2", augmentations=(augment,)).with_seed(7)
    train = virtual_recording(sc, "white-noise", 16.0, bodies=bodies, sensors=FRAME_SENSORS)
    hold = virtual_recording(sc, "test", 16.0, bodies=bodies, sensors=FRAME_SENSORS)
    # min_improvement 0.1: the factor is acceptable against the dashpot (it explains 17 %)
    st = RigDiagnosisSettings(
        train_duration_s=12.0, screen_duration_s=8.0, max_findings=1, min_improvement=0.1
    )
    return diagnose_rig(
        1, [train], [hold], damping="constant-2", bodies=bodies, sensors=FRAME_SENSORS, settings=st,
        candidates=("modal_damping",),
    )


def _per_band(d):
    return [c for c in d.metadata["candidates"] if "per_band" in c]


def test_a_modal_damping_factor_standing_in_for_a_dashpot_gives_way_to_the_local_element(bodies):
    """Truth: a 1000 N s/m dashpot to ground at ARHBZ; the catalogue offers only the chassis's modal damping
    factor, which explains 17 % at x1.22 and would be named. Per band of the chassis's modes the factors
    disagree (the dashpot damps the modes that move ARHBZ), the generic local element explains 96 %: it is
    named, at ARHBZ with its damping."""
    from exudyn_study.model import build_model_from_bodies
    from exudyn_study.physics.entries import location_point
    from exudyn_study.virtual_rig import Augment

    truth = {"stiffness_n_per_m": 0.0, "damping_n_s_per_m": 1000.0}
    d = _diagnose(bodies, Augment("ground_spring_damper", "ARHBZ", truth))
    bands = _per_band(d)
    assert bands and bands[0]["bands_disagree"]
    f = d.findings[0]
    assert f.physics == "local_element"
    model = build_model_from_bodies(
        bodies, 1, damping="constant-2", sensors=FRAME_SENSORS, exudyn_mesh="used"
    )
    assert np.linalg.norm(np.asarray(f.location["position_m"]) - location_point(model, "ARHBZ")[1]) < 0.25
    assert f.parameters["damping_n_s_per_m"]["value"] == pytest.approx(1000.0, rel=0.1)


def test_a_modal_damping_factor_kept_for_a_dashpot_is_flagged_not_body_wide(bodies, monkeypatch):
    """The same dashpot with the generic local element kept out: the factor is the round's only fit and is
    named, with a flag that its bands disagree and a local damper may explain it."""
    from dataclasses import replace

    from exudyn_study.diagnose import rig_candidates
    from exudyn_study.virtual_rig import Augment

    monkeypatch.setitem(
        rig_candidates.RIG_CANDIDATES,
        "ground_spring_damper",
        replace(rig_candidates.RIG_CANDIDATES["ground_spring_damper"], factory=lambda ctx: []),
    )
    monkeypatch.setattr(rig_candidates, "generic_local_elements", lambda ctx, n_places=6: [])
    truth = {"stiffness_n_per_m": 0.0, "damping_n_s_per_m": 1000.0}
    d = _diagnose(bodies, Augment("ground_spring_damper", "ARHBZ", truth))
    f = d.findings[0]
    assert f.physics == "modal_damping"
    assert any("per band" in x and "local damper" in x for x in f.flags)


def test_a_body_wide_modal_damping_change_keeps_its_factor_unflagged(bodies):
    """Truth: the chassis's modal damping twice the model's. The factors per band agree within 5 % and the
    finding is the modal damping factor, 2.0, with no flag."""
    from exudyn_study.virtual_rig import Augment

    d = _diagnose(bodies, Augment("modal_damping", "chassis", {"factor": 2.0, "max_frequency_hz": 200.0}))
    bands = _per_band(d)
    assert bands and not bands[0]["bands_disagree"]
    assert all(b["factor"] == pytest.approx(2.0, rel=0.05) for b in bands[0]["per_band"])
    f = d.findings[0]
    assert f.physics == "modal_damping" and not f.flags
    assert f.parameters["factor"]["value"] == pytest.approx(2.0, rel=0.02)
