"""Tests of the recording type and its HDF5 / UFF58 files."""

from __future__ import annotations

import dataclasses
import os

import numpy as np
import pytest

from exudyn_study.errors import InputError
from exudyn_study.recording import Channel, Recording, read_recording, write_recording


def make_recording(n: int = 1000, seed: int = 0) -> Recording:
    rng = np.random.default_rng(seed)
    chans = (
        Channel(
            "ARFVZ",
            "acceleration",
            "m/s^2",
            "Z",
            (-0.315, -0.455, 0.19),
            1000.0,
            rng.normal(size=n),
            sensitivity=6.764e-3,
        ),
        Channel(
            "ASVY",
            "acceleration",
            "m/s^2",
            "Y",
            (-0.11, -1.128, 0.105),
            1000.0,
            rng.normal(size=n) * 3.0,
            sensitivity=6.543e-3,
        ),
        Channel(
            "ARHTFXH",
            "acceleration",
            "m/s^2",
            "X",
            (0.465, 0.42, 0.215),
            1000.0,
            rng.normal(size=n) * 1e-3,
        ),
        Channel("load", "force", "N", "", None, 1000.0, rng.normal(size=n) * 1e3),
        Channel(
            "drive",
            "displacement",
            "m",
            "Z",
            None,
            204.8,
            rng.normal(size=int(n * 0.2048)) * 2e-4,
            role="drive",
        ),
    )
    meta = {
        "model": "model1",
        "damping": "suggested",
        "signal": "white-noise",
        "seed": 7,
        "duration": 0.5,
        "package_version": "0.1.0",
        "note": "a long description " * 8,
    }
    return Recording(chans, meta)


@pytest.mark.parametrize("suffix", [".h5", ".hdf5", ".uff", ".unv"])
def test_round_trip_identical(tmp_path, suffix):
    rec = make_recording()
    path = write_recording(rec, tmp_path / f"run{suffix}")
    back = read_recording(path)
    assert back.names == rec.names
    for a, b in zip(rec.channels, back.channels, strict=True):
        assert np.array_equal(a.data, b.data)  # bit-identical values
        assert a.sample_rate_hz == b.sample_rate_hz
        assert a.direction == b.direction
        assert a.position_m == b.position_m
        assert a.role == b.role
        assert a.quantity == b.quantity and a.unit == b.unit
        assert a.sensitivity == b.sensitivity
    assert back.channels == rec.channels
    assert dict(back.metadata) == dict(rec.metadata)
    assert isinstance(back.metadata["seed"], int) and isinstance(back.metadata["duration"], float)
    assert back.drive.name == "drive" and back.drive.sample_rate_hz == 204.8


def test_no_temp_files_left_and_overwrite(tmp_path):
    rec = make_recording()
    write_recording(rec, tmp_path / "a.h5")
    write_recording(rec.select(["ARFVZ"]), tmp_path / "a.h5")  # overwrite
    assert read_recording(tmp_path / "a.h5").names == ("ARFVZ",)
    assert sorted(os.listdir(tmp_path)) == ["a.h5"]


def test_failed_write_leaves_nothing(tmp_path, monkeypatch):
    import exudyn_study.recording.io as recmod

    def boom(recording, path):
        path.write_bytes(b"half")
        raise RuntimeError("disk full")

    monkeypatch.setattr(recmod, "_write_hdf5", boom)
    target = tmp_path / "x.h5"
    target.write_bytes(b"old")
    with pytest.raises(RuntimeError, match="disk full"):
        write_recording(make_recording(), target)
    assert target.read_bytes() == b"old"
    assert sorted(os.listdir(tmp_path)) == ["x.h5"]


def test_uff_metadata_too_long_fails_before_writing(tmp_path):
    rec = make_recording().select(["ARFVZ"])
    rec = dataclasses.replace(rec, metadata={"note": "x" * 200})
    with pytest.raises(InputError, match="shorten the metadata or write .h5"):
        write_recording(rec, tmp_path / "a.uff")
    assert os.listdir(tmp_path) == []


def test_read_uff_from_test_software(tmp_path):
    """A UFF58 file as test software writes it: no exudyn_study tags, ASCII data in g,
    a negative response direction, geometry in mm with a 164 units set."""
    import pyuff

    fs = 1000.0
    x = np.sin(2 * np.pi * 10 * np.arange(200) / fs)
    sets = [
        pyuff.prepare_164(
            units_code=6,
            units_description="mm (newton)",
            temp_mode=2,
            length=1000.0,
            force=1.0,
            temp=1.0,
            temp_offset=273.15,
        ),
        {
            "type": 2411,
            "node_nums": np.array([17]),
            "def_cs": np.zeros(1, int),
            "disp_cs": np.zeros(1, int),
            "color": np.ones(1, int),
            "x": np.array([-315.0]),
            "y": np.array([-455.0]),
            "z": np.array([190.0]),
        },
        pyuff.prepare_58(
            binary=0,
            id1="ARFVZ",
            id2="NONE",
            id3="NONE",
            id4="NONE",
            id5="NONE",
            func_type=1,
            rsp_node=17,
            rsp_dir=-3,
            ref_node=0,
            ref_dir=0,
            rsp_ent_name="ARFVZ",
            ref_ent_name="NONE",
            data=x,
            x=np.arange(200) / fs,
            abscissa_spacing=1,
            abscissa_spec_data_type=17,
            ordinate_spec_data_type=12,
            ordinate_axis_units_lab="g",
            orddenom_spec_data_type=0,
        ),
        pyuff.prepare_58(
            binary=0,
            id1="ARFVZ/ARFHZ FRF",
            func_type=4,
            rsp_node=17,
            rsp_dir=3,
            ref_node=18,
            ref_dir=3,
            data=x + 0j,
            x=np.arange(200) * 0.2,
            abscissa_spacing=1,
            abscissa_spec_data_type=18,
            ordinate_spec_data_type=12,
            orddenom_spec_data_type=13,
        ),
    ]
    path = tmp_path / "testlab.uff"
    pyuff.UFF(str(path)).write_sets(sets, mode="add")
    with pytest.warns(UserWarning, match="not time data"):
        rec = read_recording(path)
    assert rec.names == ("ARFVZ",)
    ch = rec.channel("ARFVZ")
    assert ch.direction == "Z" and ch.role == "response"
    assert ch.sample_rate_hz == 1000.0
    np.testing.assert_allclose(ch.position_m, (-0.315, -0.455, 0.19), rtol=1e-12)
    # ASCII UFF58 keeps ~12 significant digits; g -> m/s^2 and -Z -> +Z
    np.testing.assert_allclose(ch.data, -9.80665 * x, rtol=1e-9, atol=1e-9)
    assert dict(rec.metadata) == {}


def test_uff_rate_from_increment_only():
    from exudyn_study.recording.uff import _rate_from_increment

    assert _rate_from_increment(4.88281e-03) == 204.8  # what E13.5 leaves of 1/204.8
    assert _rate_from_increment(1.00000e-03) == 1000.0


def test_file_errors(tmp_path):
    with pytest.raises(InputError, match="does not exist"):
        read_recording(tmp_path / "missing.h5")
    with pytest.raises(InputError, match=r"unknown suffix '\.csv'.*\.h5/\.hdf5.*\.uff/\.unv"):
        read_recording(tmp_path / "x.csv")
    with pytest.raises(InputError, match="unknown suffix"):
        write_recording(make_recording(), tmp_path / "x.mat")
    (tmp_path / "text.h5").write_text("not hdf5")
    with pytest.raises(InputError, match="not a readable HDF5 file"):
        read_recording(tmp_path / "text.h5")
    import h5py

    with h5py.File(tmp_path / "other.h5", "w") as f:
        f.attrs["format"] = "something else"
    with pytest.raises(InputError, match="format='something else'"):
        read_recording(tmp_path / "other.h5")
    write_recording(make_recording(), tmp_path / "v.h5")
    with h5py.File(tmp_path / "v.h5", "a") as f:
        f.attrs["format_version"] = 99
    with pytest.raises(InputError, match="format_version 99"):
        read_recording(tmp_path / "v.h5")
    import pyuff

    pyuff.UFF(str(tmp_path / "geo.uff")).write_sets(
        [
            pyuff.prepare_164(
                units_code=1,
                units_description="SI",
                temp_mode=2,
                length=1.0,
                force=1.0,
                temp=1.0,
                temp_offset=273.15,
            )
        ],
        mode="add",
    )
    with pytest.raises(InputError, match="no type-58 datasets"):
        read_recording(tmp_path / "geo.uff")
    with pytest.raises(InputError, match="directory .* does not exist"):
        write_recording(make_recording(), tmp_path / "nodir" / "x.h5")


def test_channel_validation():
    ok = dict(
        name="A",
        quantity="acceleration",
        unit="m/s^2",
        direction="Z",
        position_m=None,
        sample_rate_hz=100.0,
        data=np.zeros(4),
    )
    data = np.array([0.0, 1.0, np.nan, np.inf])
    with pytest.raises(InputError, match=r"channel 'A'.*2 non-finite.*index 2"):
        Channel(**{**ok, "data": data})
    with pytest.raises(InputError, match="quantity 'velocity'"):
        Channel(**{**ok, "quantity": "velocity"})
    with pytest.raises(InputError, match="unit 'g'.*'m/s\\^2'"):
        Channel(**{**ok, "unit": "g"})
    with pytest.raises(InputError, match="role 'input'"):
        Channel(**{**ok, "role": "input"})
    with pytest.raises(InputError, match="sample_rate_hz 0"):
        Channel(**{**ok, "sample_rate_hz": 0})
    with pytest.raises(InputError, match="direction 'z'"):
        Channel(**{**ok, "direction": "z"})
    with pytest.raises(InputError, match="position_m"):
        Channel(**{**ok, "position_m": (1.0, 2.0)})
    with pytest.raises(InputError, match="1-D"):
        Channel(**{**ok, "data": np.zeros((2, 2))})
    ch = Channel(**ok)
    assert not ch.data.flags.writeable
    with pytest.raises(dataclasses.FrozenInstanceError):
        ch.name = "B"


def test_recording_api():
    rec = make_recording()
    assert rec.names[:2] == ("ARFVZ", "ASVY")
    assert [c.name for c in rec.response_channels] == ["ARFVZ", "ASVY", "ARHTFXH", "load"]
    x, fs = rec.time_data()
    assert x.shape == (4, 1000) and fs == 1000.0
    np.testing.assert_array_equal(x[1], rec.channel("ASVY").data)
    x2, _ = rec.time_data(["ASVY", "ARFVZ"])
    np.testing.assert_array_equal(x2, x[[1, 0]])
    assert rec.select(["ASVY"]).names == ("ASVY",)
    assert rec.duration_s == pytest.approx(1.0)
    with pytest.raises(
        InputError, match=r"mixed sample rates.*ARFVZ at 1000 Hz.*drive at 204.8 Hz"
    ):
        rec.time_data(["ARFVZ", "drive"])
    with pytest.raises(
        InputError, match=r"channel 'ARFVX' is not in the recording; available: 'ARFVZ'"
    ):
        rec.channel("ARFVX")
    with pytest.raises(InputError, match="recording has no drive channel"):
        _ = rec.select(["ARFVZ"]).drive
    with pytest.raises(InputError, match="unique; repeated: ARFVZ"):
        Recording(rec.channels + (rec.channels[0],))
    with pytest.raises(InputError, match="metadata 'x'.*list"):
        Recording(rec.channels, {"x": [1, 2]})


def test_from_arrays():
    x = np.arange(6.0).reshape(2, 3)
    rec = Recording.from_arrays(
        x,
        100.0,
        ["ARFVZ", "ASVY"],
        drive=np.ones(5),
        drive_rate_hz=50.0,
        metadata={"source": "test"},
    )
    assert rec.channel("ARFVZ").direction == "Z" and rec.channel("ASVY").direction == "Y"
    assert rec.drive.sample_rate_hz == 50.0 and rec.drive.quantity == "displacement"
    np.testing.assert_array_equal(rec.time_data()[0], x)
    with pytest.raises(InputError, match="2 names, 1 directions"):
        Recording.from_arrays(x, 100.0, ["A", "B"], directions=["Z"])
