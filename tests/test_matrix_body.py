"""The constant-matrix linear CMS body (``element='matrix'``) against the super-element body.

A change of coordinates of the same linear CMS body (interface motions as coordinates,
:func:`exudyn_study.bodies.linear_body.interface_coordinate_transformation`): the
linearised system must be the same, and the Exudyn time integration must agree with the
exact linear solution as the super-element path does (``tests/test_exudyn_path.py``).
"""

from __future__ import annotations

import sys

import numpy as np
import pytest

from exudyn_study.errors import InputError

sys.path.insert(0, __file__.rsplit("/", 1)[0])
from rig_fixtures import FRAME_SENSORS, MODEL3_SENSORS, mini_bodies, mini_model3_bodies  # noqa: E402

pytest.importorskip("exudyn")

#: relative agreement of the system frequencies and damping ratios of the two elements
#: (a change of coordinates: agreement to rounding, measured ~1e-12 on Model 1 production)
MODES_RTOL = 1e-8
#: band-limited (< 70 Hz) rms error allowed on the strong channels, as in tests/test_exudyn_path.py
RTOL_STRONG = 0.05


def _modes(model):
    from exudyn_study.model import linearise
    from exudyn_study.model.linearisation import system_modes

    lin = linearise(model)
    return lin, system_modes(model, lin, max_frequency_hz=150.0)


@pytest.mark.parametrize("variant", [1, 3])
def test_matrix_element_has_the_linearised_system_of_the_superelement(variant):
    """Same frequencies, damping ratios, sensor outputs and drive terms (Model 1 and mini Model 3)."""
    from exudyn_study.model import build_model_from_bodies

    if variant == 1:
        bodies, sensors = mini_bodies(), FRAME_SENSORS
    else:
        bodies, sensors = mini_model3_bodies(), MODEL3_SENSORS
    lin0, m0 = _modes(build_model_from_bodies(bodies, variant, damping="constant-2", sensors=sensors))
    model = build_model_from_bodies(bodies, variant, damping="constant-2", sensors=sensors, element="matrix")
    lin1, m1 = _modes(model)
    assert model.metadata["element"] == "matrix"
    assert m1.frequency_hz.size == m0.frequency_hz.size >= 5
    np.testing.assert_allclose(m1.frequency_hz, m0.frequency_hz, rtol=MODES_RTOL)
    np.testing.assert_allclose(m1.damping_ratio, m0.damping_ratio, rtol=MODES_RTOL)
    # sensor shapes (largest coefficient 1) up to the sign of each mode
    sign = np.sign(np.real(np.sum(m1.shapes * np.conj(m0.shapes), axis=0)))
    np.testing.assert_allclose(m1.shapes * sign, m0.shapes, atol=1e-6)
    scale = np.abs(lin0.sensor_drive).max()
    np.testing.assert_allclose(lin1.sensor_drive, lin0.sensor_drive, atol=1e-8 * scale)
    assert lin1.size == lin0.size


def test_matrix_element_time_integration_agrees_with_the_exact_linear_solution():
    """'exudyn' with element='matrix' vs 'linear' on the mini frame (white noise 2 s, seed 4)."""
    from exudyn_study.model import build_model_from_bodies
    from exudyn_study.simulate import IntegratorSettings, simulate
    from exudyn_study.simulate.checks import band_limited_rms_error

    def run(method, settings=None):
        model = build_model_from_bodies(mini_bodies(), 1, damping="constant-2", sensors=FRAME_SENSORS,
                                        element="matrix")
        settings = IntegratorSettings() if settings is None else settings
        rec = simulate(model, "white-noise", 2.0, method=method, seed=4, settings=settings)
        return np.array([rec.channel(n).data for n in FRAME_SENSORS])

    ref = run("linear")
    rms = np.std(ref, axis=1)
    strong = rms > 0.05 * rms.max()
    assert strong.sum() >= 6
    for settings in (IntegratorSettings(), IntegratorSettings(single_iteration=True)):
        y = run("exudyn", settings)
        err = band_limited_rms_error(y, ref)
        assert err[strong].max() < RTOL_STRONG, dict(zip(FRAME_SENSORS, np.round(100 * err, 2), strict=True))
        assert np.all(np.std(y[~strong], axis=1) < 2.0 * np.std(ref[~strong], axis=1))


def test_drive_offsets_per_step_give_the_python_offset_results(monkeypatch):
    """The drive prescribed once per step (symbolic offset) equals the Python offset function's run."""
    from exudyn_study import simulate as sim
    from exudyn_study.model import build_model_from_bodies
    from exudyn_study.simulate import exudyn_path

    model = build_model_from_bodies(mini_bodies(), 1, damping="constant-2", sensors=FRAME_SENSORS,
                                    element="matrix")
    x = sim.prepare_drive("white-noise", 1.0, seed=2)[:201]
    y_fast, _ = sim.simulate_exudyn(model, x)
    joint = model.mbs.GetObjectParameter(model.drive.joint, "offsetUserFunction")
    assert joint["type"] == "Python"  # restored after the run
    assert model.mbs.GetPreStepUserFunction() == 0
    monkeypatch.setattr(exudyn_path, "_drive_offsets_per_step", lambda *args: (lambda: None))
    y_python, _ = sim.simulate_exudyn(model, x)
    # the index-3 drive constraint turns the drive's rounding (~1e-16 m) into ~1e-7 m/s^2
    np.testing.assert_allclose(y_fast, y_python, rtol=0, atol=1e-5 * np.abs(y_python).max())


def test_node_marker_of_the_matrix_element_moves_with_the_mesh_node():
    """A point mass on a sensor node: the same linearised system with either element."""
    import exudyn.itemInterface as eii

    from exudyn_study.model import build_model_from_bodies

    def with_mass(element):
        model = build_model_from_bodies(mini_bodies(), 1, damping="constant-2", sensors=FRAME_SENSORS,
                                        element=element)
        att = model.sensors["ARFHZ"]
        handle = model.bodies[att.body]
        local = handle.__dict__.get("mesh_node_map", {}).get(att.node, att.node)
        marker = handle.node_marker(model.mbs, int(local))
        pos = np.asarray(handle.body.node_positions_m[att.node], dtype=float)
        node = model.mbs.AddNode(eii.NodePoint(referenceCoordinates=pos.tolist()))
        model.mbs.AddObject(eii.ObjectMassPoint(nodeNumber=node, mass=5.0))
        m_point = model.mbs.AddMarker(eii.MarkerNodePosition(nodeNumber=node))
        model.mbs.AddObject(eii.ObjectJointSpherical(markerNumbers=[marker, m_point]))
        return _modes(model)[1]

    m0, m1 = with_mass("superelement"), with_mass("matrix")
    np.testing.assert_allclose(m1.frequency_hz, m0.frequency_hz, rtol=MODES_RTOL)
    np.testing.assert_allclose(m1.damping_ratio, m0.damping_ratio, rtol=MODES_RTOL)


def test_element_choice_is_checked():
    from exudyn_study.model import build_model_from_bodies

    with pytest.raises(InputError, match=r"element 'beam'; expected one of \['superelement', 'matrix'\]"):
        build_model_from_bodies(mini_bodies(), 1, sensors=FRAME_SENSORS, element="beam")
    with pytest.raises(InputError, match=r"element='matrix' with formulation 'ffrf'"):
        build_model_from_bodies(mini_bodies(), 1, sensors=FRAME_SENSORS, formulation="ffrf", element="matrix")
