"""``bushing_stiffening``'s compression term: the rubber pad hardening in compression, per quadrant.

On the mini Model 3 (``rig_fixtures.mini_model3_bodies``: its left bracket sits on a rubber
pad). Physics checked: the four elements act along the pad's normal on its four quadrants, a
tilt of the bracket compresses two quadrants and opens the other two (so the rocking hardens,
which the face-mean shear terms cannot see), and a sine drive gets odd harmonics at the
bracket that grow as the cube of the quadrants' compression.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

from exudyn_study.physics import entry

sys.path.insert(0, str(Path(__file__).parent))
from rig_fixtures import MODEL3_SENSORS, mini_model3_bodies  # noqa: E402

RATE_HZ = 1000.0
TWO_PI = 2.0 * math.pi


@pytest.fixture(scope="module")
def bodies3():
    pytest.importorskip("exudyn")
    return mini_model3_bodies()


def _model3(bodies):
    from exudyn_study.model import build_model_from_bodies

    return build_model_from_bodies(bodies, 3, damping="constant-2", sensors=MODEL3_SENSORS,
                                   exudyn_mesh="used")


def _pad_normal(model) -> np.ndarray:
    from exudyn_study.physics.entries_more import _rubber_body

    body = model.bodies[_rubber_body(model)].body
    x = np.asarray(body.node_positions_m)[np.asarray(body.region_nodes["bracket_left_rubber"])]
    return np.eye(3)[int(np.argmin(np.ptp(x, axis=0)))]


def test_compression_term_is_off_by_default_and_adds_four_normal_elements(bodies3):
    model = _model3(bodies3)
    entry("bushing_stiffening").apply(model, cubic_stiffness_n_per_m3=1e12)
    assert [el.name for el in model.local_nonlinearities] == ["bushing_stiffening:z", "bushing_stiffening:x"]
    model = _model3(bodies3)
    entry("bushing_stiffening").apply(model, cubic_stiffness_n_per_m3=0.0,
                                      compression_cubic_stiffness_n_per_m3=1e12)
    elements = model.local_nonlinearities
    assert [el.name for el in elements] == [f"bushing_stiffening:compression{q}" for q in range(4)]
    normal = _pad_normal(model)
    for el in elements:
        assert np.allclose(el.direction, normal) and el.law.cubic_stiffness_n_per_m3 == 1e12
    assert len({el.marker_a for el in elements}) == 4 and len({el.marker_b for el in elements}) == 4


def test_a_tilt_of_the_bracket_compresses_two_quadrants_and_opens_two(bodies3):
    """The bracket's mode that tilts the pad most: its quadrant deltas have both signs and are much larger
    than their mean (the pad's normal translation), so the compression term hardens the rocking; the mode
    that compresses the pad most (the bracket moving along the normal) has all four of one sign."""
    import scipy.linalg as sla

    from exudyn_study import modal
    from exudyn_study.physics.nonlinear import gather_vectors

    model = _model3(bodies3)
    entry("bushing_stiffening").apply(model, cubic_stiffness_n_per_m3=0.0,
                                      compression_cubic_stiffness_n_per_m3=1e12)
    lin = modal.linearize(model)
    g = gather_vectors(model) @ lin.nullspace.T  # (4, n): quadrant compression per z
    w2, phi = sla.eigh(lin.stiffness, lin.mass)
    f = np.sqrt(np.maximum(w2, 0.0)) / TWO_PI
    band = np.flatnonzero((f > 1.0) & (f < 200.0))
    d_modes = g @ phi[:, band]  # (4, n_band)
    squeeze = band[int(np.argmax(np.abs(d_modes.mean(axis=0))))]
    d = g @ phi[:, squeeze]
    assert np.all(d > 0) or np.all(d < 0), d
    k = band[int(np.argmax(np.linalg.norm(d_modes - d_modes.mean(axis=0), axis=0)))]
    d = g @ phi[:, k]
    assert k != squeeze and d.min() < 0.0 < d.max(), d
    assert abs(d.mean()) < 0.5 * np.abs(d).max(), d
    # first-order energy: a linear spring kt on each quadrant raises omega^2 by kt |G phi|^2
    kt = 1e-3 * w2[k] / np.sum(d**2)
    w2_spring = sla.eigh(lin.stiffness + kt * g.T @ g, lin.mass, eigvals_only=True)
    assert w2_spring[k] - w2[k] == pytest.approx(kt * np.sum(d**2), rel=0.02)


def test_compression_hardening_gives_odd_harmonics_growing_with_the_cube(bodies3):
    from exudyn_study import modal
    from exudyn_study.physics.nonlinear import CubicStiffening, gather_vectors, simulate_local_nonlinear

    model = _model3(bodies3)
    entry("bushing_stiffening").apply(model, cubic_stiffness_n_per_m3=0.0,
                                      compression_cubic_stiffness_n_per_m3=2e13)
    lin = modal.linearize(model)
    gather = gather_vectors(model)
    i = list(lin.sensor_names).index("ASVZ")
    f0, seconds, ramp = 5.0, 3.0, 1.0
    t = np.arange(int(round(seconds * RATE_HZ))) / RATE_HZ
    n = int(round((seconds - ramp) * RATE_HZ))
    window = np.hanning(n)
    basis = np.exp(-1j * TWO_PI * f0 * t[-n:])

    def amplitude(x, harmonic):
        return abs(2.0 / window.sum() * (x[-n:] * window) @ basis**harmonic)

    out = {}
    for level in (1e-3, 2e-3):
        envelope = np.where(t < ramp, 0.5 * (1.0 - np.cos(math.pi * t / ramp)), 1.0)
        model.drive.set_signal(level * np.sin(TWO_PI * f0 * t) * envelope, RATE_HZ)
        laws = [el.law for el in model.local_nonlinearities]
        acc, d = simulate_local_nonlinear(lin, model.drive, gather, laws, return_deltas=True)
        acc_lin = simulate_local_nonlinear(lin, model.drive, gather, [CubicStiffening(0.0)] * 4)
        nl = acc[i] - acc_lin[i]
        out[level] = {h: amplitude(nl, h) for h in (1, 2, 3)}
        out[level]["compression"] = max(amplitude(dq, 1) for dq in d)
        out[level]["fund"] = amplitude(acc[i], 1)
    lo, hi = out[1e-3], out[2e-3]
    assert hi[3] > 1e-3 * hi["fund"], hi  # a visible third harmonic at the bracket
    motion = hi["compression"] / lo["compression"]
    assert 1.8 < motion < 2.05
    assert hi[3] / lo[3] == pytest.approx(motion**3, rel=0.1)
    assert hi[2] < 0.05 * hi[3] and lo[2] < 0.05 * lo[3]  # no even harmonics
