"""Fixtures shared by the rig-diagnosis tests."""

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


@pytest.fixture(scope="module")
def model3():
    """A builder of mini Model 3 (rigid joints, 2 % damping, the Model-3 sensors)."""
    pytest.importorskip("exudyn")
    from rig_fixtures import MODEL3_SENSORS, mini_model3_bodies

    from exudyn_study.bodies.damping import parse_damping
    from exudyn_study.model import build_model_from_bodies

    bodies = mini_model3_bodies()

    def build():
        return build_model_from_bodies(
            bodies, 3, damping=parse_damping("constant-2"), sensors=MODEL3_SENSORS, exudyn_mesh="used"
        )

    return build
