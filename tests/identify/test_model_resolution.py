"""The modes JSON schema and the resolution check."""

import json
import os

import numpy as np
import pytest

from exudyn_study.errors import InputError
from exudyn_study.identify import (
    ModalModel,
    Mode,
    lines_in_half_power,
    read_modes_json,
    resolution_warnings,
    suggest_resolution,
    write_modes_json,
)


def _model():
    return ModalModel(
        (Mode(21.21, 0.0119, 0.01, 0.001, 0.99, {"A": 1 + 0j, "B": -0.5 + 0.1j}),
         Mode(12.05, 0.0181, None, None, None, {"A": 0.3 - 0.2j, "B": 1.0})),
        {"estimator": "Hv"},
    )


def test_json_round_trip_sorted_and_atomic(tmp_path):
    m = _model()
    path = write_modes_json(m, tmp_path / "modes.json")
    assert os.listdir(tmp_path) == ["modes.json"]  # no temporary file left
    back = read_modes_json(path)
    assert [x.frequency_hz for x in back.modes] == [12.05, 21.21]
    assert back.modes[1].shape["B"] == -0.5 + 0.1j
    assert back.modes[0].mpc is None and back.metadata == {"estimator": "Hv"}
    np.testing.assert_array_equal(back.shapes(["A", "B"]), m.shapes(["A", "B"]))
    doc = json.loads(path.read_text())
    assert doc["modes"][0]["shape"]["A"] == [0.3, -0.2]
    assert set(doc["modes"][0]) >= {"frequency_hz", "damping_ratio", "frequency_std_hz",
                                    "damping_std", "mpc", "shape"}


def test_reads_rig_modes_without_uncertainty(tmp_path):
    # the rig's `exudyn-study modes` writes frequency, damping, description, shape only
    p = tmp_path / "rig.json"
    p.write_text(json.dumps({"modes": [{"frequency_hz": 11.9, "damping_ratio": 0.05,
                                        "description": "right fuel tank, z",
                                        "shape": {"ARFMZ": [0.1, 0.0]}}]}))
    m = read_modes_json(p)
    assert m.modes[0].description == "right fuel tank, z"
    assert m.modes[0].frequency_std_hz is None


def test_modes_json_errors(tmp_path):
    with pytest.raises(InputError, match=r"no such file"):
        read_modes_json(tmp_path / "missing.json")
    bad = tmp_path / "bad.json"
    bad.write_text('{"modes": [{"frequency_hz": -3, "damping_ratio": 0.01}]}')
    with pytest.raises(InputError, match=r"frequency_hz=-3"):
        read_modes_json(bad)
    bad.write_text('{"format": "exudyn_study.modes", "format_version": 9, "modes": []}')
    with pytest.raises(InputError, match=r"format_version 9: this version reads up to 1"):
        read_modes_json(bad)
    with pytest.raises(InputError, match=r"does not exist"):
        write_modes_json(_model(), tmp_path / "nodir" / "m.json")
    with pytest.raises(InputError, match=r"damping_ratio=1.5: expected"):
        Mode(10.0, 1.5)


def test_lines_in_half_power_bandwidth_thesis_mode_10():
    # thesis: at 0.2 Hz the 47.6 Hz / 0.53 % mode spans only ~2.5 lines
    assert lines_in_half_power(47.60, 0.0053, 0.2) == pytest.approx(2.52, abs=0.01)


def test_suggested_resolution_uses_record_length():
    f = [12.05, 47.60]
    z = [0.0181, 0.0053]
    long = suggest_resolution(f, z, duration_s=300.0)
    # narrowest half-power bandwidth: 2 * 0.0181 * 12.05 = 0.436 Hz -> 0.087 Hz -> 0.05 Hz;
    # 20 s segments, 50 % overlap in 300 s -> 29 averages
    assert long.feasible and long.resolution_hz == pytest.approx(0.05)
    assert long.lines == pytest.approx(8.72, abs=0.01) and long.n_averages == 29
    short = suggest_resolution(f, z, duration_s=80.0)
    assert not short.feasible and short.resolution_hz == pytest.approx(0.2)
    assert "0.05 Hz would be needed" in short.message and "record at least" in short.message
    msgs = resolution_warnings(f, z, 0.2, duration_s=300.0)
    assert len(msgs) == 2 and "47.60 Hz/0.53 % (2.5 lines)" in msgs[0]
    assert "12.05 Hz/1.81 % (2.2 lines)" in msgs[0]
    assert "0.05 Hz gives" in msgs[1]
    assert resolution_warnings(f, z, 0.05) == []


def test_window_corrected_damping_inverts_the_hann_broadening():
    from exudyn_study.identify.resolution import HANN_LINES, window_corrected_damping

    # a Lorentzian of width B smoothed by a kernel of width G shows the Voigt width V
    # (Olivero & Longbothum 1977); the correction gives B back
    df, f = 0.1, 20.0
    b = np.array([0.03, 0.1, 0.3, 1.0])
    g = HANN_LINES * df
    v = 0.5346 * b + np.sqrt(0.2166 * b**2 + g**2)
    np.testing.assert_allclose(window_corrected_damping(f, v / (2 * f), df), b / (2 * f), rtol=1e-9)
    # a peak no wider than the kernel is resolved by nothing: a quarter line
    assert window_corrected_damping(f, 0.5 * g / (2 * f), df) == pytest.approx(0.25 * df / (2 * f))
