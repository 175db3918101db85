"""Compensation: the joint readings to command so the real robot's TCP reaches targets.

Three methods (:class:`CompensationMethod`), vectorised over targets, each a function taking what it
needs (:func:`compensate` picks one by name, for the command line):

* ``exact`` (default, :func:`compensate_exact`): Newton through the identified geometry
  with the vectorised exact solver (:func:`deltacal.kinematics.exact.inverse`). It uses every
  element of the identified geometry, including the plate tilt and the tool's lever arm.
* ``savoure`` (:func:`compensate_savoure`): Savoure 2006's approximate complete inverse model
  (Eq. 29-33, Fig. 2): nominal closed-form IK, predicted TCP error ``δX = S_C(q) δk`` around
  the nominal geometry (TCP displacement, tilt included), correction ``δq = J_S^m(q) δx``,
  ``q_corrected = q − δq``.
* ``bai`` (:func:`compensate_bai`): Bai 2015's linear compensator (Eq. 22-25): the same
  first-order correction computed for the plate's reference point, ``Δq_m = −B_m⁻¹(B_r Δp_r −
  A_rε A_εε⁻¹ B_ε Δp_ε)``; the tilt's effect on a tool below the plate is not compensated.

The linear methods are first order in the identified deviations. Encoder offsets,
usually the largest, act in joint space, where the correction ``J_S^m J_S δθ = δθ``
is exact; the neglected terms are products of the other deviations (0.003 mm in
``deltacal demo``). The exact method has no such limit and is the default.
:func:`screen` refuses early, at the closed-form model's speed, what :func:`compensate`
would refuse among the targets that model doubts (``deltacal compensate``'s reading pass).
Units: mm and rad.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from enum import StrEnum

import numpy as np

from .arguments import geometry_of, points_array
from .errormodels import ErrorModel, get_model
from .errormodels.base import elementary_jacobian
from .exceptions import AssemblyError, GeometryError, UnreachableError
from .geometry import DeltaGeometry
from .kinematics import exact, statics
from .kinematics.closed_form import VirtualDelta
from .kinematics.continuation import inverse_along
from .kinematics.exact import PlatePose
from .kinematics.singularity import COMMAND_MARGIN
from .kinematics.workspace import default_workspace


class CompensationMethod(StrEnum):
    """A compensation method; its value is the word files and ``deltacal compensate --method`` use."""

    EXACT = "exact"
    SAVOURE = "savoure"
    BAI = "bai"

    @classmethod
    def of(cls, method: str | CompensationMethod) -> CompensationMethod:
        """The method of a word (or the method itself).

        Raises:
            ValueError: an unknown word, naming the methods.
        """
        try:
            return cls(method)
        except ValueError:
            raise ValueError(f"method must be one of {', '.join(METHODS)}, got {method!r}") from None

    @property
    def linear(self) -> bool:
        """Whether it is a linear compensator (first order in the deviations, a rotary Delta's)."""
        return _SCHEMES[self].linear

    @property
    def check_tolerance(self) -> float:
        """How far from the target its readings may leave the identified robot's TCP [mm]."""
        return _SCHEMES[self].check_tolerance


@dataclass(frozen=True)
class _Scheme:
    """What a method is: linear or not, its check's tolerance [mm], whether it moves the TCP (Eq. 31)."""

    linear: bool
    check_tolerance: float
    tool_lever: bool


#: How far from the target the identified robot may put the TCP at the readings a method
#: gives [mm]: exact solves the closed loops (Newton to 1e-9 mm); Savoure's linear scheme
#: leaves the products of deviations (micrometres for real robots); Bai's ignores the tilt's
#: lever on the tool (Eq. 22-25 move the plate centre), millimetres with a long tool.
_SCHEMES = {
    CompensationMethod.EXACT: _Scheme(linear=False, check_tolerance=1e-6, tool_lever=True),
    CompensationMethod.SAVOURE: _Scheme(linear=True, check_tolerance=0.1, tool_lever=True),
    CompensationMethod.BAI: _Scheme(linear=True, check_tolerance=5.0, tool_lever=False),
}
#: The compensation methods' words (``deltacal compensate --method``).
METHODS = tuple(method.value for method in CompensationMethod)
#: The linear compensators' words.
LINEAR_METHODS = tuple(method.value for method in CompensationMethod if method.linear)


@dataclass(frozen=True)
class LinearCalibration:
    """What the linear compensators need: the nominal geometry and the identified deviations.

    Attributes:
        nominal: The geometry the deviations are measured from.
        model: The error model.
        deviation: Identified parameter deviations (full vector of the model).
    """

    nominal: DeltaGeometry
    model: ErrorModel
    deviation: np.ndarray


def predicted_plate_displacement(calibration: LinearCalibration, q: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``δX = S(q) δk`` around the nominal geometry at readings q, plate at x, (N, 6).

    Computed as ``−J_X⁻¹ (J_k e)`` (Savoure Eq. 17) with the elementary moves
    ``e = M δk``, at the plate parallel at x, without forming S (so it is cheap for
    many targets).
    """
    g = calibration.nominal
    e = calibration.model.moves(g) @ calibration.deviation
    pose = PlatePose(x, np.broadcast_to(np.eye(3), (x.shape[0], 3, 3)))
    return exact.plate_displacement(g, q, pose, elementary_jacobian(g, q, pose, moves=e))


def _inverse_jacobian(geometry: DeltaGeometry, q: np.ndarray, x: np.ndarray) -> np.ndarray:
    """J_S^m of the virtual model (Savoure Eq. 32) at readings q with the plate at x, (N, 3, 3).

    :meth:`VirtualDelta.inverse_jacobian` with the plate position given instead of
    recomputed by the forward kinematics: rows ``n_i / (n_i · dE_i/dq_i)`` with the
    virtual rods ``n_i = x + a_i − E_i``.
    """
    virtual = VirtualDelta.from_geometry(geometry)
    n = x[:, None, :] + virtual.plate_attachment - virtual.elbows(q)
    dE = virtual.elbow_velocity(q)  # the chain's own motion (deltacal.chains)
    return n / np.sum(n * dE, axis=2)[..., None]


def compensate_linear(
    calibration: LinearCalibration, targets: np.ndarray, method: str | CompensationMethod = "savoure"
) -> np.ndarray:
    """Readings from a linear compensator (``"savoure"`` Eq. 29-33 or ``"bai"`` Eq. 22-25).

    Args:
        calibration: Nominal geometry, model and identified deviations.
        targets: Desired TCP positions [mm], shape (N, 3).
        method: ``"savoure"`` (TCP error, tilt included) or ``"bai"`` (plate reference point).

    Returns:
        Readings [rad], shape (N, 3).

    Raises:
        ValueError: a method that is not a linear compensator.
    """
    if method not in LINEAR_METHODS:
        raise ValueError(f"method must be 'savoure' or 'bai', got {str(method)!r}")
    scheme = _SCHEMES[CompensationMethod(method)]
    targets = points_array(targets, "targets")
    g = calibration.nominal
    virtual = VirtualDelta.from_geometry(g)
    x = targets - g.tool[None]
    q = _checked_inverse(virtual, x, targets)  # Eq. 29
    dX = predicted_plate_displacement(calibration, q, x)  # Eq. 30
    dx = dX[:, :3]
    if scheme.tool_lever:
        dx = dx + np.cross(dX[:, 3:], g.tool[None])  # Eq. 31: the TCP's displacement
    dq = np.einsum("nkl,nl->nk", _inverse_jacobian(g, q, x), dx)  # Eq. 32
    return q - dq  # Eq. 33


def _checked_inverse(virtual: VirtualDelta, x: np.ndarray, targets: np.ndarray) -> np.ndarray:
    q = virtual.inverse(x, check=False)
    bad = ~np.all(np.isfinite(q), axis=1)
    if np.any(bad):
        raise UnreachableError.from_mask(bad, targets)
    return q


#: How far from the target the identified robot may put the TCP at the readings a method gives
#: [mm], by method (its word, or the method: :attr:`CompensationMethod.check_tolerance`).
CHECK_TOLERANCE = {method: scheme.check_tolerance for method, scheme in _SCHEMES.items()}


def check_readings(geometry: DeltaGeometry, targets: np.ndarray, q: np.ndarray,
                   method: str | CompensationMethod) -> np.ndarray:
    """Targets whose readings are not finite, out of range, or miss the target, (N,) bool.

    The range is the chain's :attr:`~deltacal.chains.Chain.reading_range`: an arm's
    (:data:`~deltacal.chains.ARM_RANGE`) or a carriage's (:data:`~deltacal.chains.TRAVEL_RANGE`:
    not above its endstop).

    Missing is judged through the exact forward kinematics of ``geometry`` (the identified
    robot) started from its working assembly (the virtual model's pose, plate parallel: where
    the robot is when it comes from its home), against :data:`CHECK_TOLERANCE` of the method.
    For the exact method too: its inverse closes the loops wherever Newton led it, which far
    out can be another assembly than the working one (readings that would put the real robot
    millimetres away); those targets are refused.

    Raises:
        ValueError: an unknown method.
    """
    tolerance = CompensationMethod.of(method).check_tolerance
    bad = _beyond_range(geometry, q)
    ok = np.flatnonzero(~bad)
    while ok.size:
        try:
            pose = exact.forward(geometry, q[ok])
        except AssemblyError as exc:
            bad[ok[exc.indices]] = True
            ok = np.delete(ok, exc.indices)
            continue
        miss = np.linalg.norm(pose.point(geometry.tool) - targets[ok], axis=1) > tolerance
        bad[ok[miss]] = True
        break
    return bad


def _beyond_range(geometry: DeltaGeometry, q: np.ndarray) -> np.ndarray:
    """Readings not finite or beyond the chain's :attr:`~deltacal.chains.Chain.reading_range`, (N,) bool."""
    low, high = geometry.chain.reading_range
    with np.errstate(invalid="ignore"):
        return ~np.all(np.isfinite(q), axis=1) | np.any((q < low) | (q > high), axis=1)


#: Least transmission angle (arm to rod) of a commanded pose [rad] (:data:`COMMAND_MARGIN`).
MIN_TRANSMISSION_ANGLE = COMMAND_MARGIN.min_arm_rod_angle
#: Least inverse condition number of the unit rod directions of a commanded pose.
MIN_ROD_CONDITIONING = COMMAND_MARGIN.min_rod_conditioning


def singularity_margin(geometry: DeltaGeometry, q: np.ndarray, x: np.ndarray | None = None) -> np.ndarray:
    """Distance to the nearest singularity, as a fraction of the refusal thresholds, (N,).

    :data:`~deltacal.kinematics.singularity.COMMAND_MARGIN`'s margin on the virtual model
    of ``geometry``: below 1 the pose is refused. ``x``: that virtual model's plate position
    at q where known exactly (q from its inverse kinematics at x); by default its forward
    kinematics. NaN where the virtual model has no assembly at q.
    """
    return COMMAND_MARGIN.margin(VirtualDelta.from_geometry(geometry), q, x)


#: The cylinder around the robot's default workspace (``kinematics.workspace.default_workspace``)
#: whose targets are trusted to the working assembly without following their path, as factors
#: on its radius and height (same centre): 1.25 and 1.5 take in the robot files' workspaces; no
#: target in it was reached in another assembly (robots of Bai's size, see docs/errors.md).
TRUSTED_RADIUS, TRUSTED_HEIGHT = 1.25, 1.5
#: The steps along the path [mm]: a target whose path ends at other readings is followed again in
#: finer steps (at 20 mm, 3 of 90 rim targets of two robots ended 0.4-0.6 deg away, at 5 mm none).
PATH_STEPS = (20.0, 5.0, 1.25)
#: Readings of the same assembly agree to round-off; farther apart they are another's [rad].
SAME_ASSEMBLY = 1e-9


def other_assembly(geometry: DeltaGeometry, targets: np.ndarray, q: np.ndarray | None = None) -> np.ndarray:
    """Targets whose readings are not those the robot has when it comes from its workspace, (N,) bool.

    Targets outside the trusted cylinder (:data:`TRUSTED_RADIUS`, :data:`TRUSTED_HEIGHT` around the
    default workspace) are followed along the straight line from the workspace's centre
    (:func:`~deltacal.kinematics.continuation.inverse_along`, all at once, in the steps of
    :data:`PATH_STEPS`): where the working assembly is lost on the way or ends at other readings
    than ``q`` at every step (exact compensation's
    readings; by default computed here for those targets), the target is flagged. Targets whose
    readings are not finite are left to the other checks.
    """
    ws = default_workspace(geometry)
    centre = ws.centre
    radial = np.hypot(targets[:, 0] - centre[0], targets[:, 1] - centre[1])
    far = radial > TRUSTED_RADIUS * ws.radius
    far |= np.abs(targets[:, 2] - centre[2]) > 0.5 * TRUSTED_HEIGHT * ws.height
    flagged = np.zeros(targets.shape[0], dtype=bool)
    if not np.any(far):
        return flagged
    direct = exact.inverse(geometry, targets[far], check=False) if q is None else q[far]
    reached = np.all(np.isfinite(direct), axis=1)
    idx, direct = np.flatnonzero(far)[reached], direct[reached]
    for step in PATH_STEPS:  # finer where a coarser step ended elsewhere (near a fold of the rods)
        along = inverse_along(geometry, centre, targets[idx], step)
        with np.errstate(invalid="ignore"):
            apart = ~np.all(np.abs(geometry.chain.wrap(along - direct)) <= SAME_ASSEMBLY, axis=1)
        idx, direct = idx[apart], direct[apart]
    flagged[idx] = True
    return flagged


def _refuse_unsafe(geometry: DeltaGeometry, targets: np.ndarray, q: np.ndarray,
                   method: CompensationMethod, min_margin: float) -> None:
    """Refuse readings that miss their targets, are another assembly's, or are near a singularity.

    :func:`check_readings`, then :func:`other_assembly`, then :func:`singularity_margin`.

    Readings beyond the chain's range (an arm past its stops, a carriage above its endstop) put
    the target out of the robot's reach, and are refused as such.

    Raises:
        UnreachableError: naming the targets (:attr:`~UnreachableError.OUT_OF_REACH`,
            :attr:`~UnreachableError.CHECK_FAILED`, :attr:`~UnreachableError.OTHER_ASSEMBLY` or
            :attr:`~UnreachableError.SINGULAR`).
    """
    beyond = _beyond_range(geometry, q)
    if np.any(beyond):
        raise UnreachableError.from_mask(beyond, targets, UnreachableError.OUT_OF_REACH)
    failed = check_readings(geometry, targets, q, method)
    if np.any(failed):
        raise UnreachableError.from_mask(failed, targets, UnreachableError.CHECK_FAILED)
    elsewhere = other_assembly(geometry, targets, None if method.linear else q)  # exact: q is the inverse
    if np.any(elsewhere):
        raise UnreachableError.from_mask(elsewhere, targets, UnreachableError.OTHER_ASSEMBLY)
    margin = np.nan_to_num(singularity_margin(geometry, q), nan=0.0)  # no virtual assembly: at the limit
    near = margin < min_margin
    if np.any(near):
        worst = float(np.min(margin[near]))
        raise UnreachableError(
            f"{int(near.sum())} target(s) too close to a singularity (margin down to {worst:.3g} < "
            f"{min_margin:g}: arm and rod within {np.degrees(MIN_TRANSMISSION_ANGLE):g} deg of alignment "
            f"or rods nearly coplanar), first: {np.round(targets[np.flatnonzero(near)[0]], 6).tolist()} mm "
            f"(index {int(np.flatnonzero(near)[0])})",
            np.flatnonzero(near),
            targets[near],
            UnreachableError.SINGULAR,
        )


def compensate_exact(
    geometry: DeltaGeometry, targets: np.ndarray, *, min_margin: float = 1.0, payload: float = 0.0
) -> np.ndarray:
    """Joint readings that put the identified robot's TCP at the targets, through its exact kinematics.

    Newton through the identified geometry (:func:`deltacal.kinematics.exact.inverse`): every
    element of it counts, the plate tilt and the tool's lever arm included. With compliant
    actuators (``geometry.compliance``) the loaded TCP is put there: the rigid robot's readings
    e reach the targets, and the robot stands there loaded at the readings
    ``q = e − c tau(e)`` (:mod:`~deltacal.kinematics.statics`: e is its equilibrium), its own
    weight and the payload included. The checks are on e.

    Args:
        geometry: The identified geometry.
        targets: Desired TCP positions in the base frame [mm], shape (N, 3).
        min_margin: Targets whose readings have a :func:`singularity_margin` below this
            are refused (1: the thresholds MIN_TRANSMISSION_ANGLE, MIN_ROD_CONDITIONING).
        payload: Mass carried at the TCP [kg].

    Returns:
        Readings to command [rad; a printer's: carriage travels, mm], shape (N, 3).

    Raises:
        UnreachableError: naming the targets out of reach or too close to a singularity.
    """
    targets = points_array(targets, "targets")
    q = exact.inverse(geometry, targets)
    _refuse_unsafe(geometry, targets, q, CompensationMethod.EXACT, min_margin)
    if np.any(geometry.compliance):
        q = q - geometry.compliance * statics.gravity_torque(geometry, q, payload)
    return q


def compensate_savoure(
    geometry: DeltaGeometry, linear: LinearCalibration, targets: np.ndarray, *, min_margin: float = 1.0
) -> np.ndarray:
    """Joint readings from Savoure's linear compensator (Eq. 29-33), checked on the identified robot.

    Args:
        geometry: The identified geometry (the readings are checked through it).
        linear: Nominal geometry, model and identified deviations (what the scheme computes from).
        targets: Desired TCP positions in the base frame [mm], shape (N, 3).
        min_margin: As :func:`compensate_exact`.

    Returns:
        Readings to command [rad], shape (N, 3).

    Raises:
        UnreachableError: naming the targets out of reach, missed by more than
            :data:`CHECK_TOLERANCE`, or too close to a singularity.
        GeometryError: a printer (a prismatic chain): the linear schemes are a rotary Delta's.
    """
    return _compensate_linearly(geometry, linear, targets, CompensationMethod.SAVOURE, min_margin)


def compensate_bai(
    geometry: DeltaGeometry, linear: LinearCalibration, targets: np.ndarray, *, min_margin: float = 1.0
) -> np.ndarray:
    """Joint readings from Bai's linear compensator (Eq. 22-25), checked on the identified robot.

    The correction is the plate reference point's: the tilt's effect on a tool below the plate
    is not compensated (:data:`CHECK_TOLERANCE` allows for it).

    Args:
        geometry: The identified geometry (the readings are checked through it).
        linear: Nominal geometry, model and identified deviations (what the scheme computes from).
        targets: Desired TCP positions in the base frame [mm], shape (N, 3).
        min_margin: As :func:`compensate_exact`.

    Returns:
        Readings to command [rad], shape (N, 3).

    Raises:
        UnreachableError: as :func:`compensate_savoure`.
        GeometryError: a printer (a prismatic chain).
    """
    return _compensate_linearly(geometry, linear, targets, CompensationMethod.BAI, min_margin)


def _require_rotary(geometry: DeltaGeometry, method: CompensationMethod) -> None:
    if not geometry.chain.linear_compensation:  # their error models are a rotary Delta's
        raise GeometryError(f"the {method} compensation serves rotary Delta robots; "
                            f"{geometry.name or 'this geometry'!r} is a {geometry.chain.name} chain: use the "
                            "exact method")


def _compensate_linearly(geometry: DeltaGeometry, linear: LinearCalibration, targets: np.ndarray,
                         method: CompensationMethod, min_margin: float) -> np.ndarray:
    _require_rotary(geometry, method)
    targets = points_array(targets, "targets")
    q = compensate_linear(linear, targets, method)
    _refuse_unsafe(geometry, targets, q, method, min_margin)
    return q


def _checked_method(geometry: DeltaGeometry, method: str | CompensationMethod,
                    linear: LinearCalibration | None, payload: float) -> CompensationMethod:
    """The method of a word, refused if it does not exist or an argument does not belong to it.

    Raises:
        ValueError: naming the method and the argument.
        GeometryError: a linear method asked of a printer.
    """
    method = CompensationMethod.of(method)
    if not method.linear:
        if linear is not None:
            raise ValueError(f"method {method.value!r} takes no linear calibration (it computes from the "
                             f"identified geometry alone): give linear to the {' or '.join(LINEAR_METHODS)} "
                             "method only")
        return method
    _require_rotary(geometry, method)
    if payload:
        raise ValueError(f"method {method.value!r} cannot represent a payload: use the exact method")
    if linear is None:
        raise ValueError(f"method {method.value!r} needs the nominal geometry and identified deviations")
    return method


#: Each method's function of (geometry, targets, linear, min_margin, payload), once
#: :func:`_checked_method` has checked them against the method.
_COMPENSATORS: dict[CompensationMethod, Callable[..., np.ndarray]] = {
    CompensationMethod.EXACT: lambda geometry, targets, linear, min_margin, payload: compensate_exact(
        geometry, targets, min_margin=min_margin, payload=payload),
    CompensationMethod.SAVOURE: lambda geometry, targets, linear, min_margin, payload: compensate_savoure(
        geometry, linear, targets, min_margin=min_margin),
    CompensationMethod.BAI: lambda geometry, targets, linear, min_margin, payload: compensate_bai(
        geometry, linear, targets, min_margin=min_margin),
}


def compensate(
    geometry: DeltaGeometry,
    targets: np.ndarray,
    method: str | CompensationMethod = "exact",
    linear: LinearCalibration | None = None,
    min_margin: float = 1.0,
    payload: float = 0.0,
) -> np.ndarray:
    """Joint readings that put the identified robot's TCP at the targets, by a method named at run time.

    The command line's entry (``--method``): :func:`compensate_exact`,
    :func:`compensate_savoure` or :func:`compensate_bai`, once the arguments are checked
    against the method.

    Args:
        geometry: The identified geometry (or a :class:`~deltacal.calibration.Calibration`: its geometry).
        targets: Desired TCP positions in the base frame [mm], shape (N, 3) (or (3,): one target).
        method: ``"exact"``, ``"savoure"`` or ``"bai"`` (or the :class:`CompensationMethod`).
        linear: Nominal geometry, model and deviations (the linear methods' alone, and required by them).
        min_margin: Targets whose readings have a :func:`singularity_margin` below this
            are refused (1: the thresholds MIN_TRANSMISSION_ANGLE, MIN_ROD_CONDITIONING).
        payload: Mass carried at the TCP [kg] (the exact method's alone).

    Returns:
        Readings to command [rad; a printer's: carriage travels, mm], shape (N, 3).

    Raises:
        ValueError: an unknown method, an argument the method does not take (``linear`` with
            the exact method, a payload with a linear one) or lacks (a linear method without
            ``linear``), or targets of another shape (:func:`~deltacal.arguments.points_array`).
        TypeError: a geometry that is neither a geometry nor holds one.
        UnreachableError: naming the targets out of reach or too close to a singularity.
        GeometryError: a linear method asked of a printer (a prismatic chain).
    """
    geometry = geometry_of(geometry)
    method = _checked_method(geometry, method, linear, payload)
    return _COMPENSATORS[method](geometry, points_array(targets, "targets"), linear, min_margin, payload)


def screen(
    geometry: DeltaGeometry,
    targets: np.ndarray,
    method: str | CompensationMethod = "exact",
    linear: LinearCalibration | None = None,
    min_margin: float = 1.0,
) -> None:
    """Refuse early what :func:`compensate` would refuse among the targets the virtual model doubts.

    Cheap (the closed-form virtual kinematics, a few million targets per second) where
    :func:`compensate` is not, so a long file can be screened while it is read. The
    virtual model of ``geometry`` (its perfect-parallelogram view) is not the identified
    robot: it errs by the parallelograms' imperfections and the plate's tilt, so its
    verdict alone could refuse a target the exact solver reaches. It only picks the
    suspects: targets it cannot reach (plate at ``target − tool``), or reaches with a
    :func:`singularity_margin` below ``min_margin``; those alone go through
    :func:`compensate` with the same arguments, whose verdict is the one given. So a
    target is refused here only if :func:`compensate` refuses it; a target the virtual
    model reaches but the robot does not is left to :func:`compensate` itself.

    Raises:
        UnreachableError: as :func:`compensate` would, its indices among ``targets``.
        ValueError, GeometryError: arguments :func:`compensate` refuses, whatever the targets.
    """
    geometry = geometry_of(geometry)
    method = _checked_method(geometry, method, linear, 0.0)
    targets = points_array(targets, "targets")
    virtual = VirtualDelta.from_geometry(geometry)
    x = targets - geometry.tool[None]
    q = virtual.inverse(x, check=False)
    reached = np.all(np.isfinite(q), axis=1)
    suspect = ~reached
    margin = COMMAND_MARGIN.margin(virtual, q[reached], x[reached])  # x exact: q is its inverse
    suspect[reached] = ~(margin >= min_margin)
    if not np.any(suspect):
        return
    idx = np.flatnonzero(suspect)
    try:
        compensate(geometry, targets[idx], method, linear, min_margin)
    except UnreachableError as exc:
        if not exc.indices:
            raise
        bad = np.zeros(targets.shape[0], dtype=bool)
        bad[idx[exc.indices]] = True
        raise UnreachableError.from_mask(bad, targets, exc.reason) from exc


def linear_calibration_from_result(result, tool: np.ndarray | None = None) -> LinearCalibration:
    """The linear compensators' inputs from an IdentificationResult (optionally with another tool [mm])."""
    nominal = result.start if tool is None else result.start.with_tool(tool)
    return LinearCalibration(nominal=nominal, model=get_model(result.model), deviation=result.deviation)
