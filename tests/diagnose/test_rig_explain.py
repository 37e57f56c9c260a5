"""The explain stage of the rig diagnosis: what is left unexplained, precisely."""

from __future__ import annotations

import numpy as np

from exudyn_study.diagnose.rig_compare import BANDS_HZ, SignificanceMap
from exudyn_study.diagnose.rig_explain import residual_carriers, unexplained_entry

CHANNELS = tuple(f"S{i}" for i in range(6))


def _map(effect):
    effect = np.asarray(effect, dtype=float)
    sig = effect > 0.01
    return SignificanceMap(CHANNELS, BANDS_HZ, np.where(sig, 10.0, 0.0), effect, sig, 40, 4.0)


def test_the_smallest_set_of_sensors_and_the_band_that_carry_the_residual():
    """Two channels carry almost all of the coherent residual in two adjacent bands; four others are
    barely significant across the band. The carriers are those two channels and those two bands, though
    all six are significant over the whole band."""
    n_b = len(BANDS_HZ)
    effect = np.full((6, n_b), 0.02)
    effect[2, 3] = effect[4, 3] = 0.5
    effect[2, 4] = effect[4, 4] = 0.3
    m = _map(effect)
    rows, (j0, j1) = residual_carriers(m.significant, [m])
    assert sorted(rows) == [2, 4] and (j0, j1) == (3, 4)
    u = unexplained_entry(m.significant, CHANNELS, False, "nothing fits", [m], [("added_mass@S2", 0.42)])
    assert sorted(u["location"]["sensors"]) == ["S2", "S4"]
    assert u["band_hz"] == [BANDS_HZ[3][0], BANDS_HZ[4][1]]
    assert u["all_sensors"] == list(CHANNELS)
    assert u["best_places"] == [{"candidate": "added_mass@S2", "share": 0.42}]
    assert "added_mass@S2 (42 % of the residual)" in u["explanation"]
    # a second recording whose residual sits elsewhere takes its share: the larger of the two per cell
    effect2 = np.zeros((6, n_b))
    effect2[0, 0] = 2.0
    rows2, (j0, j1) = residual_carriers(m.significant | _map(effect2).significant, [m, _map(effect2)])
    assert rows2 == [0] and (j0, j1) == (0, 0)
