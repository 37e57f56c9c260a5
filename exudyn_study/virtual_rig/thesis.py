"""The ``thesis`` scenario: the virtual rig tuned so that its EMA gives roughly thesis Table 1.

The truth is Model 3 (frame, two fuel tanks and two mudguard brackets as separate flexible
bodies, thesis Section 4.5) with the physics of the catalogue (:mod:`exudyn_study.physics`)
that the thesis's discussion points at (Sections 5.3 and 7):

- the four tank mounts are compliant bolted joints (``joint_stiffness``): Model 3's fixed
  joints put the tank modes at 22-26 Hz, the measured ones are at 12-14 Hz; the rotational
  stiffness sets the tanks' vertical (roll) modes, the mounts of the left and right tank
  differ;
- the right mudguard bracket's bolted joint is compliant too (its ``x``/rotation-about-``z``
  mode near Table 1's 47.6 Hz);
- the left mudguard bracket keeps its fixed joint; its rubber pad is inside the bracket body
  and is stiffer and lossier than the nominal rubber (``bushing_stiffness``: shear modulus
  +2.3 MPa, compression modulus +10.4 MPa, damping time 1.2 ms; the bracket's x mode rises from
  26.6 to 30.2 Hz, as the thesis's own models put it at 33-36 Hz), and ``bushing_stiffening``
  adds the pad's cubic hardening, small at the white-noise level (Section 7.4: the rubber's
  nonlinearity shows with the stronger test signals);
- the drive linkage is compliant with its mass (``drive_linkage_compliance``): the ~28 Hz
  resonance between cylinder and frame of Section 7.1. The EMA does not see it, as the
  thesis's did not: with the references at the frame's drive points (``ARFVZ``/``ARFHZ``) the
  transmissibilities have the modes of the chassis with those points held
  (:func:`references_held`), which the linkage does not change;
- the joints' and the pad's stiffness-proportional damping and the bodies' modal damping
  (``modal_damping`` factors on thesis Table 6) set the modal damping ratios.

The parameters were fitted (:data:`THESIS_FIT`) on the linearised truth's system modes with
the EMA references held, then checked end to end (``benchmarks/bench_thesis_scenario.py``:
``virtual-test`` + ``identify``). What the catalogue cannot reach is listed in
:data:`THESIS_FIT` (``'not_reached'``).

Result (benchmark, seed 0, 120 s white noise, identify ``-r ARFVZ ARFHZ --band 3 50``): eight
modes, 11.29, 13.79, 16.44, 20.80, 25.74, 30.20, 43.94 and 47.64 Hz. Four Table-1 modes within
10 % in frequency and damping, all four modes of the truth: 14.15 Hz (tank z, 13.79 Hz / 1.76 %),
15.00 Hz (left bracket z, 16.44 Hz / 2.22 %), 32.69 Hz (left bracket x, 30.20 Hz / 5.02 %) and
47.60 Hz (right bracket, 47.64 Hz / 0.53 %); seven within 10 % in frequency (also 12.05 <- the
tank sway 11.29 Hz, 21.21 <- the frame yaw 20.80 Hz, both damped too little, and 43.84 <- 43.94
Hz, MPC 0.76, which is not a mode of the truth). The truth's tank fore-aft mode (25.74 Hz) is
not in Table 1; its second tank z mode (15.7 Hz, 0.6 %) is not identified. Seed 1: three
rows within 10 % in both (15.00, 32.69, 47.60 Hz), ten in frequency of which three
(36.73, 41.86, 44.15 Hz) are poles the truth does not have. The identified
damping ratios carry the identification's own standard deviations of 0.2-1.9 percentage points
at 0.2 Hz resolution, so a damping match within 10 % is partly luck.

The two references move almost together (0.998 and 1.000 m per m of drive): identified with
both at once the problem is ill-conditioned and shows poles the truth does not have (the
43.9 Hz one; 35-40 Hz ones in earlier fits). Identified as the thesis did (Section 5.1: one
identification per reference, the modes both found averaged; the benchmark's ``--references
each``), there are no such poles but, with the same truth, fewer matches: seven modes (11.30,
13.74, 16.38, 20.79, 25.77, 30.14, 50.74 Hz), six Table-1 frequencies and one row (32.69 Hz)
within 10 % in both; the right bracket shows at 50.7 Hz (the truth with one reference held has
modes at 47.6 and 50.7 Hz) and the identified damping of the sway and yaw is 0.3 and 0.2 %. A
damping refit for that view (``references_held(lin, ('ARFVZ',))``) gave 2/10 with each reference
(seeds 0 and 1) but 1/10 with both, and was not kept.
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
        # 'component.interface': (translational N/m, rotational N m/rad, damping time s)
        "tank_left.tank_left_front": (3.97e9, 5.2e5, 6.14e-4),
        "tank_left.tank_left_rear": (7.1e9, 6.36e5, 2.89e-4),
        "tank_right.tank_right_front": (1.64e8, 1.65e5, 2.0e-4),
        "tank_right.tank_right_rear": (1.41e8, 1.16e6, 3.24e-4),
        "bracket_right.bracket_right": (9.75e7, 2.87e7, 0.0),
    },
    # the ~28 Hz rig resonance of Section 7.1 (drive -> ARFVZ peak at 27.9 Hz, 3.6 % damped)
    "drive_linkage": {"stiffness_n_per_m": 1.2e7, "damping_n_s_per_m": 4e3, "mass_kg": 20.0},
    # the left bracket's rubber pad: stiffer than the nominal rubber (G 1.7 -> 4.0 MPa; a bonded thin pad's
    # compression modulus +10 MPa) and lossy (stiffness-proportional damping time, zeta ~ tau omega / 2)
    "bushing_pad": {"shear_modulus_increase_pa": 2.3e6, "compression_modulus_increase_pa": 1.04e7,
                    "damping_time_s": 1.18e-3},
    # the pad moves ~0.07 mm rms at level 1 against a ~3.6e6 N/m tangent (see the single-effect
    # 'bushing_stiffening' scenario): 3 k3 sigma^2 is ~2 % of it; at level 4 ~30 %
    "bushing_cubic_n_per_m3": 5e12,
    # (body, factor, lowest and highest free-free body-mode frequency scaled, Hz) on thesis Table 6; the
    # left bracket's body modes at 170 and 200 Hz carry the pad's shear in its z and x rocking modes
    "modal_damping": (
        ("bracket_left", 0.1, 168.0, 172.0),
        ("bracket_left", 4.65, 195.0, 205.0),
        ("bracket_right", 0.948, 0.0, 1e5),
        ("frame", 0.202, 0.0, 1e5),
        ("tank_left", 1.01, 0.0, 1e5),
        ("tank_right", 1.0, 0.0, 1e5),
    ),
}

#: how the parameters were found and what they do not reach (see the module docstring)
THESIS_FIT = {
    "method": (
        "stiffnesses (tank mounts, pad moduli): least squares on the log frequencies of the linearised "
        "truth's undamped system modes with the EMA references held (references_held), modes tracked by MAC "
        "from a start where the tank and bracket modes were apart; damping: the damping ratios are linear in"
        " the damping times and modal damping factors to first order, so bounded linear least squares on the"
        " per-parameter sensitivities (unit damper at a time), targets corrected once by the "
        "identification's bias seen end to end, then the benchmark"
    ),
    "truth_modes_hz": {  # references held; Table-1 row <- (frequency Hz, damping ratio, shape)
        "12.05": (11.45, 0.0062, "tanks y sway (not z)"),
        "14.15": (13.79, 0.0119, "tanks z"),
        "(none)": (15.73, 0.0063, "tanks z with left bracket z: not identified"),
        "15.00": (16.42, 0.0202, "left bracket z"),
        "21.21": (20.8, 0.0016, "brackets and tanks x, frame yaw"),
        "(extra)": (25.77, 0.0027, "tanks x, frame x: not in Table 1"),
        "32.69": (30.18, 0.0502, "left bracket x"),
        "47.60": (47.64, 0.0044, "right bracket x (rotation about z)"),
    },
    "not_reached": (
        (
            "36.64 Hz left bracket x/z: the pad gives the bracket two modes below 100 Hz (z 16.4, x 30.2 Hz;"
            " the third is at 117 Hz); the pad's rocking stiffnesses about x and z come from one compression"
            " modulus and the pad's shape (0.20 x 0.08 m), so x at 32.7 Hz puts z at ~18 Hz, not 15 Hz: "
            "30.2/16.4 Hz is the compromise (both within 10 %)"
        ),
        (
            "41.37/43.84 Hz frame bending about y: the truth has no frame mode below 55 Hz with the "
            "references held; no catalogue entry lowers the frame's vertical bending (a compliant rear "
            "support, tried, moved the 56 Hz mode by 3 Hz only); the 43.9 Hz identified mode is not a mode "
            "of the truth"
        ),
        (
            "13.21 Hz both tanks z: the tanks have two z modes near Table 1's three (13.8 and 15.7 Hz); the "
            "sway y and the tank z modes share the mounts' rotational stiffness, so the sway cannot sit at "
            "12.05 Hz with both z modes at 13.2/14.2 Hz"
        ),
        (
            "damping of the tank sway (0.6 % vs 1.81 %), the frame yaw (0.16 % vs 1.19 %) and the second "
            "tank z mode (0.6 % vs 1.78 %): one damping time per joint damps translation and rotation alike,"
            " so raising them over-damps the first tank z mode; the frame's and the left bracket's 170 Hz "
            "band factors sit at their bounds (0.2, 0.1) to keep the tank and right-bracket modes light"
        ),
    ),
}


def thesis_augmentations(parameters: dict = THESIS_PARAMETERS) -> tuple[Augment, ...]:
    """Return the catalogue entries of the thesis truth (``parameters``: :data:`THESIS_PARAMETERS` layout)."""
    aug = [
        Augment(
            "joint_stiffness",
            key,
            {"stiffness_n_per_m": kt, "rotational_stiffness_n_m_per_rad": kr, "damping_time_s": t},
        )
        for key, (kt, kr, t) in parameters["joints"].items()
    ]
    aug.append(Augment("drive_linkage_compliance", None, dict(parameters["drive_linkage"])))
    if "bushing_pad" in parameters:
        aug.append(Augment("bushing_stiffness", "bracket_left", dict(parameters["bushing_pad"])))
    if parameters.get("bushing_cubic_n_per_m3", 0.0) > 0:
        aug.append(
            Augment(
                "bushing_stiffening",
                "bracket_left",
                {"cubic_stiffness_n_per_m3": parameters["bushing_cubic_n_per_m3"]},
            )
        )
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
    """Pair identified modes with Table 1 (one-to-one, least total log-frequency distance).

    A mode is paired with a Table-1 mode only within ``max_freq_error``; leaving a mode unpaired
    costs as much as a pair at that distance, so a mode Table 1 does not have (the truth's tank
    fore-aft mode, say) stays extra instead of shifting every pairing above it by one row.

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
    cap = float(np.log1p(max_freq_error))
    dist = np.abs(np.log(f[:, None] / ft[None, :])) if f.size else np.zeros((0, ft.size))
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
    "modes at 12-16 Hz, left and right differ), a compliant right mudguard bracket joint, the left "
    "bracket's rubber pad stiffer and lossier than the nominal rubber with a small cubic hardening "
    "(Section 7.4), a compliant drive linkage with its mass (the ~28 Hz rig resonance of Section 7.1, "
    "which the EMA does not see) and modal damping factors per body; EMA of its white-noise recording "
    "gives part of thesis Table 1 (see THESIS_FIT).",
    variant=3,
    damping="table6",
    augmentations=thesis_augmentations(),
)
