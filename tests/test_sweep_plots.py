"""Sweep figures: panels and bars in the configuration's order, lines that can be told apart."""

from __future__ import annotations

from exudyn_study.sweep.config import parse_config
from exudyn_study.sweep.plots import _config_order, _line_styles


def _config():
    return parse_config({"study": {"name": "s", "task": "damping_sensitivity"},
                         "parameters": {"signal": {"values": ["white-noise", "test", "test-50"]},
                                        "damping": {"values": ["step", "adams-default"]}}})


def test_combinations_sort_in_the_order_the_configuration_lists_them():
    cfg = _config()
    combos = [("test-50", "step"), ("white-noise", "adams-default"), ("test", "step"),
              ("white-noise", "step")]
    ordered = sorted(combos, key=lambda c: _config_order(cfg, ["signal", "damping"], c))
    assert ordered == [("white-noise", "step"), ("white-noise", "adams-default"), ("test", "step"),
                       ("test-50", "step")]


def test_values_outside_the_grid_sort_last_and_by_their_text():
    cfg = _config()
    ordered = sorted(["zz", "test", "aa"], key=lambda v: _config_order(cfg, ["signal"], [v]))
    assert ordered == ["test", "aa", "zz"]


def test_thirty_family_members_get_thirty_different_styles():
    styles = _line_styles(30)
    assert len(set(styles)) == 30
