"""``Recording.from_arrays`` with a force drive: the documented shaker-test recording."""

import numpy as np
import pytest

from exudyn_study.errors import InputError
from exudyn_study.recording import Recording


def test_force_drive_with_its_drive_point():
    acc = np.zeros((2, 16))
    rec = Recording.from_arrays(
        acc,
        400.0,
        ["DP", "B"],
        positions_m=[(0.1, 0, 0), (0.5, 0, 0)],
        drive=np.ones(16),
        drive_quantity="force",
        drive_name="force",
        drive_position_m=(0.1, 0, 0),
    )
    assert rec.drive.quantity == "force" and rec.drive.unit == "N" and rec.drive.role == "drive"
    assert rec.drive.position_m == rec.channel("DP").position_m
    # the default stays a table displacement
    assert Recording.from_arrays(acc, 400.0, ["DP", "B"], drive=np.ones(16)).drive.unit == "m"


def test_unknown_drive_quantity_is_refused():
    with pytest.raises(InputError, match="quantity 'pressure' is unknown"):
        Recording.from_arrays(np.zeros((1, 4)), 400.0, ["A"], drive=np.ones(4), drive_quantity="pressure")
