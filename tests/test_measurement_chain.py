"""Measurement chain of the virtual rig: servo drop-offs, noise floor, quantisation, anti-aliasing."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from exudyn_study.errors import InputError
from exudyn_study.model.sensors import sensor
from exudyn_study.recording import Channel, Recording
from exudyn_study.signals import psd
from exudyn_study.virtual_rig.measurement import (
    AcquisitionParameters,
    ServoParameters,
    anti_alias_gain,
    measure,
    servo_frf,
    servo_response,
)

FS = 1000.0


def _recording(x, fs=FS, names=("ARFVZ", "ASVZ")):
    chans = []
    for name, row in zip(names, np.atleast_2d(x), strict=True):
        s = sensor(name)
        chans.append(Channel(name, "acceleration", "m/s^2", s.direction, s.position_m, fs, row,
                             sensitivity=s.sensitivity))
    drive = np.zeros(int(round(np.atleast_2d(x).shape[1] / fs * 204.8)))
    chans.append(Channel("drive", "displacement", "m", "Z", None, 204.8, drive, role="drive"))
    return Recording(tuple(chans), {"source": "test", "seed": 1})


def test_servo_dips_at_the_documented_frequencies():
    """The achieved/command PSD ratio of white noise has its minima at 12 and 26 Hz, depths as set."""
    p = ServoParameters(tracking_noise_rms_m=0.0)
    x = np.random.default_rng(0).standard_normal(int(200 * FS)) * 2.5e-4
    y = servo_response(x, FS, p)
    f, pxx = psd(x, FS, resolution_hz=0.25)
    _, pyy = psd(y, FS, resolution_hz=0.25)
    ratio_db = 10 * np.log10(pyy / pxx)
    for fc, depth in zip(p.notch_frequencies_hz, p.notch_depths_db, strict=True):
        band = (f > fc - 4) & (f < fc + 4)
        f_min = f[band][np.argmin(ratio_db[band])]
        assert f_min == pytest.approx(fc, abs=0.5)
        # exact FRF and estimate agree; the loop roll-off adds < 0.1 dB below 30 Hz
        assert np.min(ratio_db[band]) == pytest.approx(-depth, abs=0.6)
    flat = (f > 3) & (f < 6) | (f > 40) & (f < 55)
    assert np.all(np.abs(ratio_db[flat]) < 1.5)
    h = servo_frf(np.array([12.0, 26.0, 0.0]), p)
    np.testing.assert_allclose(20 * np.log10(np.abs(h[:2])), [-6.0, -9.0], atol=0.15)
    assert h[2] == pytest.approx(1.0)


def test_servo_tracking_error_is_seeded_and_has_its_rms():
    x = np.zeros(20000)
    a = servo_response(x, FS, ServoParameters(tracking_noise_rms_m=1e-6, seed=3))
    b = servo_response(x, FS, ServoParameters(tracking_noise_rms_m=1e-6, seed=3))
    c = servo_response(x, FS, ServoParameters(tracking_noise_rms_m=1e-6, seed=4))
    np.testing.assert_array_equal(a, b)
    assert not np.allclose(a, c)
    assert np.std(a) == pytest.approx(1e-6, rel=1e-6)


def test_noise_floor_has_the_set_density():
    """Zero input: the recorded PSD is the sensor noise density squared (quantisation is far below it)."""
    p = AcquisitionParameters(noise_density=3e-4, seed=5)
    rec = measure(_recording(np.zeros((2, int(60 * FS)))), p)
    f, pxx = psd(rec.channel("ARFVZ").data, FS, resolution_hz=1.0)
    band = (f > 5) & (f < 300)
    assert math.sqrt(np.mean(pxx[band])) == pytest.approx(3e-4, rel=0.03)
    # channels are independent
    r = np.corrcoef(rec.channel("ARFVZ").data, rec.channel("ASVZ").data)[0, 1]
    assert abs(r) < 0.02


def test_quantisation_step_is_one_lsb_over_the_sensitivity():
    p = AcquisitionParameters(noise_density=0.0, adc_bits=16)
    t = np.arange(int(2 * FS)) / FS
    rec = measure(_recording(np.vstack([3.0 * np.sin(2 * np.pi * 7 * t)] * 2)), p)
    for name in ("ARFVZ", "ASVZ"):
        sens = sensor(name).sensitivity
        counts = rec.channel(name).data * sens / p.lsb_v
        np.testing.assert_allclose(counts, np.round(counts), atol=1e-6)
        step = np.min(np.diff(np.unique(np.round(counts))))
        assert step == 1.0
        assert p.lsb_v / sens == pytest.approx(20.0 / 2**16 / sens)


def test_anti_alias_filter_attenuates_above_nyquist():
    """A 700 Hz tone given at 4 kHz aliases to 300 Hz, attenuated by the Butterworth gain; 100 Hz passes."""
    p = AcquisitionParameters(noise_density=0.0)
    fs_in = 4 * FS
    t = np.arange(int(4 * fs_in)) / fs_in
    x = np.vstack([np.sin(2 * np.pi * 700 * t), np.sin(2 * np.pi * 100 * t)])
    rec = measure(_recording(x, fs=fs_in), p)
    assert rec.channel("ARFVZ").sample_rate_hz == FS
    to = np.arange(int(4 * FS)) / FS
    mid = slice(500, -500)

    def amplitude(y, f0):
        basis = np.vstack([np.sin(2 * np.pi * f0 * to[mid]), np.cos(2 * np.pi * f0 * to[mid])]).T
        c = np.linalg.lstsq(basis, y[mid], rcond=None)[0]
        return float(np.hypot(*c))

    alias = amplitude(rec.channel("ARFVZ").data, 300.0)
    expected = float(anti_alias_gain(700.0, p))  # 8th order at 400 Hz: 1.75^-8, -39 dB
    assert expected == pytest.approx(1.75**-8, rel=1e-3)
    assert alias == pytest.approx(expected, rel=0.02)
    assert amplitude(rec.channel("ASVZ").data, 100.0) == pytest.approx(1.0, abs=1e-4)


def test_same_channels_rates_and_metadata_out():
    x = np.random.default_rng(1).standard_normal((2, 3000))
    rec_in = _recording(x)
    rec = measure(rec_in, AcquisitionParameters(seed=2), servo=ServoParameters())
    assert rec.names == rec_in.names
    for a, b in zip(rec_in, rec, strict=True):
        assert (a.sample_rate_hz, a.direction, a.position_m, a.sensitivity, a.role) == \
               (b.sample_rate_hz, b.direction, b.position_m, b.sensitivity, b.role)
        assert a.n_samples == b.n_samples
    assert rec.metadata["seed"] == 1 and rec.metadata["source"] == "test"
    chain = json.loads(rec.metadata["measurement_chain"])
    assert chain["acquisition"]["noise_density"] == 3e-4
    assert chain["servo"]["notch_frequencies_hz"] == [12.0, 26.0]
    # deterministic for a seed, different for another
    again = measure(rec_in, AcquisitionParameters(seed=2))
    np.testing.assert_array_equal(again.channel("ARFVZ").data, rec.channel("ARFVZ").data)
    other = measure(rec_in, AcquisitionParameters(seed=3))
    assert not np.array_equal(other.channel("ARFVZ").data, rec.channel("ARFVZ").data)


def test_clipping_warns():
    x = np.full((2, 2000), 2000.0)  # 2000 m/s^2 * 6.8 mV/(m/s^2) = 13.5 V > 10 V
    with pytest.warns(UserWarning, match="clipped"):
        rec = measure(_recording(x), AcquisitionParameters(noise_density=0.0))
    assert np.max(np.abs(rec.channel("ARFVZ").data)) <= 10.0 / sensor("ARFVZ").sensitivity + 1e-9


def test_bad_parameters():
    with pytest.raises(InputError,
                       match=r"ServoParameters.notch_depths_db = 50.0; expected a value in \[0, 40\] dB"):
        ServoParameters(notch_depths_db=(6.0, 50.0))
    with pytest.raises(InputError, match="one value per notch"):
        ServoParameters(notch_frequencies_hz=(12.0,))
    with pytest.raises(InputError,
                       match=r"ServoParameters.notch_widths_hz = 0.0; expected a value in \(0, 20\]"):
        ServoParameters(notch_widths_hz=(0.0, 4.0))
    with pytest.raises(InputError, match="ServoParameters.seed"):
        ServoParameters(seed=-1)
    with pytest.raises(InputError, match=r"aa_cutoff_ratio = 0.5; expected a value in \[0.1, 0.5\)"):
        AcquisitionParameters(aa_cutoff_ratio=0.5)
    with pytest.raises(InputError, match=r"noise_density = -1.0; expected a value in \[0, 0.1\]"):
        AcquisitionParameters(noise_density=-1.0)
    with pytest.raises(InputError, match=r"adc_bits = 40; expected an integer in \[8, 32\]"):
        AcquisitionParameters(adc_bits=40)
    with pytest.raises(InputError, match="non-finite sample at index 2"):
        servo_response([0.0, 0.0, np.nan, 0.0], FS)
    with pytest.raises(InputError, match="more than twice the highest notch"):
        servo_response(np.zeros(10), 40.0)
    with pytest.raises(InputError, match="sampled at 1500 Hz; expected an integer multiple"):
        measure(_recording(np.zeros((2, 3000)), fs=1500.0))
    odd = Recording((Channel("XYZ1", "acceleration", "m/s^2", "Z", None, FS, np.zeros(100)),))
    with pytest.raises(InputError, match="'XYZ1' has no sensitivity"):
        measure(odd)
