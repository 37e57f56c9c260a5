"""The rig diagnosis's reuse of work gives what computing it anew gives (bit for bit where it can)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from exudyn_study.diagnose.rig_compare import RigRecording, band_filter
from exudyn_study.diagnose.rig_evaluate import Evaluator
from exudyn_study.diagnose.rig_prove import channel_damage, relative_damage


def _recording(n_channels=6, n=6000, seed=0):
    rng = np.random.default_rng(seed)
    measured = rng.standard_normal((n_channels, n))
    drive = SimpleNamespace(samples=rng.standard_normal(n) * 1e-3)
    channels = tuple(f"S{k}Z" for k in range(n_channels))
    scale = 1.0 / np.sqrt(np.mean(band_filter(measured) ** 2, axis=1))
    return RigRecording("r", drive, measured, channels, 1e-3, band_filter(measured), scale)


def _direct(r, sim):
    return band_filter(r.measured - sim) * r.scale[:, None]


def test_filtered_residual_reuses_unchanged_channels_bit_for_bit():
    r = _recording()
    ev = Evaluator([r], r.channels, pad_s=1.0)
    rng = np.random.default_rng(1)
    sim = rng.standard_normal(r.measured.shape)
    first = ev._filtered_residual(0, r, sim)
    assert np.array_equal(first, _direct(r, sim))
    faulty = sim.copy()
    faulty[2] *= -1.0  # a polarity fault: one channel changes
    faulty[4] = 0.0  # a dead channel
    again = ev._filtered_residual(0, r, faulty)
    assert np.array_equal(again, _direct(r, faulty))
    # the reference is the full simulation: the first residual is unchanged by the partial one
    assert np.array_equal(ev._filtered_residual(0, r, sim), first)
    other = rng.standard_normal(r.measured.shape)  # every channel changed: filtered anew, the new reference
    assert np.array_equal(ev._filtered_residual(0, r, other), _direct(r, other))
    nan = other.copy()
    nan[1, 5] = np.nan  # not-a-number never compares equal: that channel is filtered (and not finite)
    assert not np.all(np.isfinite(ev._filtered_residual(0, r, nan)[1]))


def test_damage_cache_gives_the_uncached_damage_and_counts_each_array_once():
    r = _recording(n=8000)
    rng = np.random.default_rng(2)
    before = [rng.standard_normal(r.measured.shape)]
    after = [0.5 * before[0]]
    cache = {}
    plain = relative_damage([r], before, after)
    cached = relative_damage([r], before, after, cache)
    assert plain == cached
    # measured, before and after: one entry per array and z channel
    assert len(cache) == 3 * len(r.channels)
    # Basquin beta 5: half the amplitude, 1/32 of the damage
    d0, d1 = channel_damage(before[0], 0), channel_damage(after[0], 0)
    assert np.isclose(d1 / d0, 0.5**5, rtol=1e-12)
    # a cached value is not reused for another array that has the same id after the first is freed
    x = rng.standard_normal((1, 8000))
    d_x = channel_damage(x, 0, cache)
    key = (id(x), 0)
    del x
    y = 2.0 * rng.standard_normal((1, 8000))
    if id(y) == key[0]:
        assert channel_damage(y, 0, cache) != d_x
    assert np.isclose(channel_damage(y, 0, cache), channel_damage(y, 0), rtol=0, atol=0)


class _Counting(Evaluator):
    """An evaluator whose simulations are stand-ins that count the nonlinear ones."""

    calls = 0

    def simulate_exact(self, lin, gains=None):
        from exudyn_study.diagnose.rig_hypotheses import NonlinearSystem

        if isinstance(lin, NonlinearSystem):
            _Counting.calls += 1
            return [np.full(r.measured.shape, 2.0) for r in self.recs]
        return [np.full(r.measured.shape, 0.5) for r in self.recs]

    def simulate(self, lin, gains=None):
        return self.simulate_exact(lin, gains)


def test_set_offsets_integrates_once_per_recordings_and_returns_to_a_recent_model():
    from exudyn_study.diagnose.rig_evaluate import set_offsets
    from exudyn_study.diagnose.rig_hypotheses import NonlinearSystem

    r, other = _recording(seed=3), _recording(seed=4)
    a, b = _Counting([r], r.channels, 1.0, exact=True), _Counting([r], r.channels, 1.0)
    c = _Counting([other], other.channels, 1.0, exact=True)
    first = NonlinearSystem(lin=object(), gather=np.zeros((1, 1)), laws=[], substeps=4)
    second = NonlinearSystem(lin=object(), gather=np.zeros((1, 1)), laws=[], substeps=4)
    _Counting.calls = 0
    set_offsets([a, b, c], first)
    assert _Counting.calls == 2  # a and b share their recording, c has its own
    for ev in (a, b, c):  # nonlinear minus linear tangent
        assert np.all(ev.offset[0] == 1.5)
    set_offsets([a, b, c], second)
    assert _Counting.calls == 4
    set_offsets([a, b, c], first)  # back to the model before: nothing integrated again
    assert _Counting.calls == 4
    assert np.all(a.offset[0] == 1.5) and ("exact", id(first)) in a._cache
    linear = object()
    set_offsets([a, b, c], linear)  # a linear model clears the offsets
    assert a.offset is None and b.offset is None and _Counting.calls == 4


def test_joint_fit_members_leave_out_point_candidates():
    from exudyn_study.diagnose.rig_fit_together import _joint_members
    from exudyn_study.diagnose.rig_settings import RigDiagnosisSettings

    def hyp(physics, location, component):
        return SimpleNamespace(
            physics=physics, location=location, component=component, kind_linear=True, carry="model",
            one_per_component=False,
        )

    hyps = [
        hyp("rear_support_compliance", "rear_left", "rear_left"),
        hyp("tuned_mass_damper", "ARHTFZH", "tank_right"),
        hyp("added_mass", "ARFVZ", "frame"),
        hyp("bushing_stiffness", "bracket_left", "bracket_left"),
        hyp("drive_linkage_compliance", None, "linkage"),
    ]
    scores = [0.5, 0.4, 0.35, 0.2, 0.1]
    st = RigDiagnosisSettings(composite_max=3)
    members = _joint_members(hyps, scores, st)
    # the two point candidates screened second and third take no place: the pad and the linkage do
    assert [h.physics for h in members] == [
        "rear_support_compliance",
        "bushing_stiffness",
        "drive_linkage_compliance",
    ]
