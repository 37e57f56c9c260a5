"""The 42 accelerometers of the test rig (thesis Appendix A, Table 8) as data.

Each :class:`Sensor` carries the table's number, name, sensitivity, positive
measuring direction, description and position, converted to SI at this edge:
sensitivity from mV/(m/s^2) to V/(m/s^2), position from mm to m. Positions are in the
thesis's *local* rig coordinates (origin and axes of thesis Fig. 5); the global
Scania truck coordinates are ``X_global = X_local + 3.2 m``, ``Y_global = Y_local``,
``Z_global = Z_local + 1.0 m`` (:attr:`Sensor.position_global_m`).

Components with a negative y coordinate are on the *left*, positive y on the *right*
(thesis Section 3.3). 21 of the 42 sensors measure in z; ``ARFVZ`` and ``ARFHZ`` (frame
front attachments, at the linkage) are the reference and drive-iteration control
sensors (thesis Sections 5.1 and 7.1).

Examples
--------
>>> from exudyn_study.model.sensors import sensor, z_sensors
>>> sensor("ARFVZ").position_m
(-0.315, -0.455, 0.19)
>>> len(z_sensors())
21
"""

from __future__ import annotations

import difflib
import math
from dataclasses import dataclass

from exudyn_study.errors import InputError

__all__ = [
    "Sensor",
    "SENSORS",
    "REFERENCES",
    "COMPONENTS",
    "ALIASES",
    "sensor",
    "z_sensors",
    "sensors_on",
]

#: components a sensor can sit on (the separate flexible bodies of Model 3)
COMPONENTS = ("frame", "tank_left", "tank_right", "bracket_left", "bracket_right")

#: reference / drive-iteration control sensors (thesis Sections 5.1, 7.1)
REFERENCES = ("ARFVZ", "ARFHZ")

#: names used in the thesis text for sensors whose Table 8 name differs
ALIASES = {
    # Table 8 names sensor 40 'ATVFXZ' although it measures Z; the text (Section 7.3.1)
    # calls it 'ATVFZ', and Section 7.3.3 writes 'AVTFZ'/'AHTFZ' for ATVFXZ/ATHFZ.
    "ATVFZ": "ATVFXZ",
    "AVTFZ": "ATVFXZ",
    "AHTFZ": "ATHFZ",
}

_MM = 1e-3  # m per mm
_MV = 1e-3  # V per mV


@dataclass(frozen=True)
class Sensor:
    """One accelerometer of the rig.

    Parameters
    ----------
    number : int
        Channel number in thesis Table 8 (1-42).
    name : str
        Sensor name, e.g. ``'ARFVZ'``.
    sensitivity : float
        Sensitivity in V/(m/s^2) (Table 8 gives mV/(m/s^2)).
    direction : {'X', 'Y', 'Z'}
        Positive measuring direction, local rig coordinates.
    description : str
        Table 8 description, e.g. ``'Frame front left attachment'``.
    position_m : tuple of 3 float
        Position in m, local rig coordinates.
    component : {'frame', 'tank_left', 'tank_right', 'bracket_left', 'bracket_right'}
        The component the sensor is glued to.

    Raises
    ------
    InputError
        On a direction, component or sensitivity out of range.
    """

    number: int
    name: str
    sensitivity: float
    direction: str
    description: str
    position_m: tuple[float, float, float]
    component: str

    def __post_init__(self) -> None:
        if self.direction not in ("X", "Y", "Z"):
            raise InputError(
                f"sensor {self.name!r}: direction {self.direction!r}; expected 'X', 'Y' or 'Z'"
            )
        if self.component not in COMPONENTS:
            raise InputError(
                f"sensor {self.name!r}: component {self.component!r}; expected one of "
                f"{', '.join(COMPONENTS)}"
            )
        if not (math.isfinite(self.sensitivity) and self.sensitivity > 0):
            raise InputError(
                f"sensor {self.name!r}: sensitivity {self.sensitivity!r}; expected > 0 V/(m/s^2)"
            )
        if len(self.position_m) != 3:
            raise InputError(f"sensor {self.name!r}: position_m needs 3 coordinates in m")

    @property
    def side(self) -> str:
        """'left' (y < 0), 'right' (y > 0) or 'center' (|y| < 15 mm), thesis Section 3.3."""
        y = self.position_m[1]
        if abs(y) < 0.015:
            return "center"
        return "left" if y < 0 else "right"

    @property
    def position_global_m(self) -> tuple[float, float, float]:
        """Position in m in the global truck coordinates (Appendix A transformation)."""
        x, y, z = self.position_m
        return (x + 3.2, y, z + 1.0)


def _component(name: str, description: str, y_m: float) -> str:
    """Infer the component from the Table 8 description (and check it against y).

    'Frame ...' (sensors on the side members near a tank or bracket), crossmembers
    and attachments are on the frame; 'Left/Right fuel tank ...' (ATV*/ATH*) on the
    tanks; 'Left/Right mudguard bracket' (ASV*, rubber-bushed; ASH*) on the brackets.
    """
    d = description.lower()
    if d.startswith("frame") or "crossmember" in d or "attachment" in d:
        return "frame"
    for key, part in (("fuel tank", "tank"), ("mudguard bracket", "bracket")):
        if key in d:
            side = "left" if d.startswith("left") else "right" if d.startswith("right") else ""
            expected = "left" if y_m < 0 else "right"
            if side != expected:  # the table is self-consistent; guard edits of it
                raise InputError(
                    f"sensor {name!r}: description {description!r} says {side or 'no side'} "
                    f"but y = {y_m} m says {expected}"
                )
            return f"{part}_{side}"
    raise InputError(f"sensor {name!r}: cannot infer a component from {description!r}")


# Thesis Appendix A, Table 8, verbatim: number, name, sensitivity in mV/(m/s^2),
# positive direction, description, position in mm (local coordinates).
_TABLE_8 = (
    (1, "ARFMZ", 6.741, "Z", "Frame front center", (-530, -5, 315)),
    (2, "ARFVX", 6.804, "X", "Frame front left attachment", (-300, -455, 170)),
    (3, "ARFVY", 6.873, "Y", "Frame front left attachment", (-315, -475, 170)),
    (4, "ARFVZ", 6.764, "Z", "Frame front left attachment", (-315, -455, 190)),
    (5, "ARFHX", 6.337, "X", "Frame front right attachment", (-300, 455, 150)),
    (6, "ARFHY", 6.584, "Y", "Frame front right attachment", (-315, 475, 150)),
    (7, "ARFHZ", 6.509, "Z", "Frame front right attachment", (-315, 455, 170)),
    (8, "AVBFZ", 6.411, "Z", "First crossmember center", (125, 0, 270)),
    (9, "ARVTFZ", 6.716, "Z", "Frame left front fuel tank", (450, -425, 245)),
    (10, "ARVTBZ", 6.215, "Z", "Frame left rear fuel tank", (935, -400, 245)),
    (11, "ARHTFXH", 6.496, "X", "Frame right front fuel tank high", (465, 420, 215)),
    (12, "ARHTFYH", 6.224, "Y", "Frame right front fuel tank high", (445, 440, 215)),
    (13, "ARHTFZH", 6.453, "Z", "Frame right front fuel tank high", (445, 420, 235)),
    (14, "ARHTFXL", 6.319, "X", "Frame right front fuel tank low", (475, 420, 55)),
    (15, "ARHTFYL", 6.152, "Y", "Frame right front fuel tank low", (455, 440, 55)),
    (16, "ARHTFZL", 6.841, "Z", "Frame right front fuel tank low", (455, 420, 75)),
    (17, "ARHTBZ", 6.839, "Z", "Frame right rear fuel tank", (955, 395, 240)),
    (18, "ATBGZ", 6.851, "Z", "Third crossmember center", (1475, -10, 300)),
    (19, "ARVBX", 6.855, "X", "Rear attachment left", (2490, -535, 210)),
    (20, "ARVBY", 6.659, "Y", "Rear attachment left", (2470, -555, 210)),
    (21, "ARVBZ", 6.252, "Z", "Rear attachment left", (2470, -535, 230)),
    (22, "ARHBX", 6.697, "X", "Rear attachment right", (2500, 535, 210)),
    (23, "ARHBY", 6.312, "Y", "Rear attachment right", (2480, 555, 210)),
    (24, "ARHBZ", 6.625, "Z", "Rear attachment right", (2480, 535, 230)),
    (25, "ATBPX", 6.381, "X", "Second crossmember center", (855, 0, 260)),
    (26, "ATBPZ", 6.453, "Z", "Second crossmember center", (875, 0, 280)),
    (27, "ATHFX", 6.45, "X", "Right fuel tank front", (225, 835, 285)),
    (28, "ATHBX", 6.23, "X", "Right fuel tank rear", (1030, 835, 285)),
    (29, "ATHBZ", 6.336, "Z", "Right fuel tank rear", (1050, 835, 305)),
    (30, "ATVBX", 6.288, "X", "Left fuel tank rear", (1050, -825, 285)),
    (31, "ATVBZ", 6.247, "Z", "Left fuel tank rear", (1070, -825, 305)),
    (32, "ATVFX", 6.247, "X", "Left fuel tank front", (250, -815, 285)),
    (33, "ARSVZ", 6.522, "Z", "Frame left mudguard bracket", (-150, -450, 230)),
    (34, "ASHX", 6.326, "X", "Right mudguard bracket", (-115, 1155, 95)),
    (35, "ASHY", 6.764, "Y", "Right mudguard bracket", (-95, 1175, 95)),
    (36, "ASHZ", 6.608, "Z", "Right mudguard bracket", (-95, 1155, 115)),
    (37, "ASVX", 6.596, "X", "Left mudguard bracket", (-130, -1148, 105)),
    (38, "ASVY", 6.543, "Y", "Left mudguard bracket", (-110, -1128, 105)),
    (39, "ASVZ", 6.293, "Z", "Left mudguard bracket", (-110, -1148, 125)),
    # Table 8 names sensor 40 'ATVFXZ' though its direction is Z (the text calls it
    # 'ATVFZ'); we keep the table's name and resolve the text's spelling via ALIASES.
    (40, "ATVFXZ", 6.564, "Z", "Left fuel tank front", (230, -815, 305)),
    (41, "ATHFZ", 6.951, "Z", "Right fuel tank front", (205, 835, 305)),
    (42, "ARSHZ", 6.465, "Z", "Frame right mudguard bracket", (0, 435, 130)),
)


def _build() -> tuple[Sensor, ...]:
    out = []
    for number, name, sens_mv, direction, description, pos_mm in _TABLE_8:
        pos_m = tuple(v * _MM for v in pos_mm)
        out.append(
            Sensor(
                number=number,
                name=name,
                sensitivity=sens_mv * _MV,
                direction=direction,
                description=description,
                position_m=pos_m,
                component=_component(name, description, pos_m[1]),
            )
        )
    return tuple(out)


#: the 42 sensors in Table 8 order
SENSORS: tuple[Sensor, ...] = _build()
_BY_NAME = {s.name: s for s in SENSORS}


def sensor(name: str) -> Sensor:
    """Return the sensor called ``name`` (Table 8 name, or a text spelling in ALIASES).

    Parameters
    ----------
    name : str
        Sensor name as in the thesis's Table 8 (e.g. 'ARFVZ') or an alias from :data:`ALIASES`.

    Returns
    -------
    Sensor
        Its Appendix-A data (name, component, direction, position, sensitivity).

    Raises
    ------
    InputError
        For an unknown name; the message suggests close matches.
    """
    key = ALIASES.get(name, name)
    try:
        return _BY_NAME[key]
    except (KeyError, TypeError):
        close = difflib.get_close_matches(str(name), list(_BY_NAME), n=4, cutoff=0.5)
        hint = f"did you mean {', '.join(close)}?" if close else "see exudyn_study.model.sensors.SENSORS"
        raise InputError(
            f"unknown sensor {name!r}; expected one of the 42 Table 8 names ({hint})"
        ) from None


def z_sensors() -> tuple[Sensor, ...]:
    """Return the 21 sensors measuring in z, in Table 8 order."""
    return tuple(s for s in SENSORS if s.direction == "Z")


def sensors_on(component: str) -> tuple[Sensor, ...]:
    """Return the sensors on ``component`` (one of :data:`COMPONENTS`).

    Parameters
    ----------
    component : str
        Component name, one of :data:`COMPONENTS` (e.g. 'frame', 'tank_left').

    Returns
    -------
    tuple of Sensor
        Its sensors in Table 8 order (empty if it carries none).

    Raises
    ------
    InputError
        For an unknown component.
    """
    if component not in COMPONENTS:
        raise InputError(f"component {component!r}; expected one of {', '.join(COMPONENTS)}")
    return tuple(s for s in SENSORS if s.component == component)
