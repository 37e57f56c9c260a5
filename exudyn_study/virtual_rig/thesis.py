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
- the left mudguard bracket keeps its fixed joint: its rubber pad is inside the bracket body
  (linear at small strain) and ``bushing_stiffening`` adds the pad's cubic hardening, small at
  the white-noise level (Section 7.4: the rubber's nonlinearity shows with the stronger test
  signals);
- the drive linkage is compliant with its mass (``drive_linkage_compliance``): the ~28 Hz
  resonance between cylinder and frame of Section 7.1 (the drive -> ``ARFVZ`` FRF peaks at
  27.9 Hz). The EMA does not see it, as the thesis's did not: with the references at the
  frame's drive points (``ARFVZ``/``ARFHZ``) the transmissibilities have the modes of the
  chassis with those points held, which the linkage does not change;
- the joints' stiffness-proportional damping and the left bracket's modal damping (scaled in
  two bands of its body modes, ``modal_damping``) set the modal damping ratios; the other
  bodies keep thesis Table 6 (their modal damping hardly reaches the mounted modes).

The parameters were fitted (:data:`THESIS_FIT`) on the linearised truth's system modes: the
modes the vertical drive excites and the 36 response sensors see, paired with Table 1 by
frequency and shape class, then checked end to end (``benchmarks/bench_thesis_scenario.py``:
``virtual-test`` + ``identify``). What the catalogue cannot reach is listed in
:data:`THESIS_FIT` (``'not_reached'``).

Result (benchmark, seed 0, 120 s white noise, identify ``-r ARFVZ ARFHZ --band 3 50``): ten
modes, 11.64, 13.48, 14.79, 16.16, 20.69, 26.64, 37.33, 39.87, 43.89 and 47.66 Hz; nine Table-1
frequencies within 10 % (all but 32.69 Hz: -18.5 %), three also in damping (13.21, 14.15,
15.00 Hz). But 37.3 (MPC 0.00), 39.9 (MPC 0.25) and 43.9 Hz (MPC 0.73) are not modes of the
truth (neither free nor with the reference points held; they move with the seed): their
frequencies match Table 1, they are not the thesis's left-bracket and frame-bending modes.
Seven real modes: tank sway (y, not z) 11.6, left bracket z 13.5, left tank z 14.8, right tank
z 16.2, frame yaw 20.7, left bracket x 26.6, right bracket 47.7 Hz.
"""

from __future__ import annotations

import numpy as np

from .scenarios import THESIS_TABLE1, Augment, Scenario

__all__ = [
    "THESIS_SCENARIO",
    "THESIS_PARAMETERS",
    "THESIS_FIT",
    "EMA_REFERENCES",
    "thesis_augmentations",
    "compare_table1",
    "references_held",
]

#: the thesis's EMA references (Section 5.1): the frame side members at the linkage
EMA_REFERENCES = ("ARFVZ", "ARFHZ")

#: fitted parameters (SI): tank and bracket joints, drive linkage, bushing, per-body damping factors
THESIS_PARAMETERS = {
    "joints": {
        # 'component.interface': (translational N/m, rotational N m/rad, damping time s)
        "tank_left.tank_left_front": (3.97e9, 5.42e5, 1e-6),
        "tank_left.tank_left_rear": (8.25e9, 7.44e5, 2.74e-4),
        "tank_right.tank_right_front": (1.60e8, 1.70e5, 1e-6),
        "tank_right.tank_right_rear": (1.39e8, 1.79e6, 1.98e-3),
        "bracket_right.bracket_right": (9.75e7, 2.87e7, 1e-7),
    },
    # the ~28 Hz rig resonance of Section 7.1 (drive -> ARFVZ peak at 27.9 Hz, 3.6 % damped)
    "drive_linkage": {"stiffness_n_per_m": 1.2e7, "damping_n_s_per_m": 4e3, "mass_kg": 20.0},
    # the pad moves ~0.07 mm rms at level 1 against a ~3.6e6 N/m tangent (see the single-effect
    # 'bushing_stiffening' scenario): 3 k3 sigma^2 is ~2 % of it; at level 4 ~30 %
    "bushing_cubic_n_per_m3": 5e12,
    # (body, factor, lowest and highest free-free body-mode frequency scaled, Hz): the left
    # bracket's body modes at 170 and 200 Hz carry the rubber's shear in its z and x rocking modes
    "modal_damping": (("bracket_left", 3.13, 168.0, 172.0), ("bracket_left", 8.97, 195.0, 205.0)),
}

#: how the parameters were found and what they do not reach (see the module docstring)
THESIS_FIT = {
    "method": "stiffnesses: differential evolution + Nelder-Mead, then by hand, on the linearised truth's "
              "undamped system modes with the drive points clamped (what the EMA with references ARFVZ/ARFHZ "
              "sees), visible modes paired with Table 1 by frequency and shape class; damping: least squares "
              "on the modal damping ratios, targets corrected by the identification's bias seen end to end",
    "truth_modes_hz": {  # drive points clamped; (frequency Hz, damping ratio, shape) -> Table-1 row
        "12.05": (11.66, 0.0083, "tanks y sway (not z)"),
        "13.21": (13.47, 0.0119, "left bracket z"),
        "14.15": (14.71, 0.0207, "left tank z"),
        "15.00": (16.06, 0.0203, "right tank z"),
        "21.21": (20.72, 0.0043, "brackets x, frame yaw (frame bending about z)"),
        "32.69": (26.71, 0.0617, "left bracket x"),
        "47.60": (47.57, 0.0091, "right bracket x (rotation about z)"),
    },
    "not_reached": (
        "32.69/36.64 Hz left bracket x/z: the rubber pad is inside the bracket body; its x mode is 26.7 Hz "
        "with a fixed joint and the catalogue can only soften it (joint_stiffness replaces the fixed joint, "
        "bushing_stiffening is cubic only); a linear stiffness or modulus scale of the pad is missing",
        "41.37/43.84 Hz frame bending about y: the truth's frame+tanks z bending is at 50.8 Hz (54.0 Hz with "
        "fixed joints) and compliant tank mounts raise it; no catalogue entry lowers it except added mass",
        "15.00 Hz left bracket z: at most 13.47 Hz with the fixed joint (same missing pad stiffness)",
        "damping of the sway (12 Hz), frame yaw (21 Hz) and right bracket (47.6 Hz) modes: the joint "
        "damping that gives the tank modes 1.8-2.2 % also damps the right bracket (0.9 % vs 0.53 %); frame "
        "modal damping hardly reaches these mounted modes",
    ),
}


def thesis_augmentations(parameters: dict = THESIS_PARAMETERS) -> tuple[Augment, ...]:
    """Return the catalogue entries of the thesis truth for ``parameters`` (:data:`THESIS_PARAMETERS` layout)."""
    aug = [
        Augment(
            "joint_stiffness",
            key,
            {"stiffness_n_per_m": kt, "rotational_stiffness_n_m_per_rad": kr, "damping_time_s": t},
        )
        for key, (kt, kr, t) in parameters["joints"].items()
    ]
    aug.append(Augment("drive_linkage_compliance", None, dict(parameters["drive_linkage"])))
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

    from ..errors import InputError

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


def compare_table1(frequency_hz, damping_ratio, table=THESIS_TABLE1) -> list[dict]:
    """Pair identified modes with Table 1 (one-to-one, least total log-frequency distance).

    Parameters
    ----------
    frequency_hz, damping_ratio : array_like, shape (n_modes,)
        Identified natural frequencies (Hz) and damping ratios (1).
    table : sequence of (frequency Hz, damping ratio, description)

    Returns
    -------
    list of dict
        One per Table-1 mode, in table order: ``table_hz``, ``table_zeta``, ``description``,
        ``index`` (identified mode, or None when none is left), ``frequency_hz``, ``damping_ratio``,
        ``freq_error`` and ``zeta_error`` (relative, signed), ``within_10pct`` (both errors).
        Identified modes left over are in the last entry's ``extra`` list (indices).
    """
    from scipy.optimize import linear_sum_assignment

    f = np.atleast_1d(np.asarray(frequency_hz, dtype=float))
    z = np.atleast_1d(np.asarray(damping_ratio, dtype=float))
    ft = np.array([row[0] for row in table], dtype=float)
    cost = np.abs(np.log(f[:, None] / ft[None, :])) if f.size else np.zeros((0, ft.size))
    rows, cols = linear_sum_assignment(cost) if f.size else (np.array([], int), np.array([], int))
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
    "bracket's rubber pad with a small cubic hardening (Section 7.4), a compliant drive linkage with "
    "its mass (the ~28 Hz rig resonance of Section 7.1, which the EMA does not see) and banded modal "
    "damping of the left bracket; EMA of its white-noise recording gives part of thesis Table 1 (see THESIS_FIT).",
    variant=3,
    damping="table6",
    augmentations=thesis_augmentations(),
)
