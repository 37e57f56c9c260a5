"""Damping calibration on a real pipeline system, checked against Exudyn and a forward model.

System: two identical steel beams (1 m, 20 x 30 mm, netgen second-order tets) reduced by
Craig-Bampton with an interface at each end, beam A clamped to ground at its root, beam B
joined rigidly to A's tip (a 2 m cantilever of two flexible bodies), 10 sensors (Y and Z
at five nodes). References: Exudyn's own damped eigenvalues
(``ComputeODE2Eigenvalues(computeComplexEigenvalues=True)``) of the system built with the
damping under test, and targets generated from known body damping (forward model).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from exudyn_study.bodies.damping import MAX_RATIO
from exudyn_study.calibrate import (
    CalibrationSystem,
    DampingDesign,
    SensorPoint,
    calibrate,
    exudyn_damped_modes,
    linearise_design,
    pair_modes,
)
from exudyn_study.errors import InputError
from exudyn_study.identify.model import ModalModel, Mode

# Exudyn's eigen-solver and ours work on the same matrices: agreement to round-off
EXUDYN_ZETA_ATOL = 1e-10
EXUDYN_FREQ_RTOL = 1e-10
# acceptance of the issue: paired modes within 0.1 percentage point; the forward model must
# do far better (exact targets, identifiable design)
RECOVERY_ZETA_ATOL = 1e-7  # fraction, = 1e-5 percentage points
RECOVERY_X_ATOL = 1e-6  # fraction, without regularisation
RECOVERY_X_ATOL_REGULARISED = 1e-3  # alpha = 1e-3 biases x by ~alpha^2 / s^2
# ... and the system damping by ~3e-6 here (measured; 3e-4 percentage points)
RECOVERY_ZETA_ATOL_REGULARISED = 1e-5
TARGET_MAX_HZ = 400.0  # 12 system modes, 8 design variables (4 body modes below 500 Hz per beam)


@pytest.fixture(scope="module")
def beam():
    from netgen.occ import Box, OCCGeometry, Pnt, X

    from exudyn_study.bodies.fe.assembly import PartMaterial, assemble, interface_from_boundary
    from exudyn_study.bodies.ffrf import ffrf_data
    from exudyn_study.bodies.reduction import ReductionSettings, craig_bampton

    box = Box(Pnt(0, 0, 0), Pnt(1.0, 0.02, 0.03))
    box.faces.Min(X).name = "root"
    box.faces.Max(X).name = "tip"
    box.mat("beam")
    fe = assemble(OCCGeometry(box).GenerateMesh(maxh=0.04), [PartMaterial("beam", "steel")])
    itfs = [interface_from_boundary(fe, "root"), interface_from_boundary(fe, "tip")]
    body = craig_bampton(fe, itfs, ReductionSettings(max_frequency_hz=1000.0), name="beam")
    return body, ffrf_data(body)


@pytest.fixture(scope="module")
def builder(beam):
    body, ffrf = beam
    pos = np.asarray(body.node_positions_m)

    def node_near(p):
        return int(np.argmin(np.linalg.norm(pos - np.asarray(p), axis=1)))

    points = {
        "A1": ("A", node_near([0.5, 0.01, 0.03])),
        "A2": ("A", node_near([1.0, 0.02, 0.015])),
        "B1": ("B", node_near([0.25, 0.0, 0.015])),
        "B2": ("B", node_near([0.5, 0.01, 0.03])),
        "B3": ("B", node_near([1.0, 0.02, 0.015])),
    }

    def build(ratios) -> CalibrationSystem:
        import exudyn as exu
        import exudyn.itemInterface as eii

        from exudyn_study.bodies.ffrf import add_flexible_body

        sc = exu.SystemContainer()
        mbs = sc.AddSystem()
        ha = add_flexible_body(mbs, body, ffrf, ratios["A"], name="A")
        hb = add_flexible_body(mbs, body, ffrf, ratios["B"], position_m=(1.0, 0.0, 0.0), name="B")
        ground = mbs.AddObject(eii.ObjectGround())
        m_ground = mbs.AddMarker(
            eii.MarkerBodyRigid(bodyNumber=ground, localPosition=list(ha.interface_positions_m["root"]))
        )
        mbs.AddObject(
            eii.ObjectJointGeneric(
                markerNumbers=[m_ground, ha.interface_markers["root"]], constrainedAxes=[1] * 6
            )
        )
        mbs.AddObject(
            eii.ObjectJointGeneric(
                markerNumbers=[ha.interface_markers["tip"], hb.interface_markers["root"]],
                constrainedAxes=[1] * 6,
            )
        )
        mbs.Assemble()
        sensors = {
            f"{name}{axis}": SensorPoint(b, node, direction)
            for name, (b, node) in points.items()
            for axis, direction in (("Y", (0, 1, 0)), ("Z", (0, 0, 1)))
        }
        return CalibrationSystem(mbs, {"A": ha, "B": hb}, sensors, owner=sc)

    return build


@pytest.fixture(scope="module")
def per_mode(beam):
    # 4 body modes below 500 Hz per beam (106, 159, 293, 439 Hz) are design variables; the
    # others fixed at 5 %
    return DampingDesign.per_mode({"A": beam[0], "B": beam[0]}, cutoff_hz=500.0, above=0.05)


def forward_target(builder, design, x_true, max_hz=TARGET_MAX_HZ, shapes=True) -> ModalModel:
    """Target modes of the system built with known damping: f, zeta from Exudyn itself."""
    system = builder(design.ratios(x_true))
    f_ex, z_ex = exudyn_damped_modes(system.mbs)
    lin = linearise_design(system, design)
    m = lin.modes(x_true)
    assert np.allclose(m.frequency_hz[: f_ex.size], f_ex, rtol=1e-9)
    sel = np.flatnonzero(f_ex < max_hz)
    return ModalModel(
        tuple(
            Mode(
                f_ex[k],
                z_ex[k],
                shape=dict(zip(lin.sensor_names, m.shapes[:, k], strict=True)) if shapes else {},
            )
            for k in sel
        )
    )


# ------------------------------------------------------------------ linear basis vs Exudyn


@pytest.mark.parametrize("above", [0.05, MAX_RATIO], ids=["fixed-5pct", "fixed-100pct"])
def test_linear_damping_basis_equals_exudyn_damped_eigenvalues(beam, builder, above):
    design = DampingDesign.per_mode({"A": beam[0], "B": beam[0]}, cutoff_hz=500.0, above=above)
    x = np.random.default_rng(7).uniform(0.0, 0.3, design.n_variables)
    # linearise a system built with unrelated damping: the builder's damping is replaced
    lin = linearise_design(builder(design.ratios(np.full(design.n_variables, 0.6))), design)
    ours = lin.modes(x)
    f_ex, z_ex = exudyn_damped_modes(builder(design.ratios(x)).mbs)
    assert ours.frequency_hz.size == f_ex.size >= 10  # overdamped pairs drop out of both
    np.testing.assert_allclose(ours.frequency_hz, f_ex, rtol=EXUDYN_FREQ_RTOL)
    np.testing.assert_allclose(ours.damping_ratio, z_ex, atol=EXUDYN_ZETA_ATOL)
    # the basis really spans the body damping: the damped system differs from the undamped
    assert np.ptp(ours.damping_ratio) > 0.01


def test_eigenvalue_derivatives_match_central_differences(builder, per_mode):
    lin = linearise_design(builder(per_mode.ratios(np.full(per_mode.n_variables, 0.02))), per_mode)
    x = np.random.default_rng(3).uniform(0.01, 0.2, per_mode.n_variables)
    m = lin.modes(x, derivatives=True)
    h = 1e-6
    for j in range(per_mode.n_variables):
        xp, xm = x.copy(), x.copy()
        xp[j] += h
        xm[j] -= h
        mp, mm = lin.modes(xp), lin.modes(xm)
        dz = (mp.damping_ratio - mm.damping_ratio) / (2 * h)
        df = (mp.frequency_hz - mm.frequency_hz) / (2 * h)
        # central differences: truncation ~h^2, round-off ~1e-16 / h
        np.testing.assert_allclose(m.d_damping[:, j], dz, atol=1e-7)
        np.testing.assert_allclose(m.d_frequency_hz[:, j], df, atol=1e-5 * np.abs(m.frequency_hz).max() / 100)


def test_holding_a_sensor_interlaces_the_frequencies_and_keeps_exact_derivatives(builder, per_mode):
    """One more constraint (the EMA reference held): the sensor's output vanishes in every mode, and
    Rayleigh's theorem of constraint interlaces the frequencies, f_k <= f_held,k <= f_k+1 (one
    constraint, light damping); the damping stays affine, so the derivatives stay exact."""
    lin = linearise_design(builder(per_mode.ratios(np.full(per_mode.n_variables, 0.02))), per_mode)
    held = lin.held(["B2Y"])
    x = np.full(per_mode.n_variables, 1e-3)
    free, m = lin.modes(x), held.modes(x, derivatives=True)
    assert held.size == lin.size - 1
    assert np.abs(m.shapes[list(held.sensor_names).index("B2Y")]).max() < 1e-9
    k = min(m.frequency_hz.size, free.frequency_hz.size - 1)
    assert np.all(m.frequency_hz[:k] >= free.frequency_hz[:k] * (1 - 1e-6))
    assert np.all(m.frequency_hz[:k] <= free.frequency_hz[1:k + 1] * (1 + 1e-6))
    assert np.any(m.frequency_hz[:k] > free.frequency_hz[:k] * 1.01)  # the Y bending modes stiffen
    j, h = 0, 1e-6
    xp, xm = x.copy(), x.copy()
    xp[j] += h
    xm[j] -= h
    dz = (held.modes(xp).damping_ratio - held.modes(xm).damping_ratio) / (2 * h)
    np.testing.assert_allclose(m.d_damping[:, j], dz, atol=1e-7)
    with pytest.raises(InputError, match=r"held sensor\(s\) \['nope'\]"):
        lin.held(["nope"])


def test_sensor_shapes_follow_the_beam_physics(builder, per_mode):
    """First mode of a cantilever: tip moves most, shapes grow along the beam, Y/Z separate."""
    lin = linearise_design(builder(per_mode.ratios(np.full(per_mode.n_variables, 0.02))), per_mode)
    m = lin.modes(np.full(per_mode.n_variables, 0.02))
    names = list(lin.sensor_names)
    first = np.abs(m.shapes[:, 0])  # 4.19 Hz: bending about z (20 mm side) -> Y motion
    y = [first[names.index(n)] for n in ("A1Y", "A2Y", "B1Y", "B2Y", "B3Y")]
    assert y[-1] == pytest.approx(1.0)
    assert all(a < b for a, b in zip(y, y[1:], strict=False))
    # the unstructured tet mesh is not exactly symmetric: Y/Z cross-talk ~2e-4, not zero
    assert max(first[names.index(n)] for n in names if n.endswith("Z")) < 1e-3
    # 2 m Euler-Bernoulli cantilever, 20 mm bending height: f1 = 1.8751^2/(2 pi L^2) sqrt(EI/(rho A))
    f_eb = 1.8751**2 / (2 * math.pi * 4.0) * math.sqrt(210e9 * 0.02**2 / 12 / 7850)
    assert m.frequency_hz[0] == pytest.approx(f_eb, rel=0.02)


# ------------------------------------------------------------------ forward-model recovery


@pytest.mark.parametrize("regularization", [0.0, 1e-3], ids=["plain", "regularised"])
def test_forward_model_recovery_per_mode(builder, per_mode, regularization):
    x_true = np.random.default_rng(1).uniform(0.005, 0.08, per_mode.n_variables)
    target = forward_target(builder, per_mode, x_true)
    assert len(target) == 12
    start = np.full(per_mode.n_variables, 0.3)
    result = calibrate(builder, per_mode, target, x0=start, regularization=regularization, verify=True)
    assert result.success
    assert len(result.paired) == len(target) and not result.unpaired_targets
    assert result.max_abs_error < (
        RECOVERY_ZETA_ATOL if regularization == 0 else RECOVERY_ZETA_ATOL_REGULARISED
    )
    tol = RECOVERY_X_ATOL if regularization == 0 else RECOVERY_X_ATOL_REGULARISED
    np.testing.assert_allclose(result.variables, x_true, atol=tol)
    np.testing.assert_allclose(result.body_damping["A"][:4], x_true[:4], atol=tol)
    assert np.all(result.body_damping["B"][4:] == 0.05)  # fixed above the cut-off
    assert result.exudyn_check < 1e-10  # rebuilt with the result: Exudyn agrees
    assert result.n_evaluations < 60


def test_forward_model_recovery_per_body_without_shapes(beam, builder):
    design = DampingDesign.per_body({"A": beam[0], "B": beam[0]})
    x_true = np.array([0.043, 0.0076])
    target = forward_target(builder, design, x_true, max_hz=250.0, shapes=False)
    result = calibrate(builder, design, target, x0=[0.5, 0.5], regularization=0.0)
    assert np.isnan(result.paired[0].mac or np.nan)  # frequency-only pairing
    np.testing.assert_allclose(result.variables, x_true, atol=RECOVERY_X_ATOL)
    assert result.max_abs_error < RECOVERY_ZETA_ATOL


def test_one_ratio_per_body_cannot_give_one_body_s_modes_different_damping(builder, per_mode):
    # the truth damps beam A's first body mode at 0.5 % and its second at 6 %: the system modes
    # they dominate need different ratios of one body, which the per-mode design reaches exactly
    # and the per-body design (thesis Table 6 layout) cannot; this is why the grid calibrates
    # every model per body mode
    x_true = np.full(per_mode.n_variables, 0.02)
    x_true[per_mode.variable_names.index("A:mode1")] = 0.005
    x_true[per_mode.variable_names.index("A:mode2")] = 0.06
    target = forward_target(builder, per_mode, x_true)
    exact = calibrate(builder, per_mode, target, x0=np.full(per_mode.n_variables, 0.3), regularization=0.0)
    assert exact.max_abs_error < RECOVERY_ZETA_ATOL
    per_body = DampingDesign.per_body({"A": per_mode.body_frequencies_hz["A"],
                                       "B": per_mode.body_frequencies_hz["B"]})
    lumped = calibrate(builder, per_body, target, x0=[0.3, 0.3], regularization=0.0)
    assert lumped.max_abs_error > 0.005  # half a percentage point off at least one paired mode


# ------------------------------------------------------------------ pairing


def test_pairing_by_mac_when_two_modes_swap_order(builder, per_mode):
    """Modes 10/11 (Y and Z bending, 354.8 / 355.8 Hz): the target lists them in swapped order."""
    x_true = np.random.default_rng(1).uniform(0.005, 0.08, per_mode.n_variables)
    target = forward_target(builder, per_mode, x_true)
    modes = list(target.modes)
    a, b = modes[9], modes[10]
    assert abs(a.frequency_hz - b.frequency_hz) / a.frequency_hz < 0.01
    swapped = list(modes)
    swapped[9] = Mode(b.frequency_hz, a.damping_ratio, shape=a.shape)
    swapped[10] = Mode(a.frequency_hz, b.damping_ratio, shape=b.shape)
    target_swapped = ModalModel(tuple(swapped))
    # pure pairing: by shape the swap is undone, by frequency alone it is not
    f_t, phi_t = target_swapped.frequency_hz, target_swapped.shapes()
    f_m, phi_m = target.frequency_hz, target.shapes()
    by_mac = pair_modes(f_m, f_t, phi_m, phi_t)
    by_freq = pair_modes(f_m, f_t)
    t_of = dict(zip(by_mac.model_index.tolist(), by_mac.target_index.tolist(), strict=True))
    assert target_swapped.modes[t_of[9]].shape == a.shape
    assert target_swapped.modes[t_of[10]].shape == b.shape
    t_freq = dict(zip(by_freq.model_index.tolist(), by_freq.target_index.tolist(), strict=True))
    assert target_swapped.modes[t_freq[9]].shape == b.shape  # the trap MAC avoids
    # calibration on the swapped target still recovers the known damping
    result = calibrate(
        builder, per_mode, target_swapped, x0=np.full(per_mode.n_variables, 0.3), regularization=0.0
    )
    np.testing.assert_allclose(result.variables, x_true, atol=RECOVERY_X_ATOL)
    row10 = result.paired[9]
    assert row10.frequency_hz == pytest.approx(a.frequency_hz, rel=1e-9)
    assert row10.target_frequency_hz == pytest.approx(b.frequency_hz, rel=1e-12)


def test_unpaired_modes_are_reported(builder, per_mode, tmp_path):
    x_true = np.random.default_rng(1).uniform(0.005, 0.08, per_mode.n_variables)
    target = forward_target(builder, per_mode, x_true)
    dropped = target.modes[6]  # model mode 7 (144 Hz) gets no target
    extra = Mode(14.0, 0.02, shape=dict(target.modes[0].shape))  # no model mode near 14 Hz
    modes = [m for k, m in enumerate(target.modes) if k != 6] + [extra]
    result = calibrate(builder, per_mode, ModalModel(tuple(modes)), regularization=0.0)
    assert [r.target_frequency_hz for r in result.unpaired_targets] == [14.0]
    lonely = [r for r in result.unpaired_model if abs(r.frequency_hz - dropped.frequency_hz) < 1.0]
    assert len(lonely) == 1 and lonely[0].target_damping_ratio is None
    assert result.max_abs_error < 1e-6
    doc = json.loads(result.to_json({"model": "two beams"}))
    assert doc["format"] == "exudyn_study.calibration"
    nulls = [m for m in doc["modes"] if m["target_damping_ratio"] is None]
    assert any(abs(m["frequency_hz"] - dropped.frequency_hz) < 1.0 for m in nulls)
    assert doc["unpaired_targets"] == [{"target_frequency_hz": 14.0, "target_damping_ratio": 0.02}]
    assert set(doc["body_damping"]) == {"A", "B"}
    assert len(doc["body_damping"]["A"]["damping_ratio"]) == per_mode.body_frequencies_hz["A"].size
    assert "unpaired" not in result.table()  # rows, not words: '-' where no target
    png = result.plot(tmp_path / "damping.png") and tmp_path / "damping.png"
    assert png.stat().st_size > 10_000


# ------------------------------------------------------------------ bad input


def test_target_without_modes_in_the_model_band(builder, per_mode):
    target = ModalModel((Mode(0.5, 0.02), Mode(0.8, 0.01)))  # first model mode at 4.2 Hz
    with pytest.raises(InputError, match="target: none of its 2 modes"):
        calibrate(builder, per_mode, target)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"x0": np.full(8, 1.2)}, r"start damping ratio .* \[0, 1\)"),
        ({"prior": -0.01}, r"prior damping ratio .* \[0, 1\)"),
        ({"x0": np.full(3, 0.02)}, "x0 has 3 values"),
        ({"weights": [1.0, 2.0]}, "weights: expected 1 finite"),
        ({"regularization": -1.0}, "regularization"),
    ],
)
def test_bad_calibration_arguments(builder, per_mode, kwargs, match):
    target = ModalModel((Mode(26.0, 0.01),))
    with pytest.raises(InputError, match=match):
        calibrate(builder, per_mode, target, **kwargs)


def test_bad_designs(beam, builder):
    body = beam[0]
    with pytest.raises(InputError, match="no design variable"):
        DampingDesign.per_mode({"A": body}, cutoff_hz=10.0)
    with pytest.raises(InputError, match=r"fixed damping ratio .* \[0, 1\)"):
        DampingDesign.per_mode({"A": body}, cutoff_hz=500.0, above=1.0)
    design = DampingDesign.per_body({"C": body})
    system = builder({"A": np.full(body.n_modes, 0.02), "B": np.full(body.n_modes, 0.02)})
    with pytest.raises(InputError, match="design body 'C' is not in the system"):
        linearise_design(system, design)


def test_mode_with_damping_outside_unit_interval():
    with pytest.raises(InputError, match="damping_ratio=1.5: expected"):
        Mode(10.0, 1.5)


@pytest.mark.parametrize(
    "content, match",
    [
        ("not json at all", "not valid JSON"),
        ('{"format": "exudyn_study.recording", "modes": []}', "format 'exudyn_study.recording'"),
        ('{"modes": [{"frequency_hz": 12.0, "damping_ratio": 1.2}]}', "damping_ratio=1.2: expected"),
        ('{"modes": []}', "holds no modes"),
    ],
)
def test_cli_bad_target_writes_nothing(tmp_path, capsys, content, match):
    from exudyn_study.cli import main

    target = tmp_path / "modes.json"
    target.write_text(content)
    out = tmp_path / "out.json"
    code = main(["calibrate", "--model", "1", "--target", str(target), "--json", str(out)])
    err = capsys.readouterr().err
    assert code == 2
    assert len(err.strip().splitlines()) == 1
    assert "exudyn-study calibrate: error:" in err
    assert __import__("re").search(match, err), err
    assert not out.exists()


def test_cli_bad_numbers(tmp_path, capsys):
    from exudyn_study.cli import main

    target = tmp_path / "modes.json"
    target.write_text(ModalModel((Mode(12.0, 0.02),)).to_json())
    out = tmp_path / "out.json"
    assert (
        main(
            [
                "calibrate",
                "--model",
                "2",
                "--target",
                str(target),
                "--json",
                str(out),
                "--above-percent",
                "120",
            ]
        )
        == 2
    )
    assert "--above-percent 120: out of range; expected >= 0 and <= 100 %" in capsys.readouterr().err
    blocker = tmp_path / "a_file"
    blocker.write_text("x")
    argv = ["calibrate", "--model", "2", "--target", str(target), "--json", str(blocker / "o.json")]
    assert main(argv) == 2
    assert "is a file, not a directory" in capsys.readouterr().err
    assert main(["calibrate", "--model", "2", "--target", str(target), "--json", str(target)]) == 2
    assert "is the input --target" in capsys.readouterr().err
    assert not out.exists() and target.read_text() == ModalModel((Mode(12.0, 0.02),)).to_json()
