"""Level-trend diagnosis: each stage against physics it must reproduce, and bad input refused on one line.

Fast tests use linear systems whose FRFs are known in closed form (pole-residue sums driven by a
multisine in periodic steady state, so the DFT of a period is exact) and hand-made modal tables;
the slow tests run the synthetic twin (:mod:`exudyn_study.diagnose.twin`: a 12-mode chain with a
Jenkins joint, force multisine, lab noise and gain drift) through the whole diagnosis.
"""

from __future__ import annotations

import numpy as np
import pytest

from exudyn_study.diagnose.levels import LevelSettings, diagnose_levels
from exudyn_study.diagnose.levels.amplitude import ModalTable
from exudyn_study.diagnose.levels.fit import jenkins_df
from exudyn_study.diagnose.levels.frf import LevelFRF, detect_period, estimate_level_frf, excited_band
from exudyn_study.diagnose.levels.locate import locate_by_sensitivity, locate_pair
from exudyn_study.diagnose.levels.modal import mode_term
from exudyn_study.diagnose.levels.reference import check_reference, identify_reference
from exudyn_study.diagnose.levels.screen import screen_trends
from exudyn_study.errors import InputError
from exudyn_study.linear.nonlinear import JenkinsFriction
from exudyn_study.recording import Channel, Recording

FS = 400.0
#: modes of the closed-form system (Hz, damping ratio) and residues at three sensors
MODES = [(12.0, 0.01), (31.0, 0.008), (55.0, 0.012), (83.0, 0.01)]


def _poles():
    return np.array([complex(-z * 2 * np.pi * f, 2 * np.pi * f * np.sqrt(1 - z * z)) for f, z in MODES])


def _residues():
    rng = np.random.default_rng(3)
    return (rng.standard_normal((3, len(MODES))) + 0.1j * rng.standard_normal((3, len(MODES)))) * 200.0


def _frf(freq_hz, poles=None, residues=None):
    poles = _poles() if poles is None else poles
    residues = _residues() if residues is None else residues
    return sum(mode_term(residues[:, k], poles[k], freq_hz) for k in range(poles.size))


def _multisine_recording(
    period_s=4.0, periods=5, noise=0.0, seed=0, band=(5.0, 120.0), skip_every=0, scramble=None
):
    """Force multisine through the closed-form FRFs: periodic steady state, optional white noise.

    ``scramble=(lo, hi)``: the FRF's phase randomised line by line in that band (Hz), a periodic
    response that no modal model reproduces.
    """
    p = int(period_s * FS)
    f = np.fft.rfftfreq(p, 1 / FS)
    rng = np.random.default_rng(seed)
    exc = (f >= band[0]) & (f <= band[1])
    if skip_every:
        idx = np.flatnonzero(exc)
        exc[idx[::skip_every]] = False  # detection lines
    u_spec = np.where(exc, np.exp(2j * np.pi * rng.random(f.size)), 0.0)
    y_spec = _frf(f) * u_spec
    if scramble is not None:
        m = (f > scramble[0]) & (f < scramble[1])
        y_spec[:, m] *= np.exp(2j * np.pi * np.random.default_rng(2).random(m.sum()))
    u = np.tile(np.fft.irfft(u_spec, p), periods)
    y = np.tile(np.fft.irfft(y_spec, p), (1, periods))
    y = y + noise * np.std(y, axis=1, keepdims=True) * rng.standard_normal(y.shape)
    chans = [Channel(n, "acceleration", "m/s^2", "Z", None, FS, row) for n, row in zip("DAB", y, strict=True)]
    chans.append(Channel("force", "force", "N", "Z", None, FS, u, role="drive"))
    return Recording(tuple(chans), {"source": "closed form"}), f[exc]


def test_periodic_frf_is_the_true_frf_at_the_excited_lines_with_honest_noise():
    rec, lines = _multisine_recording(noise=0.01, periods=8)
    frf = estimate_level_frf(rec, "ms", LevelSettings())
    assert frf.excitation == "periodic" and frf.n_periods == 7  # the first period is dropped
    np.testing.assert_allclose(frf.freq_hz, lines)
    err = frf.H - _frf(frf.freq_hz)
    z = np.abs(err) / frf.sigma
    # normalised errors of a complex Gaussian: rms 1 (within the scatter of 7-period variance estimates)
    assert 0.8 < np.sqrt(np.mean(z**2)) < 1.25
    assert frf.distortion is None  # every line in the band excited: nothing to detect distortion with


def test_distortion_is_seen_at_detection_lines_only_when_the_system_is_nonlinear():
    lin, _ = _multisine_recording(skip_every=4, periods=4)
    f_lin = estimate_level_frf(lin, "lin", LevelSettings())
    assert f_lin.distortion is not None and np.max(f_lin.distortion / np.abs(f_lin.H)) < 1e-6
    # a static cubic at the output puts power on the detection lines
    y = np.array([c.data for c in lin.response_channels])
    y_nl = y + 0.3 * y**3 / np.std(y, axis=1, keepdims=True) ** 2
    chans = [
        Channel(c.name, c.quantity, c.unit, c.direction, None, FS, row)
        for c, row in zip(lin.response_channels, y_nl, strict=True)
    ] + [lin.drive]
    f_nl = estimate_level_frf(Recording(tuple(chans), {}), "nl", LevelSettings())
    assert np.median(f_nl.distortion / np.abs(f_nl.H)) > 1e-3


def test_period_detection_and_a_declared_period_that_does_not_divide_the_record():
    rec, _ = _multisine_recording(period_s=4.0, periods=5)
    assert detect_period(rec.drive.data) == int(4.0 * FS)
    assert detect_period(np.random.default_rng(1).standard_normal(8000)) is None
    with pytest.raises(InputError, match=r"declared period 3\.3 s .* does not divide the record"):
        estimate_level_frf(rec, "ms", LevelSettings(period_s=3.3))


def test_realisations_average_to_the_true_frf_and_show_no_distortion_for_a_linear_system():
    # three realisations of a random-phase multisine, recorded one after the other
    recs = [_multisine_recording(noise=0.01, periods=4, seed=s) for s in (0, 1, 2)]
    lines = recs[0][1]
    chans = [
        Channel(
            c.name,
            c.quantity,
            c.unit,
            c.direction,
            None,
            FS,
            np.concatenate([r.channels[i].data for r, _ in recs]),
            role=c.role,
        )
        for i, c in enumerate(recs[0][0].channels)
    ]
    rec = Recording(tuple(chans), {"source": "3 realisations"})
    frf = estimate_level_frf(rec, "ms", LevelSettings(realisations=3))
    assert frf.excitation == "periodic" and frf.n_periods == 9  # 3 periods each after the transient
    np.testing.assert_allclose(frf.freq_hz, lines)
    z = np.abs(frf.H - _frf(frf.freq_hz)) / frf.sigma
    assert 0.8 < np.sqrt(np.mean(z**2)) < 1.25  # the noise of the mean over realisations
    # linear: the realisations differ by their noise only, the distortion estimate is within the noise
    assert np.median(frf.distortion / frf.sigma) < 1.0
    with pytest.raises(InputError, match="do not split into 7 equal realisations"):
        estimate_level_frf(rec, "ms", LevelSettings(realisations=7))


def test_band_outside_the_data_is_refused():
    rec, _ = _multisine_recording()
    frf = estimate_level_frf(rec, "ms", LevelSettings())
    assert excited_band(frf, None) == pytest.approx((frf.freq_hz[0], frf.freq_hz[-1]))
    with pytest.raises(InputError, match="band 300-400 Hz lies outside the data"):
        excited_band(frf, (300.0, 400.0))


def test_reference_model_recovers_the_modes_and_reproduces_its_recording():
    rec, _ = _multisine_recording(noise=0.002, periods=6)
    frf = estimate_level_frf(rec, "ms", LevelSettings())
    model = identify_reference(frf, excited_band(frf, None), LevelSettings())
    f_true = np.array([m[0] for m in MODES])
    z_true = np.array([m[1] for m in MODES])
    assert model.poles.size == len(MODES)
    np.testing.assert_allclose(model.frequency_hz, f_true, rtol=1e-3)
    np.testing.assert_allclose(model.damping_ratio, z_true, rtol=0.05)
    assert all(v["passed"] and v["within_noise"] for v in model.check.values())
    check_reference(model, frf)  # does not raise


def test_a_reference_that_cannot_fit_is_refused_naming_band_and_modes():
    rec, _ = _multisine_recording(noise=0.002, periods=6)
    frf = estimate_level_frf(rec, "ms", LevelSettings())
    # a recording no modal model explains: the FRF's phase scrambled line by line between 40 and 70 Hz
    h = frf.H.copy()
    m = (frf.freq_hz > 40) & (frf.freq_hz < 70)
    h[:, m] *= np.exp(2j * np.pi * np.random.default_rng(2).random(m.sum()))
    bad = LevelFRF(
        frf.label,
        frf.level,
        frf.freq_hz,
        h,
        frf.sigma,
        None,
        frf.U,
        "periodic",
        frf.resolution_hz,
        frf.n_periods,
        frf.channels,
        "N",
        "m/s^2",
    )
    model = identify_reference(bad, excited_band(bad, None), LevelSettings())
    with pytest.raises(InputError, match=r"does not reproduce its own recording.*worst in (4|5|6)\d"):
        check_reference(model, bad)


def _table(f, z, amp, res=None):
    f, z, amp = (np.atleast_2d(np.asarray(a, float)).T for a in (f, z, amp))
    n = f.shape[0]
    res = np.ones((n, 3, 1), complex) if res is None else res
    return ModalTable(
        tuple(f"L{i}" for i in range(n)),
        np.arange(1.0, n + 1),
        f,
        1e-4 * np.ones_like(f),
        z,
        1e-5 * np.ones_like(z),
        amp,
        "m/s^2",
        ("D",),
        res,
        1e-3 * np.ones(res.shape),
        np.ones_like(f),
    )


@pytest.mark.parametrize(
    ("f", "z", "outcome"),
    [
        ([20.0, 19.98, 19.9, 19.8, 19.7], [0.005, 0.006, 0.008, 0.011, 0.014], "joint_friction"),
        ([20.0, 20.01, 20.05, 20.12, 20.2], [0.005] * 5, "joint_stiffening"),
        ([20.0, 20.0, 20.0, 20.6, 21.0], [0.005] * 5, "joint_clearance"),
        ([20.0, 20.0, 20.0, 20.0, 20.0], [0.005] * 5, "linear"),
        ([20.0, 20.3, 19.8, 20.2, 20.0], [0.005] * 5, "linear_mismodelled"),
    ],
)
def test_trend_screen_names_the_level_dependence(f, z, outcome):
    (t,) = screen_trends(_table(f, z, [1, 2, 4, 8, 16]), LevelSettings())
    assert t.outcome == outcome


def test_location_finds_the_pair_whose_relative_motion_grows_with_slip():
    # shapes at three sensors: the joint between A and B lets their relative motion grow with the level
    n = 5
    res = np.zeros((n, 3, 1), complex)
    for i in range(n):
        res[i, :, 0] = [1.0, 0.8, 0.6 - 0.02 * i]
    table = _table([20.0, 19.95, 19.9, 19.8, 19.7], [0.005, 0.006, 0.008, 0.01, 0.012], [1, 2, 4, 8, 16], res)
    trends = screen_trends(table, LevelSettings())
    pair, evidence = locate_pair(table, trends, ("D", "A", "B"), LevelSettings())
    assert pair == ("A", "B")
    assert evidence[0]["score"] > 0.3 and evidence[0]["z"] > 3


def _chain_modes(n=8, k=1e5, mass=0.5):
    """Mass-normalised modes of a clamped chain of ``n`` equal masses: (f_hz, phi[n, n])."""
    kk = np.diag(np.full(n, 2 * k)) - np.diag(np.full(n - 1, k), 1) - np.diag(np.full(n - 1, k), -1)
    kk[-1, -1] = k
    w2, phi = np.linalg.eigh(kk / mass)
    return np.sqrt(w2) / (2 * np.pi), phi / np.sqrt(mass)


@pytest.mark.parametrize("joint", [(2, 3), (5, 6)])
def test_sensitivity_locates_the_spring_whose_change_moves_every_eigenvalue(joint):
    # a spring between masses a and b loses dk(level) (complex: softening and dissipation); every mode's
    # eigenvalue moves by dk (phi_b - phi_a)^2, the modes with a node across the spring not at all
    f0, phi = _chain_modes()
    sensors = {"D": 0, "A": joint[0], "B": joint[1], "C": 7}
    a, b = joint
    rng = np.random.default_rng(4)
    n_lv, n_m = 5, f0.size
    w0 = 2 * np.pi * f0
    f, z = np.zeros((n_lv, n_m)), np.zeros((n_lv, n_m))
    for lv, dk in enumerate(np.linspace(0.0, 1.0, n_lv) * (-2e3 + 8e2j)):
        om2 = w0**2 * (1 + 2j * 0.01) + dk * (phi[b] - phi[a]) ** 2
        f[lv] = np.sqrt(om2.real) / (2 * np.pi) * (1 + 1e-5 * rng.standard_normal(n_m))
        z[lv] = om2.imag / (2 * om2.real) * (1 + 1e-3 * rng.standard_normal(n_m))
    table = ModalTable(
        tuple(f"L{i}" for i in range(n_lv)),
        np.arange(1.0, n_lv + 1),
        f,
        1e-5 * f,
        z,
        1e-3 * z,
        np.ones_like(f),
        "m/s^2",
        ("D",) * n_m,
        np.ones((n_lv, 4, n_m), complex),
        np.ones((n_lv, 4, n_m)),
        np.ones_like(f),
    )
    names = list(sensors)
    couplings = {
        (p, q): (phi[sensors[q]] - phi[sensors[p]]) ** 2 for i, p in enumerate(names) for q in names[i + 1 :]
    }
    pair, evidence = locate_by_sensitivity(table, couplings, LevelSettings())
    assert pair == ("A", "B")
    assert evidence[0]["z"] > 10 and evidence[0]["reduced_chi2"] < 3
    # the fitted stiffness change at the highest level is the one put in (first order: within 5 %)
    assert complex(*evidence[0]["stiffness_change"][-1]) == pytest.approx(-2e3 + 8e2j, rel=0.05)
    # no change with level: nothing located
    flat = ModalTable(
        *(getattr(table, k) for k in ("labels", "levels")),
        np.tile(f[0], (n_lv, 1)),
        table.frequency_std_hz,
        np.tile(z[0], (n_lv, 1)),
        *(
            getattr(table, k)
            for k in (
                "damping_std",
                "amplitude",
                "amplitude_unit",
                "amplitude_channel",
                "residues",
                "residue_std",
                "chi2",
            )
        ),
    )
    assert locate_by_sensitivity(flat, couplings, LevelSettings())[0] is None


def test_jenkins_describing_function_matches_the_hysteresis_loop():
    # one harmonic cycle of the element's force, Fourier coefficients against the closed form
    law = JenkinsFriction(1.0, 1.0)  # unit stiffness, slip at unit displacement
    for x in (0.5, 1.5, 3.0, 10.0):
        th = np.linspace(0, 2 * np.pi, 20001)
        d = x * np.sin(th)
        st = law.initial_state()
        force = np.empty(th.size)
        for _ in range(2):  # the second cycle is the steady loop
            for k, dk in enumerate(d):
                r, st = law.residual(dk, 0.0, st)
                force[k] = dk + r
        kc = np.trapezoid(force * np.sin(th), th) / (np.pi * x)
        kq = np.trapezoid(force * np.cos(th), th) / (np.pi * x)
        c, q = jenkins_df(np.array([x]))
        assert kc == pytest.approx(c[0], abs=2e-3)
        assert kq == pytest.approx(q[0], abs=2e-3)


@pytest.mark.slow
def test_twin_friction_joint_located_named_fitted_and_proven():
    from exudyn_study.diagnose.twin import Twin, simulate_twin

    recs = simulate_twin([0.2, 0.4, 0.7, 1.1, 1.6], twin=Twin(period_s=10.0), periods=4, seed=0)
    d = diagnose_levels(recs, [0, 2, 4], [1, 3], progress=False)
    (f,) = d.findings
    assert f.physics == "joint_friction"
    assert f.location["interface"] == "A-B"
    pl = f.fit["per_level"]
    assert pl["twin 1.1 N"]["mean_after"] < 0.5 * pl["twin 1.1 N"]["mean_before"]
    assert f.fit["holdout_after"] < f.fit["holdout_before"]


@pytest.mark.slow
def test_twin_with_a_linear_joint_gives_no_finding():
    from exudyn_study.diagnose.twin import Twin, simulate_twin

    recs = simulate_twin([0.2, 0.4, 0.7, 1.1, 1.6], twin=Twin(period_s=10.0, friction_share=0.0), periods=4)
    d = diagnose_levels(recs, [0, 2, 4], [1, 3], progress=False)
    assert not d.findings and not d.mismatch_found


def test_cli_levels_bad_input_is_one_line_and_writes_nothing(tmp_path, capsys):
    from exudyn_study.cli import main
    from exudyn_study.recording import write_recording

    paths = []
    for i in range(3):
        rec, _ = _multisine_recording(noise=0.002, periods=4, seed=i)
        paths.append(str(write_recording(rec, tmp_path / f"l{i}.h5")))
    # a lowest level no modal model reproduces: the FRF's phase scrambled line by line in 40-70 Hz
    rec, _ = _multisine_recording(noise=0.002, periods=4, seed=5, scramble=(40.0, 70.0))
    bad = str(write_recording(rec, tmp_path / "scrambled.h5"))
    out = tmp_path / "d.json"
    base = [
        "diagnose",
        "--model",
        "levels",
        "--train",
        paths[0],
        paths[2],
        "--holdout",
        paths[1],
        "--json",
        str(out),
        "--no-progress",
    ]
    for extra, match in (
        (["--band", "300", "400"], "band 300-400 Hz lies outside the data"),
        (["--train", bad, paths[2]], "does not reproduce its own recording"),
        (["--period", "3.3"], "does not divide the record"),
        (["--realisations", "3"], "do not split into 3 equal realisations"),
        (["--realisations", "0"], "realisations 0; expected an integer >= 1"),
    ):
        assert main(base + extra) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and match in err[0]
        assert not out.exists()


@pytest.mark.parametrize("instrument", [False, True])
@pytest.mark.parametrize("slip", ["stuck", "free"])
def test_twin_truth_is_the_structure_with_the_joint_stuck_or_without_the_slider(slip, instrument):
    from exudyn_study.diagnose import twin as tmod

    tw = tmod.Twin(period_s=5.0)
    p = int(tw.period_s * tw.sample_rate_hz)
    rng = np.random.default_rng(5)
    spec = np.zeros(p // 2 + 1, complex)
    spec[5:900] = np.exp(2j * np.pi * rng.random(895)) / np.arange(5, 900)  # a smooth motion to 180 Hz
    delta = np.tile(np.fft.irfft(spec, p), 3)
    delta *= 1e-4 / np.std(delta)
    k_t = tw.friction_share * tw.stiffness_n_per_m
    # a slider that never slips changes nothing; one that slips at no force removes its spring
    law = JenkinsFriction(k_t, 1e3 * k_t * 1e-4 if slip == "stuck" else 1e-12)
    # an element without distortion has the same k_eq against any instrument correlated with its motion
    # (here the motion delayed by 7 samples, as a drive leads the joint's response)
    drive = np.roll(delta, 7) if instrument else None
    f, z = tmod.truth_modes(tw, delta, law, p, substeps=64, drive=drive)
    m, c, kk = tmod._matrices(tw)
    n, j = tw.n_masses, tw.joint
    e = np.zeros(n)
    e[j - 1], e[j] = -1.0, 1.0
    h = 1.0 / (tw.sample_rate_hz * 64)

    def modes(dk):
        a = np.block(
            [[np.zeros((n, n)), np.eye(n)], [-(kk + dk * np.outer(e, e)) / tw.mass_kg, -c / tw.mass_kg]]
        )
        lam = np.linalg.eigvals(a)
        lam = lam[lam.imag > 0]
        return lam[np.argsort(np.abs(lam))]

    lam = modes(0.0)
    if (
        slip == "free"
    ):  # the slider's spring gone, its force held over each sub-step: -k_t (1 - e^-jwh) / (jwh)
        for r in range(n):
            for _ in range(4):
                wh = abs(lam[r]) * h
                lam[r] = modes(-k_t * (1 - np.exp(-1j * wh)) / (1j * wh))[r]
    np.testing.assert_allclose(f, np.abs(lam) / (2 * np.pi), rtol=2e-4)
    np.testing.assert_allclose(z, -lam.real / np.abs(lam), rtol=1e-6 if slip == "stuck" else 0.01)
