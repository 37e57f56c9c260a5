"""The ``thesis`` scenario: the virtual rig tuned so that its EMA gives roughly thesis Table 1.

The truth is Model 3 (frame, two fuel tanks and two mudguard brackets as separate flexible
bodies, thesis Section 4.5) with the physics of the catalogue (:mod:`exudyn_study.physics`)
that the thesis's discussion points at (Sections 5.3 and 7):

- the four tank mounts are compliant bolted joints (``joint_stiffness``): Model 3's fixed
  joints put the tank modes at 22-26 Hz, the measured ones are at 12-14 Hz; the rotational
  stiffness sets the tanks' vertical (roll) modes, the mounts of the left and right tank
  differ; the right tank's front mount dissipates in rocking (``rotational_damping_factor``
  100: the clamped plates' edges open and micro-slip), the others hardly;
- the right mudguard bracket's bolted joint is compliant too (its ``x``/rotation-about-``z``
  mode near Table 1's 47.6 Hz);
- the left mudguard bracket keeps its fixed joint; its rubber pad is inside the bracket body
  and is stiffer and lossier than the nominal rubber (``bushing_stiffness``: shear modulus
  +2.3 MPa, compression modulus +10.4 MPa, damping time 1.7 ms), its rocking modulus about z
  (the long side) twice and about x three quarters of the compression modulus (a bonded
  block's tilting modulus differs from its compression modulus and between its sides): the
  bracket's x mode rises from 26.6 to 32.7 Hz, its z mode sits at 15.8 Hz; ``bushing_stiffening``
  adds the pad's cubic hardening in compression (per quadrant, so its rocking hardens too),
  small at the white-noise level and a few per cent of the bracket's frequencies with the test
  signal at 300 % (Section 7.4: the rubber's nonlinearity shows with the stronger test signals);
- the frame's rear attachments sit on compliant supports (``rear_support_compliance``,
  2.2e7 N/m vertically each: the attachment bracket, bearing and foundation anchorage the
  tape-measured foundation body leaves out, Section 4.1): with the front held by the drive the
  frame bounces on them at 43.9 Hz, Table 1's frame bending about y (mode 9, 43.84 Hz), which
  no model of the thesis had below 51 Hz (Tables 2-4) and our truth had not below 55 Hz;
- the drive linkage is compliant with its mass (``drive_linkage_compliance``): the ~28 Hz
  resonance between cylinder and frame of Section 7.1. The EMA does not see it, as the
  thesis's did not: with the references at the frame's drive points (``ARFVZ``/``ARFHZ``) the
  transmissibilities have the modes of the chassis with those points held
  (:func:`references_held`), which the linkage does not change;
- the joints', the pad's and the rear supports' stiffness-proportional damping and the bodies'
  modal damping (``modal_damping`` factors on thesis Table 6, the frame's in three bands of its
  body modes) set the modal damping ratios.

The two references move almost together (0.998 and 1.000 m per m of drive), so what the
identification sees is the truth with ONE reference held (``references_held(lin,
('ARFVZ',))``: its modes agree with the identified ones within 0.3 %; with both held the frame
bounce would be at 49.8 Hz). The parameters were fitted (:data:`THESIS_FIT`) on that view,
then checked end to end (``benchmarks/bench_thesis_scenario.py``: ``virtual-test`` +
``identify``). What the catalogue cannot reach is listed in :data:`THESIS_FIT`
(``'not_reached'``).

Result (benchmark, 120 s white noise, identify ``--band 3 50``). Seed 0, both references at
once (``-r ARFVZ ARFHZ``): ten modes, four Table-1 rows within 10 % in frequency and damping,
13.21 Hz (tanks z, 13.66 Hz / 1.39 %), 32.69 Hz (left bracket x, 32.73 Hz / 5.49 %), 43.84 Hz
(frame bending about y: the bounce on the rear supports, 43.99 Hz / 1.89 %) and 47.60 Hz
(right bracket, 47.64 Hz / 0.55 %); nine within 10 % in frequency (also 12.05 <- the sway
11.21 Hz / 1.06 %, 14.15 <- the second tank z mode 15.24 Hz / 1.08 %, 15.00 <- the left bracket
z 15.79 Hz / 2.43 %, 11 % high in damping, 21.21 <- the yaw 20.78 Hz / 0.50 %, and 41.37 <-
41.44 Hz, MPC 0.85, which is not a mode of the truth); the tank fore-aft mode (25.75 Hz) is not
in Table 1. Seed 0, one identification per reference with the common modes averaged (the
thesis's procedure, ``--references each``): the same four rows, 7/10 in frequency (no 41.4 Hz
pole; the left bracket z, 15.79 Hz / 2.41 %, pairs with the 14.15 row and the second tank z
mode with the 15.00 row: the pairing of the three modes in 13.7-15.8 Hz with the three rows in
13.2-15.0 Hz is fragile). Seed 1, both
references: the same four rows (13.67 Hz / 1.49 %, 32.71 Hz / 5.87 %, 43.91 Hz / 2.05 %,
47.66 Hz / 0.50 %), 8/10 in frequency, no pole the truth lacks; the left bracket z is 34 %
high in damping (15.72 Hz / 2.92 %). Seed 1, each reference: the
same four rows, 7/10 in frequency, the 13.7-15.8 Hz pairing as with seed 0. (An extra 20.63 Hz
pole of MPC 0.3 appears with one reference. The virtual test takes 39 s of wall time on the
shared 2-core machine at load 1.5, 530-680 s at load 5-11.)
The identified damping ratios carry the identification's own standard deviations of
0.02-2.3 percentage points at 0.2 Hz resolution (seed 0), so a damping match within 10 % is
partly luck. Before the rear supports and the refit (the earlier truth, seed 0, both
references) four rows were within 10 % in both, seven in frequency, one of them (43.9 Hz) a
pole the truth did not have.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from .scenarios import THESIS_TABLE1, Augment, Scenario

__all__ = [
    "THESIS_SCENARIO",
    "THESIS_PARAMETERS",
    "THESIS_FIT",
    "EMA_REFERENCES",
    "thesis_augmentations",
    "compare_table1",
    "references_held",
    "average_identifications",
]

#: the thesis's EMA references (Section 5.1): the frame side members at the linkage
EMA_REFERENCES = ("ARFVZ", "ARFHZ")

#: fitted parameters (SI): tank and bracket joints, drive linkage, bushing, per-body damping factors
THESIS_PARAMETERS = {
    "joints": {
        # 'component.interface': (translational N/m, rotational N m/rad, damping time s[, rotational damping
        # factor 1: the rotations' damping time over the translations', default 1])
        "tank_left.tank_left_front": (3.97e9, 5.2e5, 0.0),
        "tank_left.tank_left_rear": (7.1e9, 6.36e5, 0.0),
        "tank_right.tank_right_front": (1.64e8, 1.65e5, 4.79e-5, 100.0),
        "tank_right.tank_right_rear": (1.41e8, 1.16e6, 0.0),
        "bracket_right.bracket_right": (9.75e7, 2.87e7, 0.0),
    },
    # the ~28 Hz rig resonance of Section 7.1 (drive -> ARFVZ peak at 27.9 Hz, 3.6 % damped)
    "drive_linkage": {"stiffness_n_per_m": 1.2e7, "damping_n_s_per_m": 4e3, "mass_kg": 20.0},
    # the frame's rear attachments on the foundation: (vertical N/m, longitudinal compliance m/N, damping
    # time s); the frame bounces on them with the front held at 43.9 Hz (Table 1's frame bending about y)
    "rear_support": {"rear_left": (2.2e7, 0.0, 3.58e-4), "rear_right": (2.2e7, 0.0, 3.58e-4)},
    # the left bracket's rubber pad: stiffer than the nominal rubber (G 1.7 -> 4.0 MPa; a bonded thin pad's
    # compression modulus +10 MPa) and lossy (stiffness-proportional damping time, zeta ~ tau omega / 2)
    "bushing_pad": {"shear_modulus_increase_pa": 2.3e6, "compression_modulus_increase_pa": 1.04e7,
                    "damping_time_s": 1.67e-3, "rocking_factor_about_x": 0.75,
                    "rocking_factor_about_z": 2.05},
    # the pad's cubic hardening (Section 7.4): the bracket's modes are set by the pad's rocking and
    # compression (a spring of 1e8 N/m across the faces' mean shear moves them by < 1 %, one of 1e6 N/m per
    # quadrant in compression by 3.5 %), so the hardening is in compression, per quadrant: each quadrant is
    # compressed ~40 um rms by the white noise and ~135 um rms by the test signal at 300 %, so 3 k3 sigma^2
    # is ~1.4e4 N/m at the white noise (nothing) and ~1.6e5 N/m at 300 % (bracket modes +0.6 %; the share
    # y_300 - 6 y_50 of ASVZ ~0.1). (2e13 made the whole truth nonlinear: a share of 0.77 at ASVZ, 3.7 %
    # median over the 42 sensors, so no linear model fitted the test signal at 300 %)
    "bushing_cubic_n_per_m3": 0.0,
    "bushing_compression_cubic_n_per_m3": 3e12,
    # (body, factor, lowest and highest free-free body-mode frequency scaled, Hz) on thesis Table 6; the
    # left bracket's body modes at 170 and 200 Hz carry the pad's shear in its z and x rocking modes; the
    # frame's vertical bending modes (140, 173 Hz) carry its bounce on the rear supports, its lateral ones
    # (44-123 Hz) the right bracket's 47.6 Hz mode
    "modal_damping": (
        ("bracket_left", 0.1, 168.0, 172.0),
        ("bracket_left", 0.112, 195.0, 205.0),
        ("bracket_right", 0.1, 0.0, 1e5),
        ("frame", 0.287, 0.0, 129.0),
        ("frame", 2.0, 130.0, 180.0),
        ("frame", 0.1, 181.0, 1e5),
    ),
}

#: how the parameters were found and what they do not reach (see the module docstring)
THESIS_FIT = {
    "method": (
        "the identification sees the truth with ONE reference held (the two references move together, "
        "0.998/1.000 m per m of drive: the identified frequencies are those of references_held(lin, "
        "('ARFVZ',)) within 0.3 %, not those with both held), so the fit is on that view. Stiffnesses "
        "(rear supports, the pad's rocking factors; tank and bracket joints and pad moduli kept from the "
        "earlier fit): least squares on the log frequencies of the undamped system modes, the linearised "
        "stiffness being affine in each spring (one build per parameter); damping: the damping ratios are "
        "linear in the damping times and modal damping factors to first order, so bounded linear least "
        "squares on per-parameter sensitivities (unit damper at a time), targets corrected once by the "
        "identification's bias seen end to end (tank z and right bracket), then the benchmark. A joint's "
        "translational damper on the stiff left-tank mounts (4-7e9 N/m) is not used: its linearised "
        "contribution to the tank modes is at round-off level (not proportional to the damping time, even "
        "negative), only its rotational damper (rotational_damping_factor) behaves"
    ),
    "truth_modes_hz": {  # one reference held; Table-1 row <- (frequency Hz, damping ratio, shape)
        "12.05": (11.22, 0.0071, "tanks y sway (not z)"),
        "13.21": (13.66, 0.0138, "tanks z"),
        "14.15": (15.34, 0.0079, "tanks z with the left bracket z"),
        "15.00": (15.79, 0.0220, "left bracket z"),
        "21.21": (20.80, 0.0021, "brackets and tanks x, frame yaw on the rear foundation"),
        "(extra)": (25.79, 0.0043, "tanks x, frame x: not in Table 1"),
        "32.69": (32.72, 0.0548, "left bracket x"),
        "43.84": (43.95, 0.0208, "frame bouncing on the rear supports (frame z, right tank z)"),
        "47.60": (47.65, 0.0047, "right bracket x (rotation about z)"),
    },
    "not_reached": (
        (
            "36.64 Hz left bracket x/z: the pad gives the bracket two modes below 100 Hz (z 15.8, x 32.7 Hz "
            "with the rocking factors 0.75/2.05); a third one (the thesis's models put the bracket's rotation"
            " about y at 36-38 Hz) would need the pad's torsion below the nominal rubber's"
        ),
        (
            "41.37 Hz frame bending about y: the rear supports give one frame mode in 41-44 Hz (the frame "
            "bouncing on them, 43.9 Hz); the second needs a second frame z mode there. Softening the supports"
            " differently left and right brings the rolling mode down only to ~50-55 Hz (the frame's "
            "torsion holds it); the frame's own vertical bending with the tanks isolated is at 56-59 Hz"
        ),
        (
            "tank sway and second tank z damping (0.7 and 0.8 % vs Table 1's 1.81 and 1.78 %): the mounts' "
            "rotational dampers damp the first tank z mode about twice as much as the sway and the second z "
            "mode; the translational ones, which would damp the sway more, are numerically unusable on the "
            "stiff left-tank mounts (see 'method')"
        ),
        (
            "frame yaw damping (0.2 % vs 1.19 %): 83 % of that mode's strain is in the rear foundation (the "
            "frame moving fore-aft on it); a damper there (the foundation's modal damping, or the rear "
            "support's longitudinal compliance) damps the right bracket's 47.6 Hz mode, which moves the "
            "frame's rear fore-aft too, about as much"
        ),
    ),
}


def thesis_augmentations(parameters: dict = THESIS_PARAMETERS) -> tuple[Augment, ...]:
    """Return the catalogue entries of the thesis truth (``parameters``: :data:`THESIS_PARAMETERS` layout)."""
    aug = []
    for key, (kt, kr, t, *factor) in parameters["joints"].items():
        values = {"stiffness_n_per_m": kt, "rotational_stiffness_n_m_per_rad": kr, "damping_time_s": t}
        if factor:
            values["rotational_damping_factor"] = factor[0]
        aug.append(Augment("joint_stiffness", key, values))
    aug.append(Augment("drive_linkage_compliance", None, dict(parameters["drive_linkage"])))
    for side, (kz, cx, t) in parameters.get("rear_support", {}).items():
        aug.append(Augment("rear_support_compliance", side, {
            "vertical_stiffness_n_per_m": kz, "longitudinal_compliance_m_per_n": cx, "damping_time_s": t}))
    if "bushing_pad" in parameters:
        aug.append(Augment("bushing_stiffness", "bracket_left", dict(parameters["bushing_pad"])))
    shear_k3 = parameters.get("bushing_cubic_n_per_m3", 0.0)
    compression_k3 = parameters.get("bushing_compression_cubic_n_per_m3", 0.0)
    if shear_k3 > 0 or compression_k3 > 0:
        aug.append(Augment("bushing_stiffening", "bracket_left", {
            "cubic_stiffness_n_per_m3": shear_k3, "compression_cubic_stiffness_n_per_m3": compression_k3}))
    aug += [
        Augment("modal_damping", body, {"factor": f, "min_frequency_hz": lo, "max_frequency_hz": hi})
        for body, f, lo, hi in parameters["modal_damping"]
    ]
    return tuple(aug)


def references_held(lin, references=EMA_REFERENCES):
    """Return the linearised system with the reference sensors' measured displacements held at zero.

    An EMA that divides by reference accelerations (transmissibilities) sees the poles of
    the structure with the reference points held: the modes of this system. The drive
    terms are zero (the references carry the motion).

    Parameters
    ----------
    lin : exudyn_study.modal.LinearSystem
    references : sequence of str
        Sensor names of ``lin`` (their measuring direction is held).

    Returns
    -------
    exudyn_study.modal.LinearSystem
        For :func:`exudyn_study.modal.system_modes`.

    Raises
    ------
    InputError
        A reference that is not a sensor of ``lin``.
    """
    import dataclasses

    import scipy.linalg as sla

    missing = [r for r in references if r not in lin.sensor_names]
    if missing:
        raise InputError(f"references {missing}: not sensors of the model; it has {list(lin.sensor_names)}")
    rows = lin.sensor_output[[lin.sensor_names.index(r) for r in references]]
    held = sla.null_space(rows)  # (n, n - n_ref): admissible increments with the references at rest
    zeros = np.zeros(held.shape[1])
    return dataclasses.replace(
        lin, mass=held.T @ lin.mass @ held, damping=held.T @ lin.damping @ held,
        stiffness=held.T @ lin.stiffness @ held, nullspace=held.T @ lin.nullspace,
        drive_shape=np.zeros_like(lin.drive_shape), b0=zeros, b1=zeros, b2=zeros)


def average_identifications(runs, rtol: float = 0.01) -> list[dict]:
    """Average the modes that separate identifications share (thesis Section 5.1).

    The thesis identified twice, with ``ARFVZ`` and with ``ARFHZ`` as the reference, and took
    the modal parameters as the average of the two. A mode of the first run is kept when every
    other run has one within ``rtol`` in frequency (one-to-one, nearest first); its frequency,
    damping ratio and MPC are the means over the runs.

    Parameters
    ----------
    runs : sequence of sequence of dict
        Per identification its modes, each with ``frequency_hz``, ``damping_ratio`` and
        optionally ``mpc`` (the ``modes`` list of ``exudyn-study identify --json``).
    rtol : float
        Largest relative frequency difference of one mode between runs.

    Returns
    -------
    list of dict
        ``frequency_hz``, ``damping_ratio``, ``mpc`` (NaN when a run has none), sorted by frequency.

    Raises
    ------
    InputError
        No run, or ``rtol`` not positive.
    """
    if not runs:
        raise InputError("average_identifications: no identification given; expected one or more mode lists")
    if not (np.isfinite(rtol) and rtol > 0):
        raise InputError(f"rtol = {rtol!r}; expected a positive relative frequency tolerance (0.01)")
    out = []
    used = [set() for _ in runs]
    for mode in sorted(runs[0], key=lambda m: m["frequency_hz"]):
        group = [mode]
        for k, run in enumerate(runs[1:], start=1):
            near = [
                (abs(m["frequency_hz"] / mode["frequency_hz"] - 1.0), i)
                for i, m in enumerate(run)
                if i not in used[k]
            ]
            near = [d for d in near if d[0] <= rtol]
            if not near:
                break
            i = min(near)[1]
            used[k].add(i)
            group.append(run[i])
        else:
            mpc = [m.get("mpc") for m in group]
            out.append({
                "frequency_hz": float(np.mean([m["frequency_hz"] for m in group])),
                "damping_ratio": float(np.mean([m["damping_ratio"] for m in group])),
                "mpc": float(np.mean(mpc)) if all(v is not None for v in mpc) else float("nan"),
            })
    return out


def compare_table1(
    frequency_hz, damping_ratio, table=THESIS_TABLE1, max_freq_error: float = 0.25
) -> list[dict]:
    """Pair identified modes with Table 1 (one-to-one, least total squared log-frequency distance).

    A mode is paired with a Table-1 mode only within ``max_freq_error``; leaving a mode unpaired
    costs as much as a pair at that distance, so a mode Table 1 does not have (the truth's tank
    fore-aft mode, say) stays extra instead of shifting every pairing above it by one row. The
    distance is squared (a convex cost keeps the frequency order of the pairs): with the plain
    distance, two modes that both lie above (or below) two rows cost the same in either pairing,
    and which one wins is up to round-off (15.24 and 15.79 Hz against the rows 14.15 and 15.00 Hz).

    Parameters
    ----------
    frequency_hz, damping_ratio : array_like, shape (n_modes,)
        Identified natural frequencies (Hz) and damping ratios (1).
    table : sequence of (frequency Hz, damping ratio, description)
    max_freq_error : float
        Largest relative frequency difference of a pair (1).

    Returns
    -------
    list of dict
        One per Table-1 mode, in table order: ``table_hz``, ``table_zeta``, ``description``,
        ``index`` (identified mode, or None when none is left), ``frequency_hz``, ``damping_ratio``,
        ``freq_error`` and ``zeta_error`` (relative, signed), ``within_10pct`` (both errors).
        Identified modes left over are in the last entry's ``extra`` list (indices).

    Raises
    ------
    InputError
        ``max_freq_error`` not positive.
    """
    from scipy.optimize import linear_sum_assignment

    f = np.atleast_1d(np.asarray(frequency_hz, dtype=float))
    z = np.atleast_1d(np.asarray(damping_ratio, dtype=float))
    ft = np.array([row[0] for row in table], dtype=float)
    if not (np.isfinite(max_freq_error) and max_freq_error > 0):
        raise InputError(f"max_freq_error = {max_freq_error!r}; expected a positive relative error (0.25)")
    cap = float(np.log1p(max_freq_error)) ** 2
    dist = np.log(f[:, None] / ft[None, :]) ** 2 if f.size else np.zeros((0, ft.size))
    # columns: the Table-1 modes, then one 'unpaired' slot per identified mode at the cap's cost
    cost = np.hstack([np.where(dist <= cap, dist, 1e6), np.full((f.size, f.size), cap)])
    rows, cols = linear_sum_assignment(cost) if f.size else (np.array([], int), np.array([], int))
    paired = cols < ft.size
    rows, cols = rows[paired], cols[paired]
    match = dict(zip(cols.tolist(), rows.tolist(), strict=True))
    out = []
    for k, (fk, zk, text) in enumerate(table):
        i = match.get(k)
        entry = {"table_hz": fk, "table_zeta": zk, "description": text, "index": i}
        if i is None:
            entry.update(
                frequency_hz=None, damping_ratio=None, freq_error=None, zeta_error=None, within_10pct=False
            )
        else:
            fe, ze = f[i] / fk - 1.0, z[i] / zk - 1.0
            entry.update(
                frequency_hz=float(f[i]),
                damping_ratio=float(z[i]),
                freq_error=float(fe),
                zeta_error=float(ze),
                within_10pct=bool(abs(fe) <= 0.10 and abs(ze) <= 0.10),
            )
        out.append(entry)
    out[-1]["extra"] = sorted(set(range(f.size)) - set(rows.tolist()))
    return out


THESIS_SCENARIO = Scenario(
    name="thesis",
    description="The thesis's rig as we read Sections 5 and 7: Model 3 on compliant tank mounts (the tank "
    "modes at 11-16 Hz, left and right differ), a compliant right mudguard bracket joint, the left "
    "bracket's rubber pad stiffer and lossier than the nominal rubber with a small cubic hardening "
    "(Section 7.4), the frame's rear attachments on compliant supports (the frame bounces on them at "
    "44 Hz: Table 1's frame bending about y), a compliant drive linkage with its mass (the ~28 Hz rig "
    "resonance of Section 7.1, which the EMA does not see) and modal damping factors per body; EMA of "
    "its white-noise recording gives part of thesis Table 1 (see THESIS_FIT).",
    variant=3,
    damping="table6",
    augmentations=thesis_augmentations(),
)
