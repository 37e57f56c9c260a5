"""Level dependence on the rig path: the model-free nonlinear share from one drive at two levels.

A linear structure driven by ``u`` and by ``u / 2`` responds with ``y`` and exactly ``y / 2``;
a cubic term ``e y^3`` leaves ``e (y^3 - 2 (y/2)^3) = 0.75 e y^3`` in ``y_100 - 2 y_50``.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal as sps

from exudyn_study.diagnose.rig_compare import RATE_HZ, RigRecording, band_filter


def _recording(name, u, y):
    from exudyn_study.model.rig import Drive

    drive = Drive()
    drive.set_signal(u, RATE_HZ)
    filt = band_filter(y)
    scale = 1.0 / np.sqrt(np.mean(filt**2, axis=1))
    return RigRecording(name, drive, y, ("A", "B", "C", "D"), float(np.std(u)), filt, scale)


def _pair(cubic):
    rng = np.random.default_rng(7)
    n = 20000
    u = sps.sosfiltfilt(sps.butter(4, (3, 60), "bandpass", fs=RATE_HZ, output="sos"), rng.standard_normal(n))
    u *= 1e-3 / np.std(u)
    # four linear "channels": resonators at different frequencies
    lin = []
    for f0 in (8.0, 15.0, 27.0, 44.0):
        b, a = sps.iirpeak(f0, 5.0, fs=RATE_HZ)
        lin.append(sps.lfilter(b, a, u) / 1e-3)

    def respond(level):
        y = np.array(lin) * level
        y[2] = y[2] + cubic * y[2] ** 3  # channel C has a cubic distortion
        return y

    return _recording("50", 0.5 * u, respond(0.5)), _recording("100", u, respond(1.0)), np.array(lin)


def test_a_linear_structure_has_no_nonlinear_share_and_a_cubic_one_has_its_exact_share():
    from exudyn_study.diagnose.rig_locate import distortion_shares

    lo, hi, _ = _pair(0.0)
    share, strong = distortion_shares([lo, hi])
    assert strong is hi
    assert share.max() < 1e-9  # exactly scaled responses: nothing level dependent

    cubic = 0.02
    lo, hi, lin = _pair(cubic)
    share, strong = distortion_shares([lo, hi])
    expected = np.sqrt(np.mean(band_filter(0.75 * cubic * lin[2] ** 3) ** 2)) * hi.scale[2]
    assert share[2] == pytest.approx(expected, rel=1e-6)
    assert share[2] > 0.005 and np.delete(share, 2).max() < 1e-9


def test_drives_that_are_not_scaled_copies_give_no_share():
    from exudyn_study.diagnose.rig_locate import distortion_shares

    lo, hi, _ = _pair(0.02)
    rng = np.random.default_rng(3)
    other = _recording("other", rng.permutation(hi.drive.samples), hi.measured)
    assert distortion_shares([lo, other]) is None


def test_level_dependence_is_judged_on_the_error_left_at_the_nonlinear_channel():
    """The cubic channel's nonlinear share counts once the model's error there is of its size (a linear
    finding has explained the rest), not while a large linear error hides it."""
    from exudyn_study.diagnose.rig_locate import distortion_shares, is_level_dependent

    lo, hi, lin = _pair(0.02)
    dist = distortion_shares([lo, hi])
    rows = np.arange(4)
    # model = the linear part exactly: what is left is the nonlinear share
    exact = [0.5 * lin, lin]
    assert is_level_dependent([lo, hi], exact, rows, dist)
    # model with a 50 % linear error everywhere: the nonlinear share is hidden
    wrong = [0.75 * lin, 1.5 * lin]
    assert not is_level_dependent([lo, hi], wrong, rows, dist)


def test_the_held_out_level_pair_takes_its_stronger_recording_from_the_held_out_ones():
    """A nonlinear finding fitted on the training levels is proven at a held-out level of the same drive:
    the pair's stronger recording must be held out (the weaker may be a training one)."""
    from exudyn_study.diagnose.rig_locate import level_pair

    lo, hi, _ = _pair(0.02)
    c, weak, strong, _ = level_pair([lo, hi], stronger_in=[hi])
    assert weak is lo and strong is hi and c == pytest.approx(2.0, rel=1e-9)
    assert level_pair([lo, hi], stronger_in=[lo]) is None  # the held-out one is the weaker: no pair
    assert level_pair([lo, hi], stronger_in=[]) is None
