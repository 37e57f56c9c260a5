"""The ``thesis`` scenario (issue #7): its description validates, the Table-1 pairing is right,
and (slow, real Model 3 bodies from the cache) the linearised truth has its modes where the fit
put them.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from exudyn_study.errors import InputError
from exudyn_study.virtual_rig import SCENARIOS
from exudyn_study.virtual_rig.scenario import THESIS_TABLE1
from exudyn_study.virtual_rig.thesis import (
    THESIS_PARAMETERS,
    THESIS_SCENARIO,
    compare_table1,
    thesis_augmentations,
)

TABLE_HZ = np.array([row[0] for row in THESIS_TABLE1])
TABLE_ZETA = np.array([row[1] for row in THESIS_TABLE1])


def test_registered_and_valid():
    assert SCENARIOS["thesis"] is THESIS_SCENARIO
    assert THESIS_SCENARIO.variant == 3
    THESIS_SCENARIO.validate()  # every entry and parameter within its bounds


def test_augmentations_follow_the_parameters():
    aug = thesis_augmentations(THESIS_PARAMETERS)
    joints = [a.location for a in aug if a.physics == "joint_stiffness"]
    assert sorted(joints) == sorted(THESIS_PARAMETERS["joints"])
    assert "bracket_left.bracket_left" not in joints  # the rubber bracket keeps its fixed joint
    assert sum(a.physics == "drive_linkage_compliance" for a in aug) == 1
    rear = sorted(a.location for a in aug if a.physics == "rear_support_compliance")
    assert rear == ["rear_left", "rear_right"]
    rotational = {a.location: a.parameters.get("rotational_damping_factor") for a in aug
                  if a.physics == "joint_stiffness"}
    assert rotational["tank_right.tank_right_front"] == 39.5  # the tank mount damps in rocking
    assert aug == THESIS_SCENARIO.augmentations


def test_a_parameter_out_of_bounds_is_named():
    bad = dict(THESIS_PARAMETERS, drive_linkage=dict(THESIS_PARAMETERS["drive_linkage"], mass_kg=-1.0))
    sc = dataclasses.replace(THESIS_SCENARIO, augmentations=thesis_augmentations(bad))
    with pytest.raises(InputError, match="mass_kg"):
        sc.validate()


def test_table1_pairs_with_itself_exactly():
    rows = compare_table1(TABLE_HZ, TABLE_ZETA)
    assert [r["index"] for r in rows] == list(range(10))
    assert all(r["within_10pct"] and r["freq_error"] == 0.0 for r in rows)
    assert rows[-1]["extra"] == []


def test_pairing_is_one_to_one_and_reports_extra_and_missing():
    rng = np.random.default_rng(0)
    order = rng.permutation(10)
    f = TABLE_HZ[order] * 1.05            # 5 % high, shuffled
    z = TABLE_ZETA[order] * 0.8           # 20 % low: frequency fine, damping not
    f = np.append(f, 28.0)                # a rig mode Table 1 does not have
    z = np.append(z, 0.08)
    rows = compare_table1(f, z)
    for k, r in enumerate(rows):
        assert order[r["index"]] == k
        assert r["freq_error"] == pytest.approx(0.05)
        assert r["zeta_error"] == pytest.approx(-0.2)
        assert not r["within_10pct"]
    assert rows[-1]["extra"] == [10]
    rows = compare_table1(TABLE_HZ[:7], TABLE_ZETA[:7])  # three modes not identified
    assert [r["index"] for r in rows[7:]] == [None, None, None]
    assert sum(r["within_10pct"] for r in rows) == 7


@pytest.mark.slow
def test_linearised_truth_modes_where_the_fit_put_them():
    """Real Model 3 bodies (cache): the system modes of the fitted truth.

    Regression values of the fitted truth (docs/thesis-truth.md; exudyn_study.model.system_modes, 0-60 Hz),
    with 2 % on frequency. Free (drive held): the tank sway at 11.7 Hz, the tank/bracket
    cluster at 12.8-15.7 Hz (Model 3 with fixed joints: tanks at 22 and 26 Hz), the wall mode at
    18.5 Hz (22 %), the frame yaw at 21.0 Hz, the linkage resonance mixed with the tanks' fore-aft
    mode at 27.1 and 27.3 Hz (Section 7.1), the left bracket x on its stiffened pad at 32.8 Hz (26.6
    Hz on the nominal rubber), the left bracket turning about y on the pad's soft torsion at 36.8 Hz
    and the right bracket at 47.4 Hz; the water's overdamped slosh modes at 2.5 Hz. With one EMA
    reference held (what the transmissibilities see: the two references move together): no linkage
    mode (the tanks' fore-aft mode alone at 27.2 Hz), the sway damped by the water (1.47 %), the
    tanks' lateral mode by the wall mode (1.51 %), the left bracket's z, x and y-turning modes at
    15.0, 32.8 and 36.8 Hz (1.45, 5.42 and 3.24 %) and the frame bouncing on its rear supports with the
    right tank at 41.3 and 44.7 Hz (1.24 and 1.94 %).
    """
    from exudyn_study.model.linearisation import linearise, system_modes
    from exudyn_study.virtual_rig.run import build_truth
    from exudyn_study.virtual_rig.thesis import references_held

    model, applied = build_truth(THESIS_SCENARIO)
    assert len(applied) == len(THESIS_SCENARIO.augmentations)
    model.assemble()
    lin = linearise(model)
    modes = system_modes(model, lin, max_frequency_hz=60.0)
    f = modes.frequency_hz
    for expected in (11.71, 12.84, 14.94, 15.68, 18.47, 20.96, 27.10, 27.31, 32.76, 36.78, 47.39):
        assert np.min(np.abs(f / expected - 1.0)) < 0.02, (expected, np.round(f, 2))
    tank_z = [fj for fj, d in zip(f, modes.descriptions, strict=True) if d.startswith("tank") and " z" in d
              and fj > 5.0]
    assert tank_z and 12.0 < min(tank_z) < 17.0
    assert np.all(modes.damping_ratio > 0)

    held = system_modes(model, references_held(lin, ("ARFVZ",)), max_frequency_hz=50.0)
    # the linkage mode is not seen: one mode near 27 Hz (the tanks' fore-aft), not two
    assert np.sum(np.abs(held.frequency_hz / 27.2 - 1.0) < 0.02) == 1
    for f_hz, zeta, what in ((11.71, 0.0147, "tank"), (14.96, 0.0145, "bracket left"),
                             (15.68, 0.0151, "tank"), (32.75, 0.0542, "bracket left"),
                             (36.78, 0.0324, "bracket left"), (41.31, 0.0124, "frame z"),
                             (44.66, 0.0194, "frame z")):
        j = int(np.argmin(np.abs(held.frequency_hz - f_hz)))
        assert held.frequency_hz[j] == pytest.approx(f_hz, rel=0.02)
        assert held.damping_ratio[j] == pytest.approx(zeta, rel=0.1)
        assert what in held.descriptions[j], held.descriptions[j]


def test_average_identifications_keeps_the_modes_both_references_found():
    from exudyn_study.virtual_rig.thesis import average_identifications

    a = [{"frequency_hz": 13.0, "damping_ratio": 0.010, "mpc": 0.9},
         {"frequency_hz": 20.0, "damping_ratio": 0.020, "mpc": 0.8},
         {"frequency_hz": 37.0, "damping_ratio": 0.012, "mpc": 0.1}]   # only in the first run
    b = [{"frequency_hz": 20.1, "damping_ratio": 0.030, "mpc": 0.6},     # 0.5 % apart: the same mode
         {"frequency_hz": 13.05, "damping_ratio": 0.012, "mpc": 1.0},
         {"frequency_hz": 44.0, "damping_ratio": 0.02}]                  # only in the second run
    avg = average_identifications([a, b])
    assert [m["frequency_hz"] for m in avg] == pytest.approx([13.025, 20.05])
    assert [m["damping_ratio"] for m in avg] == pytest.approx([0.011, 0.025])
    assert [m["mpc"] for m in avg] == pytest.approx([0.95, 0.7])
    assert average_identifications([a]) == [dict(m) for m in a]
    assert average_identifications([a, b], rtol=0.001) == []
    with pytest.raises(InputError, match="no identification"):
        average_identifications([])


def test_pairing_keeps_the_frequency_order_when_two_modes_lie_above_two_rows():
    """15.24 and 15.79 Hz against the rows 14.15 and 15.00 Hz: the plain log distances of both pairings
    are equal (ln 15.24 + ln 15.79 - ln 14.15 - ln 15.00); the squared ones pair in order."""
    for f in ([15.24, 15.79], [15.79, 15.24]):
        rows = compare_table1(f, [0.01, 0.02])
        assert [f[rows[2]["index"]], f[rows[3]["index"]]] == [15.24, 15.79]
    plain = [abs(np.log(a / b)) for a, b in ((15.24, 14.15), (15.79, 15.00), (15.79, 14.15), (15.24, 15.00))]
    assert plain[0] + plain[1] == pytest.approx(plain[2] + plain[3], rel=1e-12)


def test_a_mode_table1_lacks_stays_extra_instead_of_shifting_the_pairs():
    """Table 1 at +3 % plus a mode at 25.8 Hz (between rows 21.21 and 32.69): without the cap on the
    frequency error the extra mode would take the 32.69 row and push the rest up by one."""
    f = np.sort(np.append(TABLE_HZ * 1.03, 25.8))
    z = np.full(f.size, 0.02)
    rows = compare_table1(f, z)
    assert all(r["freq_error"] == pytest.approx(0.03) for r in rows)
    assert [f[i] for i in rows[-1]["extra"]] == [25.8]
    far = compare_table1([5.0, 13.0], [0.01, 0.01])  # 5 Hz is 58 % below the lowest row: no pair
    assert [r["index"] for r in far] == [None, 1] + [None] * 8 and far[-1]["extra"] == [0]
    with pytest.raises(InputError, match="max_freq_error"):
        compare_table1(TABLE_HZ, TABLE_ZETA, max_freq_error=0.0)


def test_the_truth_has_the_water_and_the_fore_aft_support_and_the_dry_one_has_not():
    """``thesis`` and ``thesis-iso``: the dry truth's entries plus the water's slosh dampers on both tanks
    (lateral factor below 1) and a longitudinal compliance at both rear supports; ``thesis-dry`` has
    neither; all within their entries' bounds."""
    from exudyn_study.virtual_rig.thesis import (
        THESIS_DRY_PARAMETERS,
        THESIS_DRY_SCENARIO,
        THESIS_ISO_PARAMETERS,
        THESIS_ISO_SCENARIO,
    )

    assert SCENARIOS["thesis-dry"] is THESIS_DRY_SCENARIO
    assert SCENARIOS["thesis-iso"] is THESIS_ISO_SCENARIO
    THESIS_DRY_SCENARIO.validate()
    THESIS_ISO_SCENARIO.validate()
    assert THESIS_DRY_SCENARIO.augmentations == thesis_augmentations(THESIS_DRY_PARAMETERS)
    assert THESIS_ISO_SCENARIO.augmentations == thesis_augmentations(THESIS_ISO_PARAMETERS)
    for aug in (THESIS_SCENARIO.augmentations, THESIS_ISO_SCENARIO.augmentations):
        slosh = {a.location: a.parameters for a in aug if a.physics == "sloshing"}
        assert sorted(slosh) == ["tank_left", "tank_right"]
        assert all(0 < p["lateral_damping_factor"] < 1 for p in slosh.values())
        rear = [a.parameters for a in aug if a.physics == "rear_support_compliance"]
        assert len(rear) == 2 and all(p["longitudinal_compliance_m_per_n"] > 0 for p in rear)
    assert not any(a.physics == "sloshing" for a in THESIS_DRY_SCENARIO.augmentations)
    dry_rear = [a.parameters for a in THESIS_DRY_SCENARIO.augmentations
                if a.physics == "rear_support_compliance"]
    assert all(p["longitudinal_compliance_m_per_n"] == 0 for p in dry_rear)


def test_the_truth_is_the_iso_truth_with_vertically_soft_right_mounts_and_the_wall_mode():
    """``thesis``: the right tank's mounts soft only vertically (the entry's per-axis factor), the right
    tank's wall mode, and otherwise the ``thesis-iso`` truth's entries (pad, cubic, linkage, water)."""
    from exudyn_study.virtual_rig.thesis import THESIS_ISO_SCENARIO

    aug = THESIS_SCENARIO.augmentations
    joints = {a.location: a.parameters for a in aug if a.physics == "joint_stiffness"}
    for mount in ("tank_right.tank_right_front", "tank_right.tank_right_rear"):
        vertical = joints[mount]["stiffness_n_per_m"] * joints[mount]["stiffness_factor_z"]
        assert 1e7 < vertical < 5e7 < joints[mount]["stiffness_n_per_m"]
    assert not any("stiffness_factor_z" in joints[m] for m in joints if not m.startswith("tank_right"))
    walls = [a for a in aug if a.physics == "tank_wall_mode"]
    assert [a.location for a in walls] == ["tank_right"]
    same = ("bushing_stiffness", "bushing_stiffening", "drive_linkage_compliance")
    iso = THESIS_ISO_SCENARIO.augmentations
    assert [a for a in aug if a.physics in same] == [a for a in iso if a.physics in same]
    assert not any(a.physics == "tank_wall_mode" for a in iso)
    assert not any("stiffness_factor_z" in a.parameters for a in iso)


@pytest.mark.slow
def test_the_wall_mode_damps_the_tanks_lateral_mode_and_not_the_right_bracket():
    """Real Model 3 bodies (cache), one EMA reference held: the truth has two frame modes about y
    in 40-46 Hz (Table 1: 41.37 and 43.84 Hz) and, against the same truth without the wall mode, the tanks'
    lateral mode near 15.7 Hz gains damping (0.70 -> 1.51 % measured), more than three times what the sway
    gains (1.22 -> 1.47 %: it moves the tanks across too, but farther below the wall's tuning), while the left
    bracket's z mode, the frame bouncing at 44.6 Hz and the right bracket's mode keep theirs (+0.01-0.02
    points measured)."""
    from exudyn_study.model.linearisation import linearise, system_modes
    from exudyn_study.virtual_rig.run import build_truth
    from exudyn_study.virtual_rig.thesis import references_held

    def held_modes(sc):
        model, _ = build_truth(sc)
        model.assemble()
        return system_modes(model, references_held(linearise(model), ("ARFVZ",)), max_frequency_hz=50.0)

    with_wall = held_modes(THESIS_SCENARIO)
    without = held_modes(dataclasses.replace(THESIS_SCENARIO, augmentations=tuple(
        a for a in THESIS_SCENARIO.augmentations if a.physics != "tank_wall_mode")))
    light = with_wall.damping_ratio < 0.1  # (the wall's own mode: 18.5 Hz, 22 %)
    f1, z1 = with_wall.frequency_hz[light], with_wall.damping_ratio[light]
    f0, z0 = without.frequency_hz, without.damping_ratio
    assert np.sum((f1 > 40.0) & (f1 < 46.0)) == 2

    def gain(f_hz):
        i, j = int(np.argmin(np.abs(f1 - f_hz))), int(np.argmin(np.abs(f0 - f_hz)))
        assert abs(f1[i] / f_hz - 1.0) < 0.02 and abs(f0[j] / f_hz - 1.0) < 0.02
        return z1[i] - z0[j]

    lateral, sway = gain(15.7), gain(11.7)
    assert lateral > 0.006 and lateral > 3.0 * sway > 0.0
    for f_hz in (14.96, 44.6, 47.4):
        assert abs(gain(f_hz)) < 0.0005, f_hz
