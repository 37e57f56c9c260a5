"""Generic diagnosis on a structure of our own: two beams joined by a nonlinear lap joint.

The truth is :mod:`exudyn_study.diagnose.testbench` (lumped two-beam structure, joint across
sensors A2-B1), simulated with the project's local-nonlinear integrator at four drive levels
(0.1, 0.3, 1, 3 m/s^2 rms), with sensor noise. The diagnosis identifies its linear model from
the lowest level and must (a) find nothing on a linear structure, (b) locate the joint, name
friction micro-slip / stiffening and improve the held-out levels by at least half, (c) refuse
bad input with one-line errors naming the input. Coarse settings keep the suite fast: 256 Hz,
12 s records, 0.5 Hz resolution.

Names: a hardening joint on a generic structure is ``joint_stiffening`` (the catalogue's
``bushing_stiffening`` is the chassis's rubber bushing); friction is the catalogue's
``joint_friction`` (the same Jenkins micro-slip physics); a clearance is ``joint_clearance``.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from exudyn_study.cli import main
from exudyn_study.diagnose import Diagnosis, Finding, diagnose_generic, read_json
from exudyn_study.diagnose import testbench as tb
from exudyn_study.diagnose.generic import GenericSettings, _relative_masses
from exudyn_study.diagnose.report import write_report
from exudyn_study.errors import InputError
from exudyn_study.recording import Channel, Recording, write_recording

RATE_HZ, DURATION_S, BAND_HZ = 256.0, 12.0, (5.0, 100.0)
SETTINGS = GenericSettings(resolution_hz=0.5)
#: the acceptance: held-out error at most half the nominal model's
HELD_OUT_REDUCTION = 0.5
SLIP_M = tb.TestStructure().slip_displacement_m


def _levels(joint):
    return tb.simulate_levels(
        joint, duration_s=DURATION_S, sample_rate_hz=RATE_HZ, band_hz=BAND_HZ, substeps=8
    )


@pytest.fixture(scope="module")
def linear():
    return _levels("none")


@pytest.fixture(scope="module")
def friction():
    return _levels("friction")


@pytest.fixture(scope="module")
def stiffening():
    return _levels("stiffening")


# ------------------------------------------------------------------------------------------------ invariants
def test_relative_masses_come_back_from_exact_participation_shapes():
    """psi_r = phi_r Gamma_r of the exact lumped structure gives its masses (up to scale)."""
    s = tb.TestStructure()
    lin = tb.linear_system(s)
    w2, phi = np.linalg.eig(np.linalg.solve(lin.mass, lin.stiffness))
    phi = phi.real / np.sqrt(np.einsum("ir,ij,jr->r", phi.real, lin.mass, phi.real))
    gamma = phi.T @ lin.mass @ np.ones(5)
    masses, ok = _relative_masses(phi * gamma)
    m = np.asarray(s.masses_kg)
    assert ok
    np.testing.assert_allclose(masses, m / m.sum(), rtol=1e-9)


def test_testbench_recordings_have_drive_and_layout(linear):
    rec = linear[0]
    assert rec.drive.role == "drive" and rec.drive.quantity == "displacement"
    assert tuple(c.name for c in rec.response_channels) == tb.SENSORS
    levels = [r.metadata["level_m_s2"] for r in linear]
    assert levels == [0.1, 0.3, 1.0, 3.0]


# ------------------------------------------------------------------------------------------------ diagnosis
def test_linear_structure_has_no_missing_physics(linear):
    d = diagnose_generic(linear[0], [linear[0], linear[2]], [linear[1], linear[3]], settings=SETTINGS)
    assert d.mismatch_found is False
    assert d.findings == () and d.unexplained == ()
    assert d.summary == "no missing physics found"


def test_friction_joint_is_located_named_and_improves_held_out_levels(friction, tmp_path):
    """No interface declared: the search over all sensor pairs must find A2-B1."""
    figures = {}
    d = diagnose_generic(
        friction[0],
        [friction[0], friction[2]],
        [friction[1], friction[3]],
        settings=SETTINGS,
        figures=figures,
    )
    assert d.mismatch_found and len(d.findings) == 1, d.unexplained
    f = d.findings[0]
    assert f.physics == "joint_friction"
    assert f.location["interface"] == "A2-B1"
    assert f.level_dependent
    assert f.fit["holdout_after"] <= HELD_OUT_REDUCTION * f.fit["holdout_before"], f.fit
    assert f.fit["train_after"] < f.fit["train_before"]
    # the slip displacement is scale-free: it comes back (within the model's approximations)
    slip = f.parameters["slip_displacement_m"]
    assert slip["value"] == pytest.approx(SLIP_M, rel=0.3)
    assert slip["std"] is not None and slip["std"] < 0.2 * slip["value"]
    # per-channel proof on every held-out recording
    for lab in ("holdout[0]", "holdout[1]"):
        per = f.fit["per_channel"][lab]
        assert set(per) == set(tb.SENSORS)
        assert all(v["after"] < v["before"] for v in per.values())
    assert "friction" in f.explanation and "held-out" in f.explanation
    assert figures["residual_map"].shape[1:] == (5, figures["freq_hz"].size)
    index = write_report(d, tmp_path / "report", figures)
    assert {"residual_map.png", "frf_overlay.png", "errors.png"} <= {p.name for p in index.parent.iterdir()}
    assert "joint_friction" in index.read_text()


def test_stiffening_joint_declared_interface(stiffening):
    d = diagnose_generic(
        stiffening[0],
        [stiffening[0], stiffening[1], stiffening[3]],
        [stiffening[2]],
        interfaces={"lap_joint": ("A2", "B1")},
        settings=SETTINGS,
    )
    assert d.mismatch_found and d.findings, d.unexplained
    f = d.findings[0]
    assert f.physics == "joint_stiffening"
    assert f.location["component"] == "lap_joint" and f.location["interface"] == "A2-B1"
    assert f.fit["holdout_after"] <= HELD_OUT_REDUCTION * f.fit["holdout_before"], f.fit
    rejected = {c["physics"]: c["rejected"] for c in d.metadata["candidates"]}
    assert "signature" in rejected["joint_friction"]


def test_sensor_gain_error_is_located_but_not_explained(linear):
    """A 30 % gain error on B3 in the later recordings: no joint law explains it; reported where it is."""

    def gain(rec):
        return Recording(
            tuple(
                Channel(
                    c.name,
                    c.quantity,
                    c.unit,
                    c.direction,
                    c.position_m,
                    c.sample_rate_hz,
                    c.data * (1.3 if c.name == "B3" else 1.0),
                    c.role,
                )
                for c in rec.channels
            ),
            rec.metadata,
        )

    d = diagnose_generic(linear[0], [linear[0], gain(linear[2])], [gain(linear[1])], settings=SETTINGS)
    assert d.mismatch_found and not d.findings
    (u,) = d.unexplained
    assert u["location"]["sensors"] == ["B3"]
    assert u["level_dependent"] is False
    assert "no single interface explains" in u["explanation"]


def test_force_driven_structure_friction_joint():
    """A shaker force on B3 (table fixed, drive-point accelerometer B3): the model is mass-normalised,
    so the lumped masses come back in kg, and the friction joint is found as with a table drive."""
    recs = tb.simulate_levels(
        "friction",
        (0.15, 0.45, 1.5, 4.5),
        duration_s=DURATION_S,
        sample_rate_hz=RATE_HZ,
        band_hz=BAND_HZ,
        substeps=8,
        force_at="B3",
    )
    d = diagnose_generic(
        recs[0], [recs[0], recs[2]], [recs[1], recs[3]], interfaces=[("A2", "B1")], settings=SETTINGS
    )
    masses = np.array(list(d.metadata["masses"].values()))
    np.testing.assert_allclose(masses, tb.TestStructure().masses_kg, rtol=0.05)
    f = d.findings[0]
    assert f.physics == "joint_friction"
    assert f.fit["holdout_after"] <= HELD_OUT_REDUCTION * f.fit["holdout_before"], f.fit
    assert f.parameters["slip_displacement_m"]["value"] == pytest.approx(SLIP_M, rel=0.3)


# ------------------------------------------------------------------------------------------------ bad input
def _without(rec: Recording, name: str) -> Recording:
    return Recording(tuple(c for c in rec.channels if c.name != name), rec.metadata)


def _renamed(rec: Recording, old: str, new: str) -> Recording:
    chans = [
        Channel(
            new if c.name == old else c.name,
            c.quantity,
            c.unit,
            c.direction,
            c.position_m,
            c.sample_rate_hz,
            c.data,
            c.role,
        )
        for c in rec.channels
    ]
    return Recording(tuple(chans), rec.metadata)


def test_recordings_from_different_sensor_layouts(linear):
    with pytest.raises(InputError, match=r"holdout recording 'holdout\[0\]'.*sensor layout differs"):
        diagnose_generic(linear[0], [linear[1]], [_without(linear[2], "B3")], settings=SETTINGS)


def test_no_held_out_recording(linear):
    with pytest.raises(InputError, match="holdout: no held-out recording"):
        diagnose_generic(linear[0], [linear[1]], [], settings=SETTINGS)


def test_recording_without_drive_channel(linear):
    with pytest.raises(InputError, match=r"train recording 'train\[0\]'.*no drive channel"):
        diagnose_generic(linear[0], [_without(linear[1], "drive")], [linear[2]], settings=SETTINGS)


def test_model_whose_sensors_do_not_match_the_recordings(linear):
    with pytest.raises(InputError, match="sensor layout differs from the model reference"):
        diagnose_generic(_renamed(linear[0], "B3", "C3"), [linear[1]], [linear[2]], settings=SETTINGS)


def test_recordings_driven_differently(linear):
    rec = linear[1]
    chans = [
        Channel(c.name, "force", "N", c.direction, c.position_m, c.sample_rate_hz, c.data, c.role)
        if c.role == "drive"
        else c
        for c in rec.channels
    ]
    with pytest.raises(InputError, match="must be driven the same way"):
        diagnose_generic(linear[0], [Recording(tuple(chans))], [linear[2]], settings=SETTINGS)


def test_interface_naming_an_unknown_sensor(linear):
    with pytest.raises(InputError, match="sensor 'X9' is not in the recordings"):
        diagnose_generic(linear[0], [linear[1]], [linear[2]], interfaces=[("A2", "X9")], settings=SETTINGS)


# ------------------------------------------------------------------------------------------------ schema
def _finding(**kw):
    base = dict(
        physics="joint_friction",
        location={"sensors": ["A2"], "component": None, "interface": "A2-B1"},
        band_hz=(5.0, 70.0),
        level_dependent=True,
        explanation="x",
        parameters={"slip_share": {"value": 0.6, "unit": "1", "std": 0.01}},
        fit={
            "train_before": 0.5,
            "train_after": 0.1,
            "holdout_before": 0.6,
            "holdout_after": 0.1,
            "metric": "relative FRF error",
        },
    )
    base.update(kw)
    return Finding(**base)


def test_schema_round_trip_and_atomic_write(tmp_path):
    d = Diagnosis(
        True,
        (_finding(),),
        ({"location": {"sensors": ["B3"]}, "band_hz": [1, 2], "level_dependent": False, "explanation": "y"},),
        {"levels": np.arange(2)},
    )
    path = d.write_json(tmp_path / "d.json")
    back = read_json(path)
    assert back.to_dict() == d.to_dict()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["d.json"]
    doc = json.loads(path.read_text())
    assert set(doc["findings"][0]) == {
        "physics",
        "location",
        "band_hz",
        "level_dependent",
        "explanation",
        "parameters",
        "fit",
        "flags",
    }
    assert set(doc["findings"][0]["location"]) == {"sensors", "component", "interface"}
    assert all(p["at_bound"] is False for p in doc["findings"][0]["parameters"].values())


def test_schema_carries_parameter_at_bound_and_finding_flags():
    """``at_bound`` per parameter (default False) and the finding's ``flags`` survive a round trip; a
    file written before they existed (without them) still reads."""
    f = _finding()
    name = next(iter(f.parameters))
    params = {n: dict(v) for n, v in f.parameters.items()}
    params[name]["at_bound"] = True
    flagged = _finding(parameters=params, flags=("a parameter ends at its bound",))
    back = Finding.from_dict(flagged.to_dict())
    assert back.parameters[name]["at_bound"] is True and back.flags == ("a parameter ends at its bound",)
    old = f.to_dict()
    del old["flags"]
    for v in old["parameters"].values():
        del v["at_bound"]
    assert Finding.from_dict(old) == f
    with pytest.raises(InputError, match="at_bound"):
        _finding(parameters={name: {**params[name], "at_bound": "yes"}})
    with pytest.raises(InputError, match="flags"):
        _finding(flags="at a bound")


def test_schema_rejects_incomplete_input():
    with pytest.raises(InputError, match="fit lacks"):
        _finding(fit={"train_before": 1.0})
    with pytest.raises(InputError, match="mismatch_found is False"):
        Diagnosis(False, (_finding(),))
    with pytest.raises(InputError, match="location has unknown keys"):
        _finding(location={"sensor": ["A2"]})


# ------------------------------------------------------------------------------------------------ CLI
@pytest.fixture(scope="module")
def linear_files(linear, tmp_path_factory):
    d = tmp_path_factory.mktemp("recs")
    return [
        str(write_recording(rec, d / f"L{lv:g}.h5")) for rec, lv in zip(linear, (0.1, 0.3, 1, 3), strict=True)
    ]


def test_cli_end_to_end(linear_files, tmp_path, capsys):
    """Files in, JSON and report out (the linear structure: the physics cases are tested above)."""
    low, mid, high, top = linear_files
    out, rep = tmp_path / "diag.json", tmp_path / "report"
    argv = [
        "diagnose",
        "--model",
        f"modal:{low}",
        "--train",
        low,
        high,
        "--holdout",
        mid,
        top,
        "--json",
        str(out),
        "--report",
        str(rep),
        "--interface",
        "lap=A2:B1",
        "--resolution",
        "0.5",
    ]
    rc = main(argv)
    assert rc == 0, capsys.readouterr().err
    d = read_json(out)
    assert d.mismatch_found is False
    assert d.metadata["holdout"] == ["L0.3.h5", "L3.h5"] and d.metadata["model"] == "modal:L0.1.h5"
    assert (rep / "index.html").is_file() and (rep / "residual_map.png").is_file()
    assert "no missing physics found" in capsys.readouterr().out


def test_cli_bad_input_writes_nothing(linear_files, tmp_path, capsys):
    low, mid, *_ = linear_files
    out = tmp_path / "diag.json"
    assert main(["diagnose", "--model", f"modal:{low}", "--train", mid, "--json", str(out)]) == 2
    assert "no held-out recording" in capsys.readouterr().err
    assert main(["diagnose", "--model", "7", "--train", mid, "--holdout", low, "--json", str(out)]) == 2
    assert "expected 1, 2 or 3" in capsys.readouterr().err
    assert (
        main(
            [
                "diagnose",
                "--model",
                f"modal:{low}",
                "--train",
                mid,
                "--holdout",
                str(tmp_path / "nope.h5"),
                "--json",
                str(out),
            ]
        )
        == 2
    )
    assert "nope.h5" in capsys.readouterr().err
    assert not out.exists()


def test_the_generic_time_simulation_drives_with_the_band_limited_drive():
    """The generic path's drive acceleration is the rig's band-limited reconstruction (what the test
    bench's truth is driven with), not a cubic spline through the samples: a 100 Hz sine sampled at
    512 Hz has its acceleration within 0.5 % (the spline through the samples is 13 % off,
    (omega h)^2 / 12), and it equals the rig drive's to round-off."""
    from exudyn_study.diagnose.generic import _drive_on_grid
    from exudyn_study.model.rig import Drive

    fs, f0, substeps = 512.0, 100.0, 4
    u = 1e-3 * np.sin(2 * np.pi * f0 * np.arange(2048) / fs)
    acc = _drive_on_grid(u, fs, substeps, 2)
    t = np.arange(acc.size) / (fs * substeps)
    exact = -((2 * np.pi * f0) ** 2) * 1e-3 * np.sin(2 * np.pi * f0 * t)
    inner = slice(400, -400)  # away from the record's ends
    assert np.abs(acc - exact)[inner].max() <= 5e-3 * np.abs(exact).max()
    drive = Drive()
    drive.set_signal(u, fs)
    np.testing.assert_allclose(acc, drive.evaluate(t, 2), rtol=0, atol=1e-9 * np.abs(exact).max())


def test_report_error_bars_show_the_final_model_after_several_findings(tmp_path, monkeypatch):
    """With several findings the error figure's "after" is the final model (metadata
    ``final_holdout_per_channel``), not the first finding's round; with one it is that finding's fit."""
    from exudyn_study.diagnose import report

    def finding(name, after):
        per = {"hold.h5": {"A": {"before": 2.0, "after": after}, "B": {"before": 1.0, "after": after}}}
        return Finding(physics=name, location={"sensors": ["A"], "component": None, "interface": None},
                       band_hz=(3.0, 60.0), level_dependent=False, explanation="x",
                       parameters={"k": {"value": 1.0, "unit": "N/m", "std": 0.1}},
                       fit={"train_before": 2.0, "train_after": after, "holdout_before": 2.0,
                            "holdout_after": after, "metric": "relative error", "per_channel": per})

    drawn = []
    monkeypatch.setattr(report, "_log_axis_if_spread", lambda ax, values: drawn.append(list(values)))
    final = {"hold.h5": {"A": 0.1, "B": 0.2}}
    two = Diagnosis(True, [finding("a", 1.5), finding("b", 1.2)], [], {"final_holdout_per_channel": final})
    assert report._errors(two, {"holdout": ["hold.h5"]}, tmp_path / "two.png") is not None
    assert drawn[-1] == [2.0, 1.0, 0.1, 0.2]  # held-out before (nominal), after (all findings)
    one = Diagnosis(True, [finding("a", 1.5)], [], {"final_holdout_per_channel": final})
    report._errors(one, {"holdout": ["hold.h5"]}, tmp_path / "one.png")
    assert drawn[-1] == [2.0, 1.0, 1.5, 1.5]
