"""The ``thesis`` scenario: the virtual rig tuned so that its EMA gives thesis Table 1.

The truth is Model 3 (frame, two fuel tanks and two mudguard brackets as separate flexible
bodies, thesis Section 4.5) with the physics of the catalogue (:mod:`exudyn_study.physics`)
that the thesis's discussion points at (Sections 5.3 and 7):

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
  damping time (before a0722a5 the mount's spring was preloaded by its stiffness times the
  1 cm gap between the patch centres, 40 MN, whose round-off made that contribution noise);
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
  2-4) and our truth had not below 55 Hz; longitudinally they give 1e8 N/m (the bracket's web
  in bending), which takes the frame yaw from 22.3 to 21.1 Hz (Table 1's 21.21 Hz) and damps it;
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
  vertical tank modes and the right bracket's 47.6 Hz mode (see :data:`THESIS_FIT`). In the
  3-50 Hz band only the damper ``2 zeta m (2 pi f_s)`` between tank and water and the mass
  show, so the slosh frequency and damping ratio trade: 2.5 Hz is above the first slosh
  frequency of a half-full tank of this size (about 1-1.5 Hz), with a damping ratio a plain
  tank's water would not have; read them as an equivalent damper (1170 N s/m along the tank)
  and mass, not as measured slosh properties;
- the right tank's water-loaded side walls breathe across it (``tank_wall_mode``: 24 kg on a
  spring-damper along y at 18 Hz, 23 % damped): a tuned-mass damper on the tanks' lateral mode
  at 15.7 Hz (0.70 -> 1.51 %; the sway 1.22 -> 1.47 %; the left bracket's z mode, the frame
  bounce and the right bracket +0.01-0.02 points): Table 1's 15.00 Hz row, whose damping no
  joint, support, water or body-mode damper reached without overdamping the sway or the right
  bracket (:data:`THESIS_FIT` ``'not_reached'``). The diagnosis has no candidate for it; it
  explains this mode's extra damping with the water and the joints it has;
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
('ARFVZ',))``: its modes agree with the identified ones within 0.3 %; with both held the frame
bounce would be above 49 Hz). The parameters were fitted (:data:`THESIS_FIT`) on that view,
then checked end to end (``benchmarks/bench_thesis_scenario.py``: ``virtual-test`` +
``identify``). What the catalogue cannot reach is listed in :data:`THESIS_FIT`
(``'not_reached'``).

Result (benchmark, 120 s white noise, identify ``--band 3 50``, ``--references each``: one
identification per reference, the modes both found averaged, the thesis's procedure of Section
5.1), identified frequency / damping (rows within 10 % in both marked *), seeds 0-3:

====================  ==============  ==============  ==============  ==============
Table-1 row (Hz / %)  seed 0          seed 1          seed 2          seed 3
====================  ==============  ==============  ==============  ==============
12.05 / 1.81          11.70 / 1.87 *  11.69 / 1.80 *  11.70 / 1.91 *  11.69 / 1.83 *
13.21 / 1.46          13.75 / 1.48 *  13.76 / 1.51 *  13.75 / 1.48 *  13.75 / 1.46 *
14.15 / 1.78          14.97 / 1.82 *  14.95 / 1.82 *  14.95 / 1.83 *  14.96 / 1.86 *
15.00 / 2.18          15.67 / 2.11 *  15.68 / 2.07 *  15.67 / 2.17 *  15.69 / 2.13 *
21.21 / 1.19          21.07 / 1.09 *  21.05 / 1.22 *  21.06 / 1.33    21.03 / 1.26 *
32.69 / 5.47          32.76 / 5.44 *  32.77 / 5.57 *  32.77 / 5.50 *  32.76 / 5.49 *
36.64 / 3.46          36.77 / 3.33 *  36.80 / 3.33 *  36.79 / 3.38 *  36.79 / 3.36 *
41.37 / 1.19          41.28 / 1.27 *  41.28 / 1.26 *  41.28 / 1.27 *  41.28 / 1.30 *
43.84 / 2.09          44.61 / 1.94 *  44.60 / 1.94 *  44.61 / 1.94 *  44.60 / 1.98 *
47.60 / 0.53          47.44 / 0.58 *  47.43 / 0.56 *  47.44 / 0.56 *  47.42 / 0.54 *
both within 10 %      10/10           10/10           9/10            10/10
====================  ==============  ==============  ==============  ==============

(Measured in session 15 as ``thesis-table1``, the same truth and seeds; re-run as ``thesis`` in
session 16 with the same figures.) The frame yaw's identified damping scatters by seed
(1.09-1.33 % for a truth of 1.22 %), so that row passes or fails by seed. Left over: the tanks'
fore-aft mode (27.2 Hz, not in Table 1) and, with seeds 1 and 3, a lightly damped pole at 20.9-21.0
Hz beside the yaw. The identified mode at 15.7 Hz has an MPC of 0.34-0.43 (a
complex mode: the wall's heavily damped mode at 18.5 Hz, 22 %, is its neighbour; the identification
does not report that one). Until session 9 the automatic selection could take the 36.6 Hz mode for a
satellite of the 32.8 Hz one (the same shape at the sensors, MAC 1.00, within one whole half-power
bandwidth of that 5.5 % damped mode); the satellite distance is now capped at 5 spectral lines
(:func:`exudyn_study.identify.select_modes`). With one identification for both references (``-r
ARFVZ ARFHZ``, ill-conditioned: the references move together) the result is worse (on the
``thesis-iso`` truth seed 0 gave 3/10). Virtual test 140-200 s and identification 40-75 s of wall
time with two runs side by side on the shared 2-core machine.

The diagnosis explains this truth (``benchmarks/bench_diagnose_thesis.py``): the linkage, the rear
supports, the pad and its cubic hardening are found; its joint fits start a third time with every
member at its prior (``RigDiagnosisSettings.composite_all_prior_start``), without which round 1
lands in another basin and the pad is not found.

The truth of sessions 8-15, with the tank mounts equally stiff on all axes and no wall mode, is
the ``thesis-iso`` scenario (:data:`THESIS_ISO_PARAMETERS`): 7, 8, 7 and 8 of the 10 rows within
10 % on seeds 0-3 (the 15.00 Hz row's damping, 1.2 % for 2.18 %, and the 41.37 Hz row, no mode,
missed; the sway's damping passes or fails by seed).

The session-6 truth without the water and the fore-aft compliance is the ``thesis-dry`` scenario
(:data:`THESIS_DRY_PARAMETERS`): five and six rows within 10 % in both (seeds 0/1, each); the sway
(0.7 % in that truth) and the frame yaw (0.2 %) could not be damped without overdamping the vertical
tank modes and the right bracket, see :data:`THESIS_FIT`.
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
    "THESIS_FIT",
    "EMA_REFERENCES",
    "thesis_augmentations",
    "compare_table1",
    "references_held",
    "average_identifications",
]

#: the thesis's EMA references (Section 5.1): the frame side members at the linkage
EMA_REFERENCES = ("ARFVZ", "ARFHZ")

#: the session-6 fit (SI), the ``thesis-dry`` scenario: tank and bracket joints, drive linkage, bushing,
#: per-body damping factors, no water (5-6 of the 10 Table-1 rows within 10 %; the sway and the frame yaw
#: underdamped)
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
    # y_300 - 6 y_50 of ASVZ ~0.1). (2e13 made the whole truth nonlinear: a share of 0.77 at ASVZ, 3.7 %
    # median over the 42 sensors, so no linear model fitted the test signal at 300 %)
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

#: the ``thesis-iso`` truth (SI; the ``thesis`` truth of sessions 8-15, its tank mounts equally stiff on all
#: axes: the session-6 fit refitted with the water sloshing, session 7). Added to
#: :data:`THESIS_DRY_PARAMETERS`: the water's slosh dampers (``sloshing``: 70 kg at 2.5 Hz, 50 % damped along
#: the tank, 0.73 times that across it; above 2.5 Hz the water lags the tank, so the sway and the frame yaw
#: are damped by the damper between tank and water, which no joint or body-mode damping could do without
#: overdamping the vertical tank modes and the right bracket) and the rear supports' longitudinal compliance
#: (1e8 N/m: the yaw from 22.3 to 21.2 Hz); the pad's rocking about x at 0.45 (the bracket's z mode at 15.0
#: Hz, 0.9 Hz below the tanks' lateral mode, as in Table 1); damping refitted by bounded least squares on
#: first-order modal sensitivities. Measured (``bench_thesis_scenario.py --seed N``, one identification per
#: reference, averaged): 7, 8, 7 and 8 of the 10 Table-1 rows within 10 % in frequency and damping on seeds
#: 0-3 (session 9, with the satellite fix of the mode selection; 7, 7, 7, 8 before; the dry truth: 5 and 6 on
#: seeds 0 and 1); the 15.00 Hz row (the tanks' lateral mode, 0.95 %) and the 41.37 Hz row (no mode) are
#: missed, the sway's damping passes or fails by seed (identified 1.3-1.9 % for 1.56 %). A truth with the
#: right tank's mounts soft only vertically gives 9 of 10 on every seed (see THESIS_FIT['not_reached']; with
#: the wall mode 9-10: :data:`THESIS_PARAMETERS`). The diagnosis finds every entry of this truth, the pad's
#: cubic hardening included (``bench_diagnose_thesis.py --scenario thesis-iso``); before it had candidates for
#: the water and the fore-aft compliance (and fitted the pad's rocking about x free) it missed the cubic here
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

#: the ``thesis`` truth (SI; session 15, as ``thesis-table1``; ``thesis`` since session 16): the per-axis
#: truth of session 9 (the right tank's mounts soft only vertically, so the frame bounces with the right tank
#: at 41.3 and 44.6 Hz: Table 1's two frame modes about y) with the right tank's water-loaded side walls
#: breathing across it (``tank_wall_mode``: 24 kg at 18 Hz, 23 % damped, a tuned-mass damper on the tanks'
#: lateral mode at 15.7 Hz: 0.70 -> 1.51 %, the sway 1.22 -> 1.47 %, the left bracket's z, the frame bounce
#: and the right bracket +0.01-0.02 points; the 15.00 Hz row's damping, which no joint, support, water or
#: body-mode damper reached without overdamping the sway or the right bracket, see THESIS_FIT['not_reached']);
#: the water's slosh damping (0.53, lateral factor 0.357), the left rear support's damping time (2.54e-4 s)
#: and the frame's 130-180 Hz modal damping (x1.70) refitted by least squares on the linearised modes with one
#: reference held, at the identification's offsets measured end to end. Its EMA gives Table 1: 10, 10, 9 and
#: 10 of the 10 rows within 10 % on seeds 0-3 (the table in the module docstring). Tuned on the lateral mode
#: itself (15.6 Hz, 17 %, 9.5 kg) the identification lost the lateral mode (merged with the bracket's z mode
#: into one at 15.0 Hz: 6/10 on seed 0); a second, overdamped slosh mass acting along the tank too (16.7 Hz)
#: gave 9, 10, 10, 7 of 10 (seed 3 lost the mode, MPC 0.03-0.13). The diagnosis (``bench_diagnose_thesis.py``)
#: needs its joint fits' third start (``RigDiagnosisSettings.composite_all_prior_start``, on by default since
#: session 16): without it round 1 lands in another basin (session 15, 910 s: the left tank's front mount at
#: 3.3e5 N/m vertically for 3.97e9, 300 and 193 kg of sloshing water for 70, the linkage's mass 102 kg for 20;
#: held-out 4.61 -> 0.78/0.80, the pad and its cubic hardening not found); with it round 1 reaches 0.465
#: instead of 0.922 and the diagnosis finds the linkage, the rear supports, the pad and its cubic hardening
#: (sessions 15 and 16, 2685 s at load 1-1.6 and 4991 s at load 4: 12 findings, the cubic 2.83e12 N/m^3 for
#: 3e12, held-out 4.61 -> 0.180/0.171, pseudo damage median 59 910 % -> 96 %, 21/21 sensors closer to 100 %)
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

#: how the parameters were found and what they do not reach (see the module docstring)
THESIS_FIT = {
    "method": (
        "the identification sees the truth with ONE reference held (the two references move together, "
        "0.998/1.000 m per m of drive: the identified frequencies are those of references_held(lin, "
        "('ARFVZ',)) within 0.3 %, not those with both held), so the fit is on that view. Stiffnesses "
        "(rear supports, the pad's rocking factors and torsion; tank and bracket joints and pad moduli kept "
        "from the earlier fit): scans and least squares on the frequencies of the undamped system modes, the "
        "linearised stiffness being affine in each spring. Damping: to first order zeta_j = phi_j^T C phi_j "
        "/ (2 omega_j) (phi_j mass-normalised), linear in the damping times, the slosh dampers and the modal "
        "damping factors: sensitivities per parameter (a unit damper on one axis of one spring-damper "
        "through the linearised damping matrix; a body mode's modal damping through the body's modal "
        "coordinates in phi_j), summed over the axes and body modes one catalogue parameter scales, then "
        "bounded linear least squares (scipy lsq_linear) on the relative errors against Table 1 less the "
        "identification's offset measured end to end (identified / truth 1.2-1.3 for the bracket's z mode, "
        "the sway's 0.8-1.2 by seed), the first-order values corrected by the exact damped modes (close "
        "modes exchange damping), then the benchmark (seeds 0-3, "
        "--references each). Strain-energy shares per spring axis and body mode (k delta^2 / omega^2) show "
        "what each mode can be damped by (see 'not_reached'). Session 7: with every spring axis and every "
        "body mode damped freely (up to a 5 ms damping time and 10 % modal damping), the sway stayed at "
        "1.07 % and the yaw at 0.9 % while the vertical tank mode overshot: they needed the water's slosh "
        "damper, which acts on the tanks' horizontal motion only"
    ),
    "truth_modes_hz": {  # one reference held; Table-1 row <- (frequency Hz, damping ratio, shape)
        "12.05": (11.71, 0.0147, "tanks y sway (not z), damped by the water"),
        "13.21": (13.73, 0.0138, "tanks z"),
        "14.15": (14.96, 0.0145, "left bracket z"),
        "15.00": (15.68, 0.0151, "tanks y with the left bracket z and the frame y, damped by the wall mode"),
        "(wall)": (18.51, 0.2205, "the right tank's wall mode (tanks y): not in Table 1"),
        "21.21": (21.03, 0.0122, "brackets and tanks x, frame yaw on the rear supports, damped by the water"),
        "(extra)": (27.16, 0.0139, "tanks x, frame x: not in Table 1"),
        "32.69": (32.75, 0.0542, "left bracket x"),
        "36.64": (36.78, 0.0324, "left bracket turning about y (the pad's torsion)"),
        "41.37": (41.31, 0.0124, "frame bouncing on the rear supports with the right tank pitching"),
        "43.84": (44.66, 0.0194, "frame bouncing on the rear supports with both tanks (frame z, tanks z)"),
        "47.60": (47.43, 0.0048, "right bracket x (rotation about z)"),
    },
    # what the catalogue did not reach on the earlier truths, and how the two hardest rows were reached (the
    # thesis truth since session 16 reaches every row; what is left is the identification's scatter, last)
    "not_reached": (
        (
            "41.37 Hz frame bending about y (reached since session 16): the rear supports give one frame "
            "mode in 41-44 Hz (the frame bouncing on them, 44.3 Hz); the second needs a second frame z mode "
            "there. Session 8 (linearised modes, one reference held): softening the rear supports "
            "differently left and right moves only "
            "the bounce (2.2e7/1e7 N/m: 40.7 Hz; no rolling mode below 60 Hz, the frame's torsion holds it); "
            "a tank bouncing on soft mounts couples with it but the pair stays 5.6 Hz apart (40.2 and 45.8 "
            "Hz, left tank at 2.5e7 N/m), and a soft front mount lets the tank pitch and yaw about its rear "
            "one, two modes 1 Hz apart that mix with the brackets' x modes; the best (right front mount "
            "1.8e7 N/m, supports 1.8e7 N/m, fore-aft 7e-9 m/N) puts modes at 41.49 Hz / 1.17 % and 43.68 Hz "
            "/ 1.60 %, neither frame dominated, and the right bracket's 47.6 Hz mode to 45.0 Hz / 1.46 % "
            "(the mount's rocking damper). The joint entry's stiffness is the same on all three axes, so "
            "every softer mount also moves the tanks' fore-aft modes (21.2 -> 19.5-20.6 Hz). Session 9: with "
            "the entry's per-axis factors (stiffness_factor_x/y/z) the right tank's mounts soft only "
            "vertically (2e7 front, 3e7 N/m rear, in-plane kept), the rear supports at 2.0e7 N/m and the "
            "damping refitted (right support undamped, left 4.9e-4 s; right front mount 1.05e-4 s in "
            "translation; the frame's modal damping 0.1 throughout; the left tank's rear mount 7e-5 s in "
            "rocking; the left bracket's 135 Hz body mode 0.194) put the pair at 41.3 / 1.18 % and 44.6 Hz / "
            "2.02 % (the frame bouncing with the right tank pitching, and with its front) and leave the "
            "other rows: 9 of 10 within 10 % on each of seeds 0-3, only the 15.00 Hz row's damping missed. "
            "That truth was not adopted: the diagnosis fails on it (bench_diagnose_thesis.py, 390 s, with a "
            "joint candidate that also fits the vertical stiffness apart): round 1 lands in a wrong basin "
            "(rear supports 3-4e6 N/m for 2e7, the linkage's mass at its 500 kg bound), held-out error 4.62 "
            "-> 1.09 (session 8's truth: -> 0.096), the cubic not found; without that candidate round 1 "
            "switched the response off and nothing was found. Issue 8's thesis acceptance needs the "
            "diagnosis to work on the truth, so the per-axis truth waits for a diagnosis that finds it. "
            "Session 11 (that truth on the code of 2c7d6fe, whose joint fits hold a damping time that runs to"
            " its bound; fresh recordings): Table 1 again 9/10 on seeds 0 and 1 (the 15.00 Hz row's damping "
            "missed); the diagnosis (isotropic joint candidate, 1119 s) again in the wrong basin: round 1 "
            "took the rear supports at 1.1e6 and 1.5e6 N/m (truth 2e7), the right tank's rear mount at 1.6e7 "
            "N/m in all directions (truth 1.41e8, 3e7 vertically) and the right tank's water at 132 kg, round"
            " 2 the linkage with 500 kg (its bound); held-out error 4.62 -> 1.12, the cubic not found"
            "; session 12 (joint candidates fitting the vertical stiffness apart, a joint fit's second "
            "start): round 1 in the truth's basin, 9 findings all in the truth, held-out 0.51/0.47, but the"
            " pad explained 20 % of what round 1 left (a finding needs 30 %), so neither the pad nor the "
            "cubic was found. Session 13 (branch 'axis', trials not adopted): Table 1 re-measured on that "
            "truth with the current identification, 9/10 on each of seeds 0-3 (10/10 in frequency; only the"
            " 15.00 Hz row's damping missed, 1.08-1.22 % for 2.18 %); refitting the findings together and "
            "screening again when no candidate explains enough left the pad at 15 %; a third start of round"
            " 1's joint fit (every member at its prior) reached a training residual of 0.18 (0.39 before) "
            "but dropped both waters and ended at held-out 0.98/1.20, and on the shipped truth it gave 0.24"
            " (0.095 in session 12). A composite model of a joint fit is exact only where no member's "
            "carried values are clipped (the joint candidate's vertical/in-plane ratio is carried as the "
            "entry's stiffness_factor_z, bounded 1e-3..1e3: a composite built at a ratio of 5000 is 0.9 % "
            "off in its modes on the mini Model 3, 1e-11 unclipped); with the bounds widened to 1e-7..1e7 "
            "(branch fix-clip) rounds 1 and 2 on this truth came out identical (0.392 against 1.812; the "
            "pad again at 20 %), so the clipping is not what hides the pad. Session 14: the composite "
            "made exact everywhere (those bounds adopted, and a composite no longer linearised at a zero "
            "damping time or a rear support carried as rigid) and a fit kept out of indefinite mass "
            "matrices (the water at 300 + 250 kg had made one): round 1 0.934, held-out 0.74/0.76, the pad"
            " still not found; the 0.392 of session 12 came from an inexact composite. Session 15: with the "
            "joint fit's third start (every member at its prior) round 1 on that truth with the wall mode "
            "reached 0.465 (0.922 without) and the diagnosis found the pad and its cubic hardening, so that "
            "truth is the thesis truth since session 16 (the third start on by default)"
        ),
        (
            "15.00 Hz row damping (reached since session 16; on thesis-iso the tanks' lateral mode with the "
            "left bracket z, 0.95 % vs 2.18 %): every "
            "damper that reaches it damps the sway (11.8 Hz) or the right bracket (47.4 Hz) as much "
            "(percentage points on 15.8 / 11.8 / 47.4 Hz): the water's lateral damper x2 +0.17/+0.35/0; a "
            "tank mount's rotational damping (4 ms) +0.8-1.1/+1.5-1.7/0; the frame's 52.5 Hz body mode's "
            "modal damping x60 +1.27/+0.39/+0.73; best combination (frame x40, lateral factor 0.5) 1.67 % "
            "with the sway at 1.57 % but the right bracket at 0.97 % (Table 1: 0.53 %). Session 9 "
            "(first-order sensitivities per damper, on the per-axis trial truth above): the mounts' rocking "
            "dampers and the water's lateral damper give this mode 0.4-0.64 times what they give the sway "
            "(both swing the tanks about their mounts and across the water), so from them it gets at most "
            "~1.0 % with the sway at its 1.6 %; the rest must come from the frame's lateral motion, which "
            "the right bracket's mode shares (per unit modal damping ratio, 15.8 / 11.8 / 47.4 Hz: the "
            "frame's 52.5 Hz body mode 14.4 / 4.1 / 8.4, its 44.0 Hz one 4.9 / 1.7 / 22.4; a damped lateral "
            "compliance of the rear supports, 1e-7 m/N and 1 ms: +0.29 / +0.12 / +0.29 points); the mounts' "
            "lateral stiffness does not move the mode (it swings the tanks, the rotational stiffness holds "
            "it). A least-squares search over the tanks' rotational stiffnesses (left x0.84, right x1.36), "
            "the mounts' rocking dampers and the water's damping (lateral factor 1.44) reached 1.39 % here "
            "(15.9 Hz) with the sway at 1.61 % and the tank z mode at 1.56 %: identified about 1.8 %, still "
            "short of 1.96 %. Session 10: a lateral compliance of the rear supports (the entry's "
            "lateral_compliance_m_per_n, which the diagnosis's rear-support candidate does not fit) swings "
            "the frame sideways and takes this mode below the left bracket's z mode (3e-7 m/N: 15.83 -> "
            "14.47 Hz), so that with the pad's rocking about x at 0.56-0.58 the 15.00 Hz row becomes the "
            "bracket's z mode (15.3 Hz, 1.5-1.7 %), as Table 1 describes it. Fitted on the linearised modes "
            "(one reference held, damping ratios scaled by the identification's offsets measured on the "
            "shipped truth) every row but 41.37 Hz came within 10 %, but end to end it did not: seeds 0/1 "
            "gave 5 and 2 of 10 (the mode at 14.4 Hz identified at 1.6-1.7 times its truth's damping with "
            "MPC 0.02, the right bracket's, pulled to 45.4 Hz beside the frame bounce, at 0.63 times), and "
            "refitted on those offsets (left/right lateral 3.6e-7/1.5e-7 m/N, the right bracket's joint ten "
            "times stiffer to keep its mode at 46 Hz) seeds 0/1 gave 4 and 7 of 10, the offsets moved again "
            "and differed by seed (the bracket's z mode, truth 1.51 %, identified 1.67 and 2.00 %; the 14.7 "
            "Hz mode, 1.11 %, 1.56 and 1.73 %; the sway 2.32 and 2.07 % for 2.04 %): three modes within 1.5 "
            "Hz (13.9, 14.7, 15.3 Hz) at 0.2 Hz resolution are not identified with damping ratios that "
            "follow the truth's, so that truth was not adopted. Session 15: the first selective damper found "
            "is a damped resonator inside the right tank, tuned above this mode (the catalogue's "
            "tank_wall_mode, the tank's water-loaded side walls breathing across it: 24 kg at 18 Hz, 23 %): "
            "on the per-axis truth it takes this mode from 0.70 to 1.51 %, the sway from 1.22 to 1.47 %, and "
            "leaves the left bracket's z mode, the frame bounce and the right bracket (+0.01-0.02 points). "
            "That truth (the per-axis mounts and the wall mode) is the thesis truth since session 16 "
            "(THESIS_PARAMETERS: 10, 10, 9, 10 of 10 on seeds 0-3)"
        ),
        (
            "reached with the water (session 7; the dry truth missed them): the tank sway and the second "
            "tank z mode's damping (0.7-0.8 % without the water: their strain energy sits in the frame and "
            "the mounts' rocking springs, which damp the first tank z mode 2.2 times as much), the frame "
            "yaw's damping (0.2 % dry: 74 % of its strain in one quasi-static rear-foundation body mode) and "
            "the 14.15 Hz row (the dry truth's second z mode at 15.3 Hz)"
        ),
        (
            "15.00 Hz left mudguard bracket: the truth has two modes near 15 Hz, the left bracket's z (14.96 "
            "Hz, 1.45 %, paired with the 14.15 Hz row, +6 %) and the tanks moving sideways with the bracket "
            "and the frame (15.68 Hz, 1.51 %, paired with the 15.00 Hz row, +5 %; on thesis-iso 15.83 Hz, "
            "0.95 %). The pad's rocking modulus "
            "about x (0.45) puts the bracket's mode 0.9 Hz below the other, as in Table 1 (0.85 Hz); at 0.85 "
            "they were 0.2 Hz apart, one spectral line, and the identification merged or mixed them (damping "
            "1.1/2.8 % for 1.0/2.3 %). The tank mounts' rocking stiffnesses move the 15.83 Hz mode by < 0.4 "
            "% per 20 %. Its damping is the slosh damper's (tanks y), the frame's and the right tank's wall "
            "mode's; 2 % from the water alone overdamps the sway, which moves the tanks the same way"
        ),
        (
            "the identification's scatter: with 120 s of white noise at 0.2 Hz resolution the frame yaw's "
            "identified damping ratio is 1.09-1.33 % over seeds 0-3 for a truth of 1.22 % (on thesis-iso "
            "the sway's 1.3-1.8 % for 1.53 %: the vertical drive hardly excites a lateral mode), so rows "
            "near the "
            "10 % limit pass or fail by seed (seed 2: the yaw at 1.33 % for Table 1's 1.19 %, +12 %)"
        ),
    ),
}


def thesis_augmentations(parameters: dict = THESIS_PARAMETERS) -> tuple[Augment, ...]:
    """Return the catalogue entries of the thesis truth (``parameters``: :data:`THESIS_PARAMETERS` layout)."""
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
    "which the EMA does not see) and modal damping factors per body; EMA of its white-noise recording gives "
    "thesis Table 1's 10 rows within 10 % on most seeds, 9 on others (see THESIS_PARAMETERS).",
    variant=3,
    damping="table6",
    augmentations=thesis_augmentations(),
)

#: the truth of sessions 8-15 (see :data:`THESIS_ISO_PARAMETERS`)
THESIS_ISO_SCENARIO = Scenario(
    name="thesis-iso",
    description="The thesis truth of sessions 8-15: as 'thesis' but with the tank mounts equally stiff on "
    "all axes and no wall mode (the water's and the supports' damping as fitted then); its EMA gives 7-8 of "
    "thesis Table 1's 10 rows within 10 % (the 15.00 Hz row underdamped, no mode at 41.37 Hz).",
    variant=3,
    damping="table6",
    augmentations=thesis_augmentations(THESIS_ISO_PARAMETERS),
)

#: the session-6 truth without the water (see :data:`THESIS_DRY_PARAMETERS`)
THESIS_DRY_SCENARIO = Scenario(
    name="thesis-dry",
    description="The session-6 thesis truth: as 'thesis-iso' but without the water sloshing and the fore-aft "
    "compliance of the rear supports (the pad rocking about x at 0.85 of its compression modulus); its EMA "
    "gives 5-6 of thesis Table 1's 10 rows within 10 % (the tank sway and the frame yaw underdamped).",
    variant=3,
    damping="table6",
    augmentations=thesis_augmentations(THESIS_DRY_PARAMETERS),
)
