"""Figures of an identification: what they show is what they say (no FE, synthetic modes)."""

from __future__ import annotations

import numpy as np

from exudyn_study.identify.model import ModalModel, Mode
from exudyn_study.identify.plots import _real_shape, _sensor_nodes, _wire_frame, plot_mac, plot_mode_shapes


def test_channels_at_one_point_share_a_node_and_the_wire_frame_joins_every_node():
    positions = {"AX": (0, 0, 0), "AZ": (0, 0, 0), "B": (1, 0, 0), "C": (1, 1, 0), "D": (3, 1, 0)}
    directions = {"AX": "X", "AZ": "Z", "B": "Z", "C": "Z", "D": "Z"}
    nodes, node_of, dirs = _sensor_nodes(list(positions), positions, directions)
    assert len(nodes) == 4 and node_of[0] == node_of[1]
    edges = _wire_frame(nodes)
    assert len(edges) == len(nodes) - 1  # a spanning tree: connected, no loop
    assert {tuple(sorted(e)) for e in edges} == {(0, 1), (1, 2), (2, 3)}  # the nearest neighbours


def test_a_complex_shape_of_one_phase_becomes_its_real_shape_with_largest_entry_one():
    real = np.array([0.5, -1.0, 0.25])
    r = _real_shape(real * np.exp(1j * 0.7) * 3.0)
    assert np.allclose(np.abs(r), np.abs(real)) and np.isclose(np.abs(r).max(), 1.0)


def test_mode_shape_and_mac_figures_are_written(tmp_path):
    positions = {f"S{i}": (float(i), 0.0, 0.0) for i in range(5)}
    directions = dict.fromkeys(positions, "Z")
    shape = {n: complex(np.sin(0.5 * i)) for i, n in enumerate(positions)}
    model = ModalModel((Mode(10.0, 0.02, shape=shape), Mode(20.0, 0.01, shape=shape)), {})
    assert plot_mode_shapes(model, positions, directions, tmp_path / "shapes.png").stat().st_size > 0
    assert plot_mac(np.eye(2), tmp_path / "mac.png", row_title="mode frequency [Hz]").stat().st_size > 0
