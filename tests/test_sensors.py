"""Tests of the Appendix A sensor table."""

from __future__ import annotations

import pytest

from exudyn_study.errors import InputError
from exudyn_study.model.sensors import (
    REFERENCES,
    SENSORS,
    Sensor,
    sensor,
    sensors_on,
    z_sensors,
)


def test_count_and_numbering():
    assert len(SENSORS) == 42
    assert [s.number for s in SENSORS] == list(range(1, 43))
    assert len({s.name for s in SENSORS}) == 42
    assert len(z_sensors()) == 21  # thesis Section 3.3
    assert all(s.direction == "Z" for s in z_sensors())
    counts = {d: sum(s.direction == d for s in SENSORS) for d in "XYZ"}
    assert counts == {"X": 13, "Y": 8, "Z": 21}


def test_units_converted_from_table():
    s = sensor("ARFVZ")  # Table 8 row 4: 6,764 mV/(m/s^2), (-315, -455, 190) mm
    assert s.number == 4
    assert s.sensitivity == pytest.approx(6.764e-3, rel=1e-12)
    assert s.position_m == pytest.approx((-0.315, -0.455, 0.190), abs=1e-12)
    assert s.position_global_m == pytest.approx((2.885, -0.455, 1.190), abs=1e-12)
    assert sensor("ARSHZ").position_m == pytest.approx((0.0, 0.435, 0.130), abs=1e-12)
    # all sensitivities in the 6.1-7.0 mV/(m/s^2) band of the table, as V/(m/s^2)
    assert all(6.1e-3 < s.sensitivity < 7.0e-3 for s in SENSORS)
    # the rig spans about -0.53..2.5 m in x and +-1.18 m in y
    xs = [s.position_m[0] for s in SENSORS]
    ys = [s.position_m[1] for s in SENSORS]
    assert min(xs) == pytest.approx(-0.53) and max(xs) == pytest.approx(2.5)
    assert min(ys) == pytest.approx(-1.148) and max(ys) == pytest.approx(1.175)


def test_components():
    assert {s.name for s in sensors_on("tank_left")} == {"ATVBX", "ATVBZ", "ATVFX", "ATVFXZ"}
    assert {s.name for s in sensors_on("tank_right")} == {"ATHFX", "ATHBX", "ATHBZ", "ATHFZ"}
    assert {s.name for s in sensors_on("bracket_left")} == {"ASVX", "ASVY", "ASVZ"}
    assert {s.name for s in sensors_on("bracket_right")} == {"ASHX", "ASHY", "ASHZ"}
    assert len(sensors_on("frame")) == 42 - 14
    # frame sensors next to a tank or bracket stay on the frame
    for name in ("ARVTFZ", "ARHTFZH", "ARSVZ", "ARSHZ", "ATBGZ", "ATBPZ"):
        assert sensor(name).component == "frame"
    for s in SENSORS:
        if s.component.endswith("_left"):
            assert s.position_m[1] < 0 and s.side == "left"
        if s.component.endswith("_right"):
            assert s.position_m[1] > 0 and s.side == "right"


def test_references_and_aliases():
    assert REFERENCES == ("ARFVZ", "ARFHZ")
    assert all(sensor(r).direction == "Z" for r in REFERENCES)
    assert sensor("ATVFZ") is sensor("ATVFXZ")
    assert sensor("ATVFXZ").direction == "Z" and sensor("ATVFXZ").number == 40


def test_unknown_sensor_suggests():
    with pytest.raises(InputError, match=r"unknown sensor 'ARFVQ'.*did you mean.*ARFVZ"):
        sensor("ARFVQ")
    with pytest.raises(InputError, match="component 'tank'"):
        sensors_on("tank")
    with pytest.raises(InputError, match="direction 'W'"):
        Sensor(1, "A", 6e-3, "W", "Frame", (0.0, 0.0, 0.0), "frame")
