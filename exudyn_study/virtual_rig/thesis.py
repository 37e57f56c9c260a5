"""The ``thesis`` scenario: the virtual rig tuned so that its EMA gives thesis Table 1.

The truth is Model 3 (frame, two fuel tanks and two mudguard brackets as separate flexible
bodies, thesis Section 4.5) with the physics of the catalogue (:mod:`exudyn_study.physics`)
that the thesis's discussion points at (Sections 5.3 and 7); ``docs/thesis-truth.md`` says
which Table-1 row each of its modes is, how the parameters are chosen and why each entry is
there:

- the four tank mounts are compliant bolted joints (``joint_stiffness``): Model 3's fixed
  joints put the tank modes at 22-26 Hz, the measured ones are at 12-14 Hz; the rotational
  stiffness sets the tanks' vertical (roll) modes, the mounts of the left and right tank
  differ. The right tank's mounts are soft only vertically (the entry's ``stiffness_factor_z``:
  2e7 N/m at the front, 3e7 N/m at the rear, 1.64e8 and 1.41e8 N/m in plane), so the frame
  bounces on its rear supports with the right tank pitching, two modes at 41.3 and 44.6 Hz:
  Table 1's two frame modes about y (41.37 and 43.84 Hz). The right tank's front mount
  dissipates in rocking (``rotational_damping_factor`` 39.5: the clamped plates' edges open
  and micro-slip), the others hardly. A translational
  damper on the stiff left-tank mounts (4-7e9 N/m) damps by its spring's share of the modal
  strain energy, below 0.1 % in the tank modes: 0.0002 percentage points per 1e-5 s of
  damping time;
- the right mudguard bracket's bolted joint is compliant too (its ``x``/rotation-about-``z``
  mode near Table 1's 47.6 Hz);
- the left mudguard bracket keeps its fixed joint; its rubber pad is inside the bracket body
  and is stiffer and lossier than the nominal rubber (``bushing_stiffness``: shear modulus
  +2.3 MPa, compression modulus +10.4 MPa, damping time 1.53 ms), its rocking modulus about z
  (the long side) twice and about x 0.45 of the compression modulus (a bonded block's tilting
  modulus differs from its compression modulus and between its sides), and it is nearly free
  in torsion about its normal (``torsion_modulus_change_pa`` -3.92 MPa: 0.08 MPa in total,
  5 % of the nominal rubber's; a pad clamped rather than bonded at its rim): the bracket's z
  mode sits at 15.0 Hz, its x mode at 32.8 Hz (26.6 Hz on the nominal rubber), and it turns
  about y at 36.8 Hz, Table 1's 36.64 Hz mode, which the thesis's models put at 36-38 Hz and
  ours, with the bonded block's torsion, above 120 Hz; ``bushing_stiffening`` adds the pad's
  cubic hardening in compression (per quadrant, so its rocking hardens too), small at the
  white-noise level and a few per cent of the bracket's frequencies with the test signal at
  300 % (Section 7.4: the rubber's nonlinearity shows with the stronger test signals);
- the frame's rear attachments sit on compliant supports (``rear_support_compliance``,
  2.0e7 N/m vertically each, the left one damped: the attachment bracket, bearing and
  foundation anchorage the tape-measured foundation body leaves out, Section 4.1): with the
  front held by the drive the frame bounces on them (with the right tank, above), Table 1's
  frame bending about y (modes 8 and 9), which no model of the thesis had below 51 Hz (Tables
  2-4); longitudinally they give 1e8 N/m (the bracket's web in bending), which takes the frame
  yaw from 22.3 to 21.1 Hz (Table 1's 21.21 Hz) and damps it;
- the water sloshes (``sloshing``, both tanks; 222 l of water in each 400 l tank, Section
  3.1; "in reality the water will move within the fuel tank", Section 4.3, "suspected to be a
  significant source of error", Section 5.3): an equivalent
  slosh mass of 70 kg on horizontal springs at 2.5 Hz, damped at 53 % of critical along the
  tank and 0.357 times that across it (the baffles). Above 2.5 Hz the water lags the tank, so
  every mode that moves a tank horizontally loses that mass (the sway rises from 11.2 to
  11.7 Hz, Table 1's 12.05) and is damped by the slosh damper between the tank and the
  nearly still water, the sway and the frame yaw most, the tanks' vertical modes not at all.
  No joint or body-mode damping could do that: their damping follows the modes' strain
  energy, which the sway and the yaw share with the
  vertical tank modes and the right bracket's 47.6 Hz mode. In the
  3-50 Hz band only the damper ``2 zeta m (2 pi f_s)`` between tank and water and the mass
  show, so the slosh frequency and damping ratio trade: 2.5 Hz is above the first slosh
  frequency of a half-full tank of this size (about 1-1.5 Hz), with a damping ratio a plain
  tank's water would not have; read them as an equivalent damper (1170 N s/m along the tank)
  and mass, not as measured slosh properties;
- the right tank's water-loaded side walls breathe across it (``tank_wall_mode``: 24 kg on a
  spring-damper along y at 18 Hz, 23 % damped): a tuned-mass damper on the tanks' lateral mode
  at 15.7 Hz (0.70 -> 1.51 %; the sway 1.22 -> 1.47 %; the left bracket's z mode, the frame
  bounce and the right bracket +0.01-0.02 points): Table 1's 15.00 Hz row, whose damping no
  joint, support, water or body-mode damper reaches without overdamping the sway or the right
  bracket. The diagnosis has no candidate for it; it explains this mode's extra damping with the water and
  the joints it has;
- the drive linkage is compliant with its mass (``drive_linkage_compliance``): the ~28 Hz
  resonance between cylinder and frame of Section 7.1. The EMA does not see it, as the
  thesis's did not: with the references at the frame's drive points (``ARFVZ``/``ARFHZ``) the
  transmissibilities have the modes of the chassis with those points held
  (:func:`references_held`), which the linkage does not change;
- the joints', the pad's and the rear supports' stiffness-proportional damping and the bodies'
  modal damping (``modal_damping`` factors on thesis Table 6: the frame's in three bands of its
  body modes, the left bracket's in the body modes that carry the pad's torsion and rocking),
  the water's slosh dampers and the wall mode set the modal damping ratios.

The two references move almost together (0.998 and 1.000 m per m of drive), so what the
identification sees is the truth with ONE reference held (``references_held(lin,
('ARFVZ',))``; with both held the frame bounce would be above 49 Hz). The parameters are
chosen on that view and checked end to end by ``benchmarks/bench_thesis_scenario.py``
(``virtual-test`` + ``identify``, one identification per reference, the modes both found
averaged: the thesis's procedure of Section 5.1), which writes the per-row agreement with
Table 1 to ``benchmarks/results/``.

The diagnosis explains this truth (``benchmarks/bench_diagnose_thesis.py``) with its joint
fits started a third time with every member at its prior
(``RigDiagnosisSettings.composite_all_prior_start``); without that start round 1 lands in
another basin and the pad is not found.

Two variants take ingredients out: ``thesis-iso`` (:data:`THESIS_ISO_PARAMETERS`: the tank
mounts equally stiff on all axes, no wall mode) and ``thesis-dry``
(:data:`THESIS_DRY_PARAMETERS`: that truth without the water and the rear supports' fore-aft
compliance).
"""

from __future__ import annotations

import numpy as np

from exudyn_study.errors import InputError
from exudyn_study.virtual_rig.scenario import THESIS_TABLE1, Augment, Scenario

__all__ = [
    "THESIS_SCENARIO",
    "THESIS_PARAMETERS",
    "THESIS_DRY_PARAMETERS",
    "THESIS_DRY_SCENARIO",
    "THESIS_ISO_PARAMETERS",
    "THESIS_ISO_SCENARIO",
    "EMA_REFERENCES",
    "thesis_augmentations",
    "compare_table1",
    "references_held",
    "average_identifications",
]

#: the thesis's EMA references (Section 5.1): the frame side members at the linkage
EMA_REFERENCES = ("ARFVZ", "ARFHZ")

#: the ``thesis-dry`` truth (SI): tank and bracket joints, drive linkage, rear supports (vertical only),
#: the pad and its cubic hardening, per-body damping factors; no water, no fore-aft compliance. Its EMA
#: leaves the tank sway and the frame yaw underdamped (docs/thesis-truth.md)
THESIS_DRY_PARAMETERS = {
    "joints": {
        # 'component.interface': (translational N/m, rotational N m/rad, damping time s[, rotational damping
        # factor 1: the rotations' damping time over the translations', default 1])
        "tank_left.tank_left_front": (3.97e9, 5.2e5, 0.0),
        "tank_left.tank_left_rear": (7.1e9, 6.36e5, 0.0),
        "tank_right.tank_right_front": (1.64e8, 1.65e5, 4.93e-5, 100.0),
        "tank_right.tank_right_rear": (1.41e8, 1.16e6, 0.0),
        "bracket_right.bracket_right": (9.75e7, 2.87e7, 0.0),
    },
    # the ~28 Hz rig resonance of Section 7.1 (drive -> ARFVZ peak at 27.9 Hz, 3.6 % damped)
    "drive_linkage": {"stiffness_n_per_m": 1.2e7, "damping_n_s_per_m": 4e3, "mass_kg": 20.0},
    # the frame's rear attachments on the foundation: (vertical N/m, longitudinal compliance m/N, damping
    # time s); the frame bounces on them with the front held at 43.9 Hz (Table 1's frame bending about y)
    "rear_support": {"rear_left": (2.2e7, 0.0, 3.69e-4), "rear_right": (2.2e7, 0.0, 3.69e-4)},
    # the left bracket's rubber pad: stiffer than the nominal rubber (G 1.7 -> 4.0 MPa; a bonded thin pad's
    # compression modulus +10 MPa) and lossy (stiffness-proportional damping time, zeta ~ tau omega / 2), but
    # nearly free in torsion about its normal (G 0.08 MPa there: the bracket turns about y at 36.8 Hz, where
    # the thesis's models have that mode, 36-38 Hz; with the bonded block's torsion ours is above 120 Hz)
    "bushing_pad": {"shear_modulus_increase_pa": 2.3e6, "compression_modulus_increase_pa": 1.04e7,
                    "damping_time_s": 1.26e-3, "rocking_factor_about_x": 0.85,
                    "rocking_factor_about_z": 2.05, "torsion_modulus_change_pa": -3.92e6},
    # the pad's cubic hardening (Section 7.4): the bracket's modes are set by the pad's rocking and
    # compression (a spring of 1e8 N/m across the faces' mean shear moves them by < 1 %, one of 1e6 N/m per
    # quadrant in compression by 3.5 %), so the hardening is in compression, per quadrant: each quadrant is
    # compressed ~40 um rms by the white noise and ~135 um rms by the test signal at 300 %, so 3 k3 sigma^2
    # is ~1.4e4 N/m at the white noise (nothing) and ~1.6e5 N/m at 300 % (bracket modes +0.6 %; the share
    # y_300 - 6 y_50 of ASVZ ~0.1). (At 2e13 the whole truth is nonlinear: a share of 0.77 at ASVZ, 3.7 %
    # median over the 42 sensors, so no linear model fits the test signal at 300 %)
    "bushing_cubic_n_per_m3": 0.0,
    "bushing_compression_cubic_n_per_m3": 3e12,
    # (body, factor, lowest and highest free-free body-mode frequency scaled, Hz) on thesis Table 6; the
    # left bracket's body modes at 135, 170 and 200 Hz carry the pad's torsion and shear in its y-turning,
    # z and x rocking modes; the
    # frame's vertical bending modes (140, 173 Hz) carry its bounce on the rear supports, its lateral ones
    # (44-123 Hz) the right bracket's 47.6 Hz mode
    "modal_damping": (
        ("bracket_left", 0.192, 130.0, 140.0),
        ("bracket_left", 0.1, 168.0, 172.0),
        ("bracket_left", 0.1, 180.0, 190.0),
        ("bracket_left", 2.18, 195.0, 205.0),
        ("bracket_right", 0.1, 0.0, 1e5),
        ("frame", 0.42, 0.0, 48.0),
        ("frame", 0.287, 48.1, 129.0),
        ("frame", 2.0, 130.0, 180.0),
        ("frame", 0.1, 181.0, 1e5),
    ),
}

#: the ``thesis-iso`` truth (SI): :data:`THESIS_DRY_PARAMETERS` plus the water's slosh dampers (``sloshing``:
#: 70 kg at 2.5 Hz, 50 % damped along the tank, 0.73 times that across it; above 2.5 Hz the water lags the
#: tank, so the sway and the frame yaw are damped by the damper between tank and water, which no joint or
#: body-mode damping can do without overdamping the vertical tank modes and the right bracket) and the rear
#: supports' longitudinal compliance (1e8 N/m: the yaw from 22.3 to 21.2 Hz); the pad's rocking about x at
#: 0.45 (the bracket's z mode at 15.0 Hz, 0.9 Hz below the tanks' lateral mode, as in Table 1); damping
#: fitted for this structure by bounded least squares on first-order modal sensitivities. Its tank mounts
#: are equally stiff on all axes and it has no wall mode, so its EMA has no second frame mode about y near
#: Table 1's 41.37 Hz and leaves the 15.00 Hz row (the tanks' lateral mode) underdamped
#: (docs/thesis-truth.md). The diagnosis benchmark runs on it with ``--scenario thesis-iso``
THESIS_ISO_PARAMETERS = {
    **THESIS_DRY_PARAMETERS,
    "joints": {
        **THESIS_DRY_PARAMETERS["joints"],
        "tank_right.tank_right_front": (1.64e8, 1.65e5, 4.15e-5, 100.0),
    },
    # (vertical N/m, longitudinal compliance m/N, damping time s): 1e8 N/m fore-aft, the yaw at 21.2 Hz
    "rear_support": {"rear_left": (2.2e7, 1e-8, 3.12e-4), "rear_right": (2.2e7, 1e-8, 3.12e-4)},
    # the water (222 l in 400 l, Section 3.1): (slosh frequency Hz, damping ratio along the tank, mass kg,
    # lateral damping factor): a damper of 1100 N s/m between tank and water along x, 800 across, and 70 kg
    # the tanks' horizontal modes lose above 2.5 Hz. 2.5 Hz is above a half-full tank's first slosh
    # frequency (1-1.5 Hz); in 3-50 Hz only the damper and the mass show, so frequency and ratio trade
    "sloshing": {"tank_left": (2.5, 0.5, 70.0, 0.73), "tank_right": (2.5, 0.5, 70.0, 0.73)},
    "bushing_pad": {
        **THESIS_DRY_PARAMETERS["bushing_pad"],
        "damping_time_s": 1.53e-3,
        "rocking_factor_about_x": 0.45,
    },
    "modal_damping": (
        ("bracket_left", 0.204, 130.0, 140.0),
        ("bracket_left", 0.1, 168.0, 172.0),
        ("bracket_left", 2.06, 180.0, 190.0),
        ("bracket_left", 0.898, 195.0, 205.0),
        ("bracket_right", 0.1, 0.0, 1e5),
        ("frame", 0.1, 0.0, 129.0),
        ("frame", 2.46, 130.0, 180.0),
        ("frame", 0.1, 181.0, 1e5),
    ),
}

#: the ``thesis`` truth (SI): :data:`THESIS_ISO_PARAMETERS` with the right tank's mounts soft only vertically
#: (the frame bounces with the right tank at 41.3 and 44.6 Hz: Table 1's two frame modes about y) and the
#: right tank's water-loaded side walls breathing across it (``tank_wall_mode``: 24 kg at 18 Hz, 23 % damped,
#: a tuned-mass damper on the tanks' lateral mode at 15.7 Hz: 0.70 -> 1.51 %, the sway 1.22 -> 1.47 %, the
#: left bracket's z, the frame bounce and the right bracket +0.01-0.02 points: the 15.00 Hz row's damping,
#: which no joint, support, water or body-mode damper reaches without overdamping the sway or the right
#: bracket); the
#: water's slosh damping (0.53, lateral factor 0.357), the left rear support's damping time (2.54e-4 s) and
#: the frame's 130-180 Hz modal damping (x1.70) fitted by least squares on the linearised modes with one
#: reference held, against Table 1 less the identification's offsets measured end to end. How the
#: parameters are chosen and which mode each Table-1 row is: docs/thesis-truth.md. The diagnosis
#: (``bench_diagnose_thesis.py``) needs its joint fits' third start on this truth
#: (``RigDiagnosisSettings.composite_all_prior_start``)
THESIS_PARAMETERS = {
    **THESIS_ISO_PARAMETERS,
    "joints": {
        "tank_left.tank_left_front": (3.97e9, 5.2e5, 0.0),
        "tank_left.tank_left_rear": (7.1e9, 6.36e5, 7e-7, 100.0),
        # soft vertically only (stiffness_factor_z): 2e7 N/m at the front, 3e7 N/m at the rear
        "tank_right.tank_right_front": (1.64e8, 1.65e5, 1.05e-4, 39.5, {"stiffness_factor_z": 2e7 / 1.64e8}),
        "tank_right.tank_right_rear": (1.41e8, 1.16e6, 0.0, 1.0, {"stiffness_factor_z": 3e7 / 1.41e8}),
        "bracket_right.bracket_right": (9.75e7, 2.87e7, 0.0),
    },
    "rear_support": {"rear_left": (2.0e7, 1e-8, 2.54e-4), "rear_right": (2.0e7, 1e-8, 0.0)},
    "sloshing": {"tank_left": (2.5, 0.53, 70.0, 0.357),
                 "tank_right": (2.5, 0.53, 70.0, 0.357)},
    # (wall frequency Hz, damping ratio, mass kg)
    "tank_wall_mode": {"tank_right": (18.0, 0.23, 24.0)},
    "modal_damping": (
        ("bracket_left", 0.194, 130.0, 140.0),
        ("bracket_left", 0.1, 168.0, 172.0),
        ("bracket_left", 2.06, 180.0, 190.0),
        ("bracket_left", 0.898, 195.0, 205.0),
        ("bracket_right", 0.1, 0.0, 1e5),
        ("frame", 0.1, 0.0, 129.0),
        ("frame", 1.70, 130.0, 180.0),
        ("frame", 0.1, 181.0, 1e5),
    ),
}

def thesis_augmentations(parameters: dict = THESIS_PARAMETERS) -> tuple[Augment, ...]:
    """Return the catalogue entries of the thesis truth (``parameters``: :data:`THESIS_PARAMETERS` layout).

    Parameters
    ----------
    parameters : dict
        Entry parameters in the layout of :data:`THESIS_PARAMETERS` ('joints', 'drive_linkage' and
        'modal_damping'; optionally 'rear_support', 'sloshing', 'tank_wall_mode', 'bushing_pad',
        'bushing_cubic_n_per_m3', 'bushing_compression_cubic_n_per_m3'), SI units as in that table.

    Returns
    -------
    tuple of Augment
        One augmentation per joint, the drive linkage, each further entry given, and one per
        modal-damping row.
    """
    aug = []
    for key, (kt, kr, t, *rest) in parameters["joints"].items():
        values = {"stiffness_n_per_m": kt, "rotational_stiffness_n_m_per_rad": kr, "damping_time_s": t}
        if rest:
            values["rotational_damping_factor"] = rest[0]
        if len(rest) > 1:  # per-axis translational factors, e.g. {'stiffness_factor_z': 0.12}
            values.update(rest[1])
        aug.append(Augment("joint_stiffness", key, values))
    aug.append(Augment("drive_linkage_compliance", None, dict(parameters["drive_linkage"])))
    for side, (kz, cx, t) in parameters.get("rear_support", {}).items():
        aug.append(Augment("rear_support_compliance", side, {
            "vertical_stiffness_n_per_m": kz, "longitudinal_compliance_m_per_n": cx, "damping_time_s": t}))
    for tank, (f_s, zeta_s, m_s, *lateral) in parameters.get("sloshing", {}).items():
        values = {"slosh_frequency_hz": f_s, "slosh_damping_ratio": zeta_s, "slosh_mass_kg": m_s}
        if lateral:
            values["lateral_damping_factor"] = lateral[0]
        aug.append(Augment("sloshing", tank, values))
    for tank, (f_w, zeta_w, m_w) in parameters.get("tank_wall_mode", {}).items():
        aug.append(Augment("tank_wall_mode", tank, {
            "wall_frequency_hz": f_w, "wall_damping_ratio": zeta_w, "wall_mass_kg": m_w}))
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
    lin : exudyn_study.linear.modes.LinearSystem
    references : sequence of str
        Sensor names of ``lin`` (their measuring direction is held).

    Returns
    -------
    exudyn_study.linear.modes.LinearSystem
        For :func:`exudyn_study.linear.modes.system_modes`.

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
    frequency_hz, damping_ratio, table=THESIS_TABLE1, max_freq_error: float = 0.15
) -> list[dict]:
    """Pair identified modes with Table 1 (one-to-one, least total squared log-frequency distance).

    A mode is paired with a Table-1 mode only within ``max_freq_error``; leaving a mode unpaired
    costs as much as a pair at that distance, so a mode Table 1 does not have (the truth's tank
    fore-aft mode, say) stays extra instead of shifting every pairing above it by one row. The
    window is 15 %: with 25 %, an identification that missed the 36.6 Hz mode paired the tanks'
    fore-aft mode (27.7 Hz, -15 %) with the left bracket's 32.69 Hz row and that bracket mode
    (32.8 Hz) with the 36.64 Hz row (-10.5 %), two wrong pairs that together cost less than
    leaving the 27.7 Hz mode over. The
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
        raise InputError(f"max_freq_error = {max_freq_error!r}; expected a positive relative error (0.15)")
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
    description="The thesis's rig as we read Sections 5 and 7: Model 3 on compliant tank mounts (the "
    "tank modes at 11-16 Hz, left and right differ; the right tank's mounts soft only vertically) with the "
    "water sloshing in both tanks (an equivalent slosh mass whose damper acts between tank and water) and "
    "the right tank's water-loaded side walls breathing across it (a damped resonator at 18 Hz), a compliant "
    "right mudguard bracket joint, the left bracket's rubber pad stiffer and lossier than the nominal rubber "
    "with a small cubic hardening (Section 7.4), the frame's rear attachments on compliant supports (the "
    "frame bounces on them with the right tank at 41 and 45 Hz: Table 1's two frame modes about y; fore-aft "
    "compliant too), a compliant drive linkage with its mass (the ~28 Hz rig resonance of Section 7.1, "
    "which the EMA does not see) and modal damping factors per body; tuned so that the EMA of its "
    "white-noise recording gives thesis Table 1 (see docs/thesis-truth.md).",
    variant=3,
    damping="table6",
    augmentations=thesis_augmentations(),
)

#: the thesis truth with isotropic tank mounts and no wall mode (see :data:`THESIS_ISO_PARAMETERS`)
THESIS_ISO_SCENARIO = Scenario(
    name="thesis-iso",
    description="As 'thesis' but with the tank mounts equally stiff on all axes and no wall mode, its "
    "damping fitted for that structure; its EMA has no second frame mode about y near Table 1's 41.37 Hz "
    "and leaves the 15.00 Hz row underdamped.",
    variant=3,
    damping="table6",
    augmentations=thesis_augmentations(THESIS_ISO_PARAMETERS),
)

#: ``thesis-iso`` without the water (see :data:`THESIS_DRY_PARAMETERS`)
THESIS_DRY_SCENARIO = Scenario(
    name="thesis-dry",
    description="As 'thesis-iso' but without the water sloshing and the fore-aft compliance of the rear "
    "supports (the pad rocking about x at 0.85 of its compression modulus); its EMA leaves the tank sway "
    "and the frame yaw underdamped.",
    variant=3,
    damping="table6",
    augmentations=thesis_augmentations(THESIS_DRY_PARAMETERS),
)
