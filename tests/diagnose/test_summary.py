"""What a diagnosis says in one line and in its findings' flags: values the data do not determine are
never presented as findings, and a global entry is named without a place."""

from __future__ import annotations

import numpy as np

from exudyn_study.diagnose.rig_explain import make_finding
from exudyn_study.diagnose.rig_hypotheses import Hypothesis
from exudyn_study.diagnose.schema import NOT_IDENTIFIABLE, Diagnosis, Finding

FIT = {"train_before": 1.0, "train_after": 0.5, "holdout_before": 1.2, "holdout_after": 0.6, "metric": "rms"}


def _joint(location="tank_right_rear"):
    """A two-parameter joint (stiffness in N/m, damping time in s) at ``location``."""
    return Hypothesis(
        "joint_stiffness", location, ("stiffness_n_per_m", "damping_time_s"), ("N/m", "s"),
        np.array([1e5, 1e-6]), np.array([1e12, 1e-2]), np.array([1e8, 1e-4]),
        component="tank_right", interface=location,
    )


def _finding(p, std, at_bound=(False, False), h=None):
    return make_finding(h or _joint(), np.array(p), np.array(std), np.array(at_bound), (), (8.0, 30.0), False,
                        "text", FIT)


def test_a_finding_whose_parameters_the_data_do_not_determine_is_flagged_not_identifiable():
    """3.61e10 +- 2.3e12 N/m (std 64 times the value) and a damping time at its bound: nothing is
    determined, so the finding carries the not-identifiable flag and does not count as a finding."""
    f = _finding([3.61e10, 1e-2], [2.3e12, 0.0], at_bound=(False, True))
    assert not f.identifiable
    assert any(NOT_IDENTIFIABLE in t for t in f.flags)
    assert f.explanation.startswith("Not identifiable, not a finding")


def test_a_determined_parameter_keeps_the_finding_and_the_loose_one_is_named_with_its_value():
    """Stiffness 2e7 +- 1e6 N/m is determined (5 %); a damping time 1.867e-5 +- 2e-3 s is not: the
    finding stands, with a flag naming the loose parameter and its value."""
    f = _finding([2e7, 1.867e-5], [1e6, 2e-3])
    assert f.identifiable
    loose = [t for t in f.flags if "damping_time_s" in t]
    assert loose and "1.87e-05 +- 0.002 s" in loose[0] and "stiffness_n_per_m" not in loose[0]
    firm = _finding([2e7, 1e-3], [1e6, 1e-4])
    assert firm.identifiable and firm.flags == ()


def test_the_summary_names_identifiable_findings_and_puts_the_others_apart():
    good = _finding([2e7, 1e-3], [1e6, 1e-4], h=_joint("frame_left_front"))
    weak = _finding([3.61e10, 1e-2], [2.3e12, 0.0], at_bound=(False, True))
    d = Diagnosis(True, [good, weak], [{"location": {"sensors": ["ARHBZ"]}, "band_hz": [20, 40]}])
    text = d.summary
    assert text.startswith("joint_stiffness at frame_left_front; 1 unexplained mismatch; ")
    assert text.endswith("fitted but not identifiable (not findings): joint_stiffness at tank_right_rear")
    only_weak = Diagnosis(True, [weak], [])
    assert only_weak.summary.startswith("mismatch found, not explained; fitted but not identifiable")
    assert Diagnosis(False).summary == "no missing physics found"


def test_a_global_entry_is_named_without_a_place():
    """The drive linkage acts on the whole rig (location None): its label and its finding's place say
    so without a literal 'None'."""
    h = Hypothesis("drive_linkage_compliance", None, ("stiffness_n_per_m",), ("N/m",), np.array([1e5]),
                   np.array([1e9]), np.array([1e7]), sensors=("ARFVZ", "ARHBZ"))
    assert h.label == "drive_linkage_compliance"
    assert _joint().label == "joint_stiffness@tank_right_rear"
    f = make_finding(h, np.array([2e7]), np.array([1e6]), np.array([False]), (), None, False, "t", FIT)
    d = Diagnosis(True, [f], [])
    assert "None" not in d.summary and d.summary == "drive_linkage_compliance at ARFVZ, ARHBZ"
    assert Finding.from_dict(f.to_dict()).identifiable


def test_report_states_a_small_relative_std_as_it_is(tmp_path):
    """A damping of 5.28e5 +- 1.8e3 N s/m is 0.3 % uncertain: the page says 0.3 %, not 0 %."""
    from exudyn_study.diagnose.report import write_report

    f = _finding([2e7, 5.28e5], [1e6, 1.8e3])
    page = write_report(Diagnosis(True, [f], []), tmp_path / "r", {}).read_text(encoding="utf-8")
    assert "(±0.3%)" in page and "(±5.0%)" in page and "(±0%)" not in page
