"""The uni-axial test rig of the thesis (Section 3.2, 4.2) from Exudyn rigid bodies and joints.

Layout (local rig coordinates, m; ``x`` rearwards, ``y`` to the right, ``z`` up)::

      frame drive pads (front_left_drive / front_right_drive)
              |  spherical joints                       rear attachments
       strut  |  strut (rigid, universal joint below)       |  spherical joints
              |                                        rear foundation (flexible body,
   linkage ===+=== (rigid, revolute about y to ground)      two interfaces fixed to ground)
              |  pin (x and z), piston
        piston|  prismatic along z, prescribed displacement u(t)
      cylinder|  revolute about y to ground

- the hydraulic cylinder is jointed to ground, rotation about y only;
- the piston sits on the cylinder with a joint that constrains all six relative
  coordinates, the one along the cylinder axis to the drive ``u(t)`` (a prismatic joint
  with a prescribed displacement: ``ObjectJointGeneric`` with an offset user function);
- the piston is pinned to the linkage (x and z; the planar loop needs no y constraint,
  a spherical joint there would be redundant for rigid parts);
- the linkage rotates about y on ground; its lever ratio is 1 (the pin and the strut
  feet sit at the drive pads' x), so the frame front follows the drive displacement;
- two rigid struts carry the motion to the frame's front drive pads (universal joint at
  the linkage, spherical joint at the frame);
- a front-attachment strut along y (universal joint at ground, spherical at the frame's
  ``front_strut`` patch) restrains the frame's y motion;
- the rear foundation is a flexible body: ``ground_left``/``ground_right`` fixed to
  ground, ``frame_left``/``frame_right`` spherical to the frame's rear attachments,
  so the frame can rotate about y at the rear.

No gravity: the study is of small vibrations about the static equilibrium (the rig's
static preload is not part of the measured response).

The drive is a :class:`Drive`: a time series reconstructed band-limited on a finer grid
and interpolated there by a cubic spline (so the displacement, velocity and acceleration
seen by Exudyn are continuous, those of the band-limited signal the samples represent,
and the linear path in :mod:`exudyn_study.simulate` can discretise the same input exactly).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from exudyn_study.errors import InputError

#: interfaces of the rear foundation fixed to ground by the rig
FOUNDATION_GROUND_INTERFACES = ("ground_left", "ground_right")

__all__ = ["FOUNDATION_GROUND_INTERFACES", "RigParameters", "RigHandles", "Drive", "DRIVE_UPSAMPLING",
           "band_limited_upsample", "add_rig", "generic_joint", "ground_marker", "position_marker"]

@dataclass(frozen=True)
class RigParameters:
    """Dimensions (m) and masses (kg) of the rig's rigid parts (tape-measure estimates).

    Parameters
    ----------
    linkage_z_m : float
        Height of the linkage (its pivot, the piston pin and the strut feet).
    linkage_pivot_x_m : float
        x of the linkage's pivot on ground (the pin and strut feet are at the drive pads' x).
    cylinder_base_z_m : float
        Height of the cylinder's pivot on ground (below the piston pin).
    cylinder_length_m : float
        Length of the cylinder barrel; the piston rod makes up the rest to the pin.
    front_strut_length_m : float
        Length of the y-restraining front strut, from ground to the ``front_strut`` patch.
    cylinder_mass_kg, piston_mass_kg, linkage_mass_kg, strut_mass_kg, front_strut_mass_kg : float
    """

    linkage_z_m: float = -0.45
    linkage_pivot_x_m: float = -0.90
    cylinder_base_z_m: float = -1.25
    cylinder_length_m: float = 0.45
    front_strut_length_m: float = 0.60
    cylinder_mass_kg: float = 45.0
    piston_mass_kg: float = 12.0
    linkage_mass_kg: float = 40.0
    strut_mass_kg: float = 4.0
    front_strut_mass_kg: float = 3.0

    def __post_init__(self) -> None:
        for name in ("cylinder_mass_kg", "piston_mass_kg", "linkage_mass_kg", "strut_mass_kg",
                     "front_strut_mass_kg", "cylinder_length_m", "front_strut_length_m"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise InputError(f"RigParameters.{name} = {v!r}; expected a positive finite value")
        if not self.cylinder_base_z_m + self.cylinder_length_m < self.linkage_z_m:
            raise InputError(
                f"RigParameters: cylinder (base z {self.cylinder_base_z_m} m + length "
                f"{self.cylinder_length_m} m) must end below the linkage (z {self.linkage_z_m} m)"
            )


#: default upsampling factor of :class:`Drive` (measured: see its docstring)
DRIVE_UPSAMPLING = 8
#: half-length of the band-limited interpolation kernel, in input samples (16 ms at 1 kHz)
DRIVE_KERNEL_HALF_LENGTH = 16
#: Kaiser window parameter of the interpolation kernel: with the default half-length and factor the
#: kernel is flat to 1e-9 up to 300 Hz and below -185 dB from 700 Hz at a 1 kHz input (images of a
#: 1 Hz component near 1 kHz weigh (1000 / 1)^2 more in acceleration)
DRIVE_KAISER_BETA = 20.0


def _interpolation_kernel(factor: int, half_length: int, kaiser_beta: float) -> np.ndarray:
    """Kaiser-windowed sinc of cutoff half the input rate, ``2 half_length factor + 1`` taps.

    Zero at the other input samples (``sinc(n / factor)``), so the input samples are kept
    exactly; every polyphase component is scaled to unit sum, so a constant is kept exactly.
    """
    n = np.arange(-half_length * factor, half_length * factor + 1)
    h = np.sinc(n / factor) * np.kaiser(n.size, kaiser_beta)
    phase = np.mod(n, factor)
    sums = np.bincount(phase, weights=h, minlength=factor)
    return h / sums[phase]


def band_limited_upsample(samples: np.ndarray, factor: int, half_length: int = DRIVE_KERNEL_HALF_LENGTH,
                          kaiser_beta: float = DRIVE_KAISER_BETA) -> np.ndarray:
    """Return the band-limited signal through ``samples`` sampled at ``factor`` times their rate.

    An FIR interpolator (:func:`_interpolation_kernel`, applied with
    :func:`scipy.signal.upfirdn`); the record is extended at both ends by odd reflection about
    its end samples (value and slope continue), so the ends do not ring as they would against
    zeros.

    Parameters
    ----------
    samples : ndarray, shape (N,)
    factor : int
        Upsampling factor (>= 1; 1 returns a copy).
    half_length : int
        Kernel half-length in input samples.
    kaiser_beta : float

    Returns
    -------
    ndarray, shape ((N - 1) factor + 1,)
        ``out[k factor] == samples[k]``.

    Raises
    ------
    InputError
        ``factor`` not an integer >= 1.
    """
    from scipy import signal as sps

    x = np.asarray(samples, dtype=float)
    if isinstance(factor, bool) or not isinstance(factor, (int, np.integer)) or factor < 1:
        raise InputError(f"upsampling factor {factor!r}; expected an integer >= 1 (1: no upsampling)")
    if factor == 1:
        return x.copy()
    h = _interpolation_kernel(factor, half_length, kaiser_beta)
    pad = half_length + 1
    xp = np.pad(x, pad, mode="reflect", reflect_type="odd")
    y = sps.upfirdn(h, xp, up=factor)
    first = (half_length + pad) * factor  # the kernel's delay plus the padding
    return y[first: first + (x.size - 1) * factor + 1]


class Drive:
    """Prescribed piston displacement ``u(t)`` (m), reconstructed from samples.

    :meth:`set_signal` takes samples at ``sample_rate_hz`` (in the simulations the output
    rate, 1 kHz) as samples of a band-limited signal: they are upsampled by ``upsampling`` with a
    band-limited interpolator (:func:`band_limited_upsample`) and a natural cubic spline is
    put through the fine samples. The spline keeps the representation simple (one cubic per
    fine interval: ``_coef`` (4, n_fine - 1), interval ``1 / spline_rate_hz``) and makes the
    displacement, velocity and acceleration continuous; the upsampling makes them those of
    the band-limited signal. A cubic spline through the 1 kHz samples themselves has a
    relative acceleration error of ~(omega h)^2 / 12 at the samples (1.1 % at 58 Hz), which
    showed in the FRFs of small y channels, differences of drive-following terms (issue 3).

    Measured on a 1 kHz sine, away from the record ends (largest error over time, relative
    to the amplitude of the displacement, velocity, acceleration): acceleration 0.0006 % at
    10 Hz, 0.008 % at 40 Hz, 0.019 % at 60 Hz, 0.025 % at 70 Hz, 0.05 % at 100 Hz with the
    default factor 8 (the fine spline's (omega h)^2 / 12 with h = 1/8 ms; the interpolator's
    own error is 0.006 % at 1 Hz); factor 4: 0.074 % at 60 Hz, 0.1 % at 70 Hz; factor 1 (the
    plain spline): 0.03 % at 10 Hz, 0.53 % at 40 Hz, 1.2 % at 60 Hz. Cost on Model 1 (80 s):
    :func:`exudyn_study.simulate.simulate_linear` 0.20 -> 0.25-0.31 s CPU, :meth:`set_signal`
    0.08 s. Within ``DRIVE_KERNEL_HALF_LENGTH`` samples of the record ends the signal beyond
    them is guessed (odd reflection); the drives of :func:`exudyn_study.simulate.prepare_drive`
    start from rest.

    Before :meth:`set_signal` the drive is zero. Outside the sampled interval the end
    values are held (with zero velocity).

    Parameters
    ----------
    upsampling : int
        Upsampling factor (>= 1) used by :meth:`set_signal`; 1 gives the plain cubic spline
        through the samples.

    Attributes
    ----------
    sample_rate_hz : float
        Rate of the given samples (Hz).
    samples : ndarray
        The given samples (m).
    upsampling : int
    spline_rate_hz : float
        ``sample_rate_hz * upsampling``: the spline's knot rate (Hz).
    """

    def __init__(self, upsampling: int = DRIVE_UPSAMPLING) -> None:
        self.sample_rate_hz = 1.0
        self.samples = np.zeros(2)
        self.upsampling = upsampling
        self.spline_rate_hz = 1.0
        self._coef = np.zeros((4, 1))  # c0 dt^3 + c1 dt^2 + c2 dt + c3 on each fine interval
        self.joint = None  # Exudyn object number of the driven joint (set by add_rig)
        self.axis = 2  # driven coordinate of the joint (z of its joint frame)

    def set_signal(self, samples, sample_rate_hz: float) -> None:
        """Use ``samples`` (m) at ``sample_rate_hz`` as the drive (band-limited, then a natural cubic spline).

        Parameters
        ----------
        samples : array_like, shape (n_samples,)
            Piston displacement samples (m), at least 4, all finite; any shape is flattened.
        sample_rate_hz : float
            Their sample rate (Hz), finite and > 0.

        Raises
        ------
        InputError
            On NaN/inf samples, fewer than 4 samples, a bad rate or a bad ``upsampling``.
        """
        from scipy.interpolate import CubicSpline

        x = np.asarray(samples, dtype=float).ravel()
        if not (math.isfinite(sample_rate_hz) and sample_rate_hz > 0):
            raise InputError(f"drive sample_rate_hz {sample_rate_hz!r}; expected a finite rate > 0 Hz")
        factor = self.upsampling
        if isinstance(factor, bool) or not isinstance(factor, (int, np.integer)) or factor < 1:
            raise InputError(f"drive upsampling {factor!r}; expected an integer >= 1 (1: no upsampling)")
        if x.size < 4:
            raise InputError(f"drive signal of {x.size} samples; expected at least 4")
        bad = ~np.isfinite(x)
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise InputError(
                f"drive signal has non-finite samples, the first at index {i} "
                f"(t = {i / sample_rate_hz:.4f} s)"
            )
        fine = band_limited_upsample(x, int(factor))
        spline_rate = float(sample_rate_hz) * int(factor)
        spline = CubicSpline(np.arange(fine.size) / spline_rate, fine, bc_type="natural")
        self.sample_rate_hz = float(sample_rate_hz)
        self.spline_rate_hz = spline_rate
        self.samples = x
        self._coef = np.ascontiguousarray(spline.c)

    @property
    def duration_s(self) -> float:
        """Time of the last sample (s)."""
        return (self.samples.size - 1) / self.sample_rate_hz

    def _locate(self, t: float):
        k = int(t * self.spline_rate_hz)
        n = self._coef.shape[1]
        if k < 0:
            return None, 0.0
        if k >= n:
            return None, 1.0
        return k, t - k / self.spline_rate_hz

    def value(self, t: float) -> float:
        """Return the displacement at time ``t`` (m).

        Parameters
        ----------
        t : float
            Time (s); before the first sample the first sample is held, after the last the last.

        Returns
        -------
        float
            Piston displacement (m).
        """
        k, dt = self._locate(t)
        if k is None:
            return float(self.samples[0] if dt == 0.0 else self.samples[-1])
        c = self._coef
        return ((c[0, k] * dt + c[1, k]) * dt + c[2, k]) * dt + c[3, k]

    def velocity(self, t: float) -> float:
        """Return the velocity at time ``t`` (m/s).

        Parameters
        ----------
        t : float
            Time (s); outside the sampled interval the velocity is 0.

        Returns
        -------
        float
            Piston velocity (m/s).
        """
        k, dt = self._locate(t)
        if k is None:
            return 0.0
        c = self._coef
        return (3.0 * c[0, k] * dt + 2.0 * c[1, k]) * dt + c[2, k]

    def evaluate(self, t: np.ndarray, derivative: int = 0) -> np.ndarray:
        """Return the displacement (0), velocity (1) or acceleration (2) at times ``t``, vectorised.

        Parameters
        ----------
        t : array_like
            Times (s), any shape; outside the sampled interval the end intervals' polynomials are
            evaluated at their ends.
        derivative : {0, 1, 2}
            Time derivative to return.

        Returns
        -------
        ndarray, shape of ``t``
            Displacement (m), velocity (m/s) or acceleration (m/s^2).

        Raises
        ------
        InputError
            For another ``derivative``.
        """
        t = np.asarray(t, dtype=float)
        n = self._coef.shape[1]
        k = np.clip((t * self.spline_rate_hz).astype(int), 0, n - 1)
        dt = np.clip(t - k / self.spline_rate_hz, 0.0, 1.0 / self.spline_rate_hz)
        c0, c1, c2, c3 = (self._coef[i, k] for i in range(4))
        if derivative == 0:
            return ((c0 * dt + c1) * dt + c2) * dt + c3
        if derivative == 1:
            return (3.0 * c0 * dt + 2.0 * c1) * dt + c2
        if derivative == 2:
            return 6.0 * c0 * dt + 2.0 * c1
        raise InputError(f"derivative {derivative!r}; expected 0, 1 or 2")

    # Exudyn user functions (ObjectJointGeneric offsetUserFunction / offsetUserFunction_t)
    def offset_user_function(self, mbs, t, item_number, parameters):
        """Return the joint offset at ``t``: Exudyn's ``ObjectJointGeneric`` ``offsetUserFunction``.

        Parameters
        ----------
        mbs : exudyn.MainSystem
            The system (unused; part of Exudyn's user-function signature).
        t : float
            Time (s).
        item_number : int
            The joint's object number (unused).
        parameters : list of float
            The joint's ``offsetUserFunctionParameters`` (unused).

        Returns
        -------
        list of float, length 6
            Zero except the driven axis ``self.axis``: the displacement :meth:`value` (m).
        """
        out = [0.0] * 6
        out[self.axis] = self.value(t)
        return out

    def offset_user_function_t(self, mbs, t, item_number, parameters):
        """Return the joint offset velocity at ``t``: Exudyn's ``offsetUserFunction_t``.

        Parameters
        ----------
        mbs : exudyn.MainSystem
            The system (unused; part of Exudyn's user-function signature).
        t : float
            Time (s).
        item_number : int
            The joint's object number (unused).
        parameters : list of float
            The joint's ``offsetUserFunctionParameters`` (unused).

        Returns
        -------
        list of float, length 6
            Zero except the driven axis ``self.axis``: the velocity :meth:`velocity` (m/s).
        """
        out = [0.0] * 6
        out[self.axis] = self.velocity(t)
        return out


@dataclass
class RigHandles:
    """Exudyn item numbers of the rig.

    Attributes
    ----------
    bodies : dict name -> rigid-body object number
        'cylinder', 'piston', 'linkage', 'strut_left', 'strut_right', 'front_strut'.
    nodes : dict name -> rigid-body node number
    joints : dict name -> joint object number
    ground : int
        The ground object.
    drive : Drive
    """

    bodies: dict = field(default_factory=dict)
    nodes: dict = field(default_factory=dict)
    joints: dict = field(default_factory=dict)
    ground: int = -1
    drive: Drive = field(default_factory=Drive)


def ground_marker(mbs, ground: int, position_m) -> int:
    """Add a ``MarkerBodyRigid`` on the ground object at the global ``position_m``.

    Parameters
    ----------
    mbs : exudyn.MainSystem
        System to add the marker to.
    ground : int
        Object number of the ground (``ObjectGround`` at the origin).
    position_m : array_like, shape (3,)
        Global marker position (m).

    Returns
    -------
    int
        The marker number.
    """
    import exudyn.itemInterface as eii

    return mbs.AddMarker(eii.MarkerBodyRigid(bodyNumber=ground, localPosition=[float(v) for v in position_m]))


def generic_joint(mbs, marker0: int, marker1: int, axes, name: str, **kwargs) -> int:
    """Add an ``ObjectJointGeneric`` constraining ``axes`` (6 flags: x, y, z, rx, ry, rz, global axes).

    Parameters
    ----------
    mbs : exudyn.MainSystem
        System to add the joint to.
    marker0, marker1 : int
        Marker numbers of the two joined points (rigid markers: the rotations are constrained too).
    axes : sequence of 6 int or bool
        1 for each constrained axis, in the order x, y, z, rx, ry, rz.
    name : str
        Exudyn name of the joint.
    **kwargs
        Further ``ObjectJointGeneric`` arguments (e.g. ``offsetUserFunction``).

    Returns
    -------
    int
        The joint's object number.
    """
    import exudyn.itemInterface as eii

    return mbs.AddObject(
        eii.ObjectJointGeneric(
            name=name,
            markerNumbers=[marker0, marker1],
            constrainedAxes=[int(a) for a in axes],
            visualization=eii.VObjectJointGeneric(show=False),
            **kwargs,
        )
    )


def position_marker(mbs, marker: int) -> int:
    """Add a ``MarkerSuperElementPosition`` on the nodes and weights of a rigid super-element marker.

    For a joint that constrains positions only (spherical), the position marker gives
    the same point (the weighted mean of the patch nodes) and the same linearisation as
    the ``MarkerSuperElementRigid`` it is made from, without the marker's rotation
    (weighted rotation and its Jacobian from every patch node in every Newton
    iteration): on Model 1 the rig's seven spherical joints on flexible bodies made the
    full Exudyn path 1.46x slower with rigid markers (``benchmarks/bench_simulation.py``).
    Any other marker (or a rigid one with an offset) is returned unchanged.

    Parameters
    ----------
    mbs : exudyn.MainSystem
        System holding the marker.
    marker : int
        Marker number.

    Returns
    -------
    int
        The new position marker's number, or ``marker`` itself.
    """
    import exudyn.itemInterface as eii

    data = mbs.GetMarker(marker)
    offset = np.asarray(data.get("offset", 0.0), dtype=float)
    if str(data.get("markerType")) != "SuperElementRigid" or np.any(offset != 0.0):
        return marker
    return mbs.AddMarker(eii.MarkerSuperElementPosition(
        name=f"position:{data.get('name', marker)}", bodyNumber=data["bodyNumber"],
        meshNodeNumbers=[int(n) for n in data["meshNodeNumbers"]],
        weightingFactors=[float(w) for w in data["weightingFactors"]]))


def _rigid_body(mbs, name: str, position, mass: float, side_lengths, color,
                lie_group_node: bool = False) -> tuple[int, int]:
    """Add a cuboid-inertia rigid body of ``mass`` centred at ``position``; return (object, node).

    ``lie_group_node``: a ``NodeRigidBodyRotVecLG`` (rotation vector, Lie-group update)
    instead of Euler parameters; with the centre of mass at the node its mass matrix is
    constant.
    """
    import exudyn as exu
    import exudyn.utilities as eu

    sides = np.asarray(side_lengths, dtype=float)
    density = mass / float(np.prod(sides))
    kwargs = {"nodeType": exu.NodeType.RotationRotationVector} if lie_group_node else {}
    obj = mbs.CreateRigidBody(
        name=name,
        referencePosition=[float(v) for v in position],
        inertia=eu.InertiaCuboid(density, sides.tolist()),
        gravity=[0.0, 0.0, 0.0],
        color=list(color),
        **kwargs,
    )
    return int(obj), int(mbs.GetObject(obj)["nodeNumber"])


def _body_marker(mbs, body: int, body_position, global_point) -> int:
    import exudyn.itemInterface as eii

    local = np.asarray(global_point, dtype=float) - np.asarray(body_position, dtype=float)
    return mbs.AddMarker(eii.MarkerBodyRigid(bodyNumber=body, localPosition=local.tolist()))


def add_rig(mbs, frame_markers: dict, frame_positions: dict, foundation,
            params: RigParameters = RigParameters(), ground: int | None = None,
            lie_group_nodes: bool = False) -> RigHandles:
    """Add the rig's rigid parts and joints, connecting them to the frame and the foundation.

    Parameters
    ----------
    mbs : exudyn.MainSystem
    frame_markers : dict
        Interface name -> ``MarkerSuperElementRigid`` of the body carrying it, for
        'front_left_drive', 'front_right_drive', 'front_strut', 'rear_left', 'rear_right'.
    frame_positions : dict
        Interface name -> global patch centre (m), same keys.
    foundation : FlexibleBodyHandle-like
        The rear foundation (``interface_markers``, ``interface_positions_m`` with
        'ground_left', 'ground_right', 'frame_left', 'frame_right'). Interfaces in its
        ``fixed_interfaces`` (if any) are already fixed (their coordinates eliminated):
        no joint is added for them.
    params : RigParameters
    ground : int, optional
        An existing ground object (created if None).
    lie_group_nodes : bool
        Rigid parts on ``NodeRigidBodyRotVecLG`` nodes (constant mass matrices) instead of
        Euler parameters. With constant-matrix flexible bodies
        (:func:`~exudyn_study.bodies.linear_body.add_linear_matrix_body`) every mass matrix of
        the model is then constant and Exudyn computes the system mass matrix once instead of
        in every residual evaluation. Same linearised system.

    Returns
    -------
    RigHandles
    """
    import exudyn.itemInterface as eii

    needed = ("front_left_drive", "front_right_drive", "front_strut", "rear_left", "rear_right")
    missing = [n for n in needed if n not in frame_markers]
    if missing:
        raise InputError(f"rig: the frame has no interface {missing}; it needs {list(needed)}")
    h = RigHandles()
    h.ground = mbs.AddObject(eii.ObjectGround(name="ground")) if ground is None else ground
    p = params
    lg = bool(lie_group_nodes)
    left = np.asarray(frame_positions["front_left_drive"], dtype=float)
    right = np.asarray(frame_positions["front_right_drive"], dtype=float)
    x_d = 0.5 * (left[0] + right[0])
    z_l = p.linkage_z_m
    pin = np.array([x_d, 0.0, z_l])
    pivot = np.array([p.linkage_pivot_x_m, 0.0, z_l])
    base = np.array([x_d, 0.0, p.cylinder_base_z_m])
    cyl_top = base + [0.0, 0.0, p.cylinder_length_m]

    # cylinder: revolute about y at its base
    c_pos = 0.5 * (base + cyl_top)
    h.bodies["cylinder"], h.nodes["cylinder"] = _rigid_body(
        mbs, "cylinder", c_pos, p.cylinder_mass_kg, (0.12, 0.12, p.cylinder_length_m), (0.4, 0.4, 0.4, 1), lg)
    h.joints["cylinder_ground"] = generic_joint(
        mbs, ground_marker(mbs, h.ground, base), _body_marker(mbs, h.bodies["cylinder"], c_pos, base),
        (1, 1, 1, 1, 0, 1), "cylinder_ground")
    # piston: all six coordinates to the cylinder, z prescribed (prismatic + actuator)
    rod = pin[2] - cyl_top[2]
    p_pos = 0.5 * (cyl_top + pin)
    h.bodies["piston"], h.nodes["piston"] = _rigid_body(
        mbs, "piston", p_pos, p.piston_mass_kg, (0.08, 0.08, rod), (0.5, 0.5, 0.1, 1), lg)
    drive = h.drive
    h.joints["drive"] = generic_joint(
        mbs, _body_marker(mbs, h.bodies["cylinder"], c_pos, cyl_top),
        _body_marker(mbs, h.bodies["piston"], p_pos, cyl_top), (1, 1, 1, 1, 1, 1), "drive",
        offsetUserFunction=drive.offset_user_function, offsetUserFunction_t=drive.offset_user_function_t)
    drive.joint = h.joints["drive"]
    # linkage: revolute about y to ground, pinned (x, z) to the piston
    y_span = abs(right[1] - left[1])
    l_pos = 0.5 * (pivot + pin)
    h.bodies["linkage"], h.nodes["linkage"] = _rigid_body(
        mbs, "linkage", l_pos, p.linkage_mass_kg, (abs(x_d - pivot[0]), y_span, 0.10), (0.2, 0.6, 0.2, 1), lg)
    h.joints["linkage_ground"] = generic_joint(
        mbs, ground_marker(mbs, h.ground, pivot), _body_marker(mbs, h.bodies["linkage"], l_pos, pivot),
        (1, 1, 1, 1, 0, 1), "linkage_ground")
    h.joints["piston_linkage"] = generic_joint(
        mbs, _body_marker(mbs, h.bodies["piston"], p_pos, pin),
        _body_marker(mbs, h.bodies["linkage"], l_pos, pin), (1, 0, 1, 0, 0, 0), "piston_linkage")
    # struts: universal joint at the linkage (twist about the strut axis locked), spherical at the pad
    for side, top in (("left", left), ("right", right)):
        foot = np.array([top[0], top[1], z_l])
        s_pos = 0.5 * (foot + top)
        name = f"strut_{side}"
        h.bodies[name], h.nodes[name] = _rigid_body(
            mbs, name, s_pos, p.strut_mass_kg, (0.05, 0.05, float(top[2] - foot[2])), (0.1, 0.7, 0.8, 1), lg)
        h.joints[f"{name}_linkage"] = generic_joint(
            mbs, _body_marker(mbs, h.bodies["linkage"], l_pos, foot),
            _body_marker(mbs, h.bodies[name], s_pos, foot), (1, 1, 1, 0, 0, 1), f"{name}_linkage")
        h.joints[f"{name}_frame"] = mbs.AddObject(eii.ObjectJointSpherical(
            name=f"{name}_frame",
            markerNumbers=[_body_marker(mbs, h.bodies[name], s_pos, top),
                           position_marker(mbs, frame_markers[f"front_{side}_drive"])],
            visualization=eii.VObjectJointSpherical(show=False)))
    # front attachment strut along y: universal joint at ground, spherical at the frame
    fs = np.asarray(frame_positions["front_strut"], dtype=float)
    g = fs - [0.0, p.front_strut_length_m, 0.0]
    f_pos = 0.5 * (g + fs)
    h.bodies["front_strut"], h.nodes["front_strut"] = _rigid_body(
        mbs, "front_strut", f_pos, p.front_strut_mass_kg, (0.04, p.front_strut_length_m, 0.04),
        (0.1, 0.2, 0.9, 1), lg)
    h.joints["front_strut_ground"] = generic_joint(
        mbs, ground_marker(mbs, h.ground, g), _body_marker(mbs, h.bodies["front_strut"], f_pos, g),
        (1, 1, 1, 0, 1, 0), "front_strut_ground")  # universal joint: twist about y locked
    h.joints["front_strut_frame"] = mbs.AddObject(eii.ObjectJointSpherical(
        name="front_strut_frame",
        markerNumbers=[_body_marker(mbs, h.bodies["front_strut"], f_pos, fs),
                       position_marker(mbs, frame_markers["front_strut"])],
        visualization=eii.VObjectJointSpherical(show=False)))
    # rear foundation: fixed to ground (unless its body has these coordinates eliminated already,
    # ``fixed_interfaces``), spherical to the frame's rear attachments
    for side in ("left", "right"):
        gname = f"ground_{side}"
        if gname not in getattr(foundation, "fixed_interfaces", ()):
            h.joints[f"foundation_{gname}"] = generic_joint(
                mbs, ground_marker(mbs, h.ground, foundation.interface_positions_m[gname]),
                foundation.interface_markers[gname], (1, 1, 1, 1, 1, 1), f"foundation_{gname}")
        h.joints[f"foundation_rear_{side}"] = mbs.AddObject(eii.ObjectJointSpherical(
            name=f"foundation_rear_{side}",
            markerNumbers=[position_marker(mbs, foundation.interface_markers[f"frame_{side}"]),
                           position_marker(mbs, frame_markers[f"rear_{side}"])],
            visualization=eii.VObjectJointSpherical(show=False)))
    return h
