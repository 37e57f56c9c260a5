"""The prove stage of the rig diagnosis: acceptance per held-out channel, not on a mean over channels."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from exudyn_study.diagnose.rig_compare import summary_error
from exudyn_study.diagnose.rig_prove import channel_verdict
from exudyn_study.diagnose.rig_settings import RigDiagnosisSettings
from exudyn_study.errors import InputError

CHANNELS = tuple(f"C{i}" for i in range(10))


def test_a_mean_that_halves_while_most_channels_get_worse_is_caught():
    """One large channel dominates the quadratic mean: it falls 4.0 -> 0.2 while the nine others grow
    0.1 -> 0.6; the mean more than halves, yet 90 % of the channels are materially worse and the median
    channel got six times worse."""
    before = np.array([4.0] + [0.1] * 9)
    after = np.array([0.2] + [0.6] * 9)
    assert summary_error(after) < 0.5 * summary_error(before)
    v = channel_verdict([("hold.h5", None)], CHANNELS, [before], [after], RigDiagnosisSettings())
    assert v["n_channels"] == 10 and v["share_channels_worse"] == pytest.approx(0.9)
    assert sorted(v["channels_worse"]) == list(CHANNELS[1:])
    assert v["channels_worse"]["C1"] == (pytest.approx(0.1), pytest.approx(0.6))
    assert v["holdout_median_improvement"] == pytest.approx(1.0 - 6.0)


def test_small_changes_and_noise_level_channels_do_not_count_as_worse():
    """A channel counts as worse only above both the relative tolerance and the absolute floor: 0.5 -> 0.54
    (+8 %) and 0.05 -> 0.065 (+30 % but +0.015 < 0.02) do not; 0.5 -> 0.6 does. With two held-out
    recordings the channels are named per recording and counted over both."""
    st = RigDiagnosisSettings()
    before = [np.array([0.5, 0.05, 0.5]), np.array([0.5, 0.05, 0.5])]
    after = [np.array([0.54, 0.065, 0.3]), np.array([0.6, 0.05, 0.3])]
    v = channel_verdict([("a.h5", None), ("dir/b.h5", None)], ("X", "Y", "Z"), before, after, st)
    assert v["channels_worse"] == {"b.h5:X": (0.5, pytest.approx(0.6))}
    assert v["n_channels"] == 6 and v["share_channels_worse"] == pytest.approx(1 / 6)
    looser = dataclasses.replace(st, channel_worse_tolerance=0.25)
    assert channel_verdict([("a.h5", None), ("b.h5", None)], ("X", "Y", "Z"), before, after, looser)[
        "channels_worse"
    ] == {}


def test_settings_are_frozen_and_checked():
    st = RigDiagnosisSettings()
    with pytest.raises(dataclasses.FrozenInstanceError):
        st.max_findings = 2
    assert dataclasses.replace(st, max_findings=2).max_findings == 2
    with pytest.raises(InputError, match="max_channels_worse = 1.5"):
        RigDiagnosisSettings(max_channels_worse=1.5)
    with pytest.raises(InputError, match="fit_nfev = -1"):
        RigDiagnosisSettings(fit_nfev=-1)


def test_every_setting_is_documented():
    doc = RigDiagnosisSettings.__doc__
    for f in dataclasses.fields(RigDiagnosisSettings):
        assert f"\n    {f.name} : " in doc or f", {f.name} : " in doc or f"{f.name}, " in doc, f.name
