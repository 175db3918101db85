"""Error models of a Delta printer: a linear one's complete (54), its firmware's (13); a rotary one's (54).

The rotary printer's is :class:`RotaryPrinterModel` (``rotary_printer``); the values Klipper's rotary
calibration fits, as its moves: :func:`rotary_firmware_modes`.

``printer``: Savoure's complete model carried over to a prismatic chain (Savoure 2006, Eq. 12-22,
written for the whole family of parallelogram robots): per rod (i, j), in the order (1,1), (1,2),
..., (3,2),

* ``b{i}{j}x, b{i}{j}y, b{i}{j}z`` [mm]: effector ball B_ij in the effector frame; as in Eq. 13 it
  also stands for the opposite move of the tower (its carriage frame's origin P_i);
* ``a{i}{j}x, a{i}{j}y, a{i}{j}z`` [mm]: carriage ball A_ij in the carriage frame (x radial, y up
  the tower, z = −t_i);
* ``l{i}{j}`` [mm]: rod length;

then per tower i: ``lean{i}r``, ``lean{i}t`` [rad], its rotation about r_i and about t_i through
P_i (a positive ``lean{i}t`` moves its top outward); ``endstop{i}`` [mm], the height of its carriage
at the endstop (the carriage frame moved up the tower); and ``scale{i}`` [mm per 100 mm], the
carriage's travel per 100 mm counted in the nominal step distance, minus 100 (a step distance
0.3 % long is 0.3). 7 × 6 + 4 × 3 = 54.

``klipper``: the values Klipper holds (``[printer] delta_radius``; per ``[stepper_*]`` ``angle``,
``arm_length``, ``position_endstop``, and the step distance through ``rotation_distance``), as
moves of the full geometry: the radius moves every tower out along r_i, an angle moves its tower
along t_i by ρ δα, an arm length moves both rods of the tower, an endstop the carriage up. What a
firmware calibration can reach; the rest of the complete model is what it leaves.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from ...chains import PRISMATIC, REVOLUTE
from ...errormodels.base import (
    N_ELEMENTARY,
    ErrorModel,
    ListedParameters,
    actuator_rotation_index,
    arm_ball_index,
    axis_point_index,
    joint_scale_index,
    plate_ball_index,
    rod_index,
)
from ...errormodels.complete import CompleteModel
from ...geometry import DeltaGeometry, Tolerances
from ...kinematics import exact

#: The travel a ``scale{i}`` parameter is given per [mm]: its value is the error over this travel.
SCALE_TRAVEL_MM = 100.0

_TOWERS = "abc"

#: How far the bed may sit from the nominal one, for the prior of a fit: its tilt [rad] and
#: height [mm]. The identified printer is expressed on its true bed, so the bed's tilt is in the
#: towers' leans and its height in the endstops.
BED_TILT = float(np.radians(0.5))
BED_HEIGHT = 10.0


class PrinterModel(ListedParameters, ErrorModel):
    """The complete model of a linear Delta printer (54 parameters)."""

    name = "printer"
    chain = PRISMATIC
    tilts_plate = True
    bed_rise = ("endstop1", "endstop2", "endstop3")

    def __init__(self) -> None:
        names: list[str] = []
        units: list[str] = []
        kinds: list[str] = []  # what bounds each before a measurement (prior_sigma)
        rows: list[list[tuple[int, float]]] = []
        for i in range(3):
            for j in range(2):
                for prefix, index in (("b", plate_ball_index), ("a", arm_ball_index)):
                    for k, axis in enumerate("xyz"):
                        names.append(f"{prefix}{i + 1}{j + 1}{axis}")
                        rows.append([(index(i, j, k), 1.0)])
                        kinds.append("tower" if prefix == "b" and k < 2 else "ball")
                names.append(f"l{i + 1}{j + 1}")
                rows.append([(rod_index(i, j), 1.0)])
                units += ["mm"] * 7
                kinds.append("rod")
        for i in range(3):
            names += [f"lean{i + 1}r", f"lean{i + 1}t", f"endstop{i + 1}", f"scale{i + 1}"]
            units += ["rad", "rad", "mm", "mm"]
            kinds += ["lean", "lean", "endstop", "scale"]
            # the carriage frame is [r_i, z, −t_i]: a rotation about t_i is minus one about its z0
            rows += [[(actuator_rotation_index(i, 0), 1.0)], [(actuator_rotation_index(i, 2), -1.0)],
                     [(actuator_rotation_index(i, 1), -1.0)],  # up the tower: less travel below it
                     [(joint_scale_index(i), 1.0 / SCALE_TRAVEL_MM)]]
        M = np.zeros((N_ELEMENTARY, len(names)))
        for col, row in enumerate(rows):
            for move, value in row:
                M[move, col] = value
        self._names, self._units, self._kinds, self._moves = names, units, kinds, M
        # regroupings keep what a printer's user adjusts: endstops, scales, leans, rods, then balls
        self.preferred = (
            [f"endstop{i}" for i in range(1, 4)] + [f"scale{i}" for i in range(1, 4)]
            + [f"lean{i}{a}" for a in "rt" for i in range(1, 4)]
            + [f"l{i}{j}" for i in range(1, 4) for j in (1, 2)]
            + [f"b{i}{j}{a}" for i in range(1, 4) for j in (1, 2) for a in "xyz"]
            + [f"a{i}{j}{a}" for i in range(1, 4) for j in (1, 2) for a in "xyz"]
        )

    def moves(self, geometry: DeltaGeometry) -> np.ndarray:
        """Each parameter is one elementary move (a constant matrix)."""
        return self._moves

    @staticmethod
    def kit_tolerances() -> Tolerances:
        """The build tolerances its fit takes (a linear printer kit's: :meth:`Tolerances.printer_kit`)."""
        return Tolerances.printer_kit()

    def prior_sigma(self, tolerances: Tolerances) -> np.ndarray:
        """σ of each parameter before any measurement, from the build tolerances (n,).

        An effector ball's x and y also carry its tower's position (Eq. 13); a lean and an endstop
        also carry the bed's tilt and height (:data:`BED_TILT`, :data:`BED_HEIGHT`).
        """
        return self._sigma(tolerances, BED_TILT, BED_HEIGHT)

    def _sigma(self, tolerances: Tolerances, bed_tilt: float, bed_height: float) -> np.ndarray:
        tower = float(np.hypot(tolerances.ball_centre, tolerances.axis_position))
        sigma = {"tower": tower, "ball": tolerances.ball_centre, "rod": tolerances.rod_length,
                 "lean": float(np.hypot(tolerances.axis_direction, bed_tilt)),
                 "endstop": float(np.hypot(tolerances.encoder_offset, bed_height)),
                 "scale": SCALE_TRAVEL_MM * tolerances.joint_scale}
        return np.array([sigma[kind] for kind in self._kinds])

    def prior_factor(self, tolerances: Tolerances, geometry: DeltaGeometry,
                     calibrated: bool | Sequence[str] = False) -> np.ndarray:
        """P with ``Σ = P Pᵀ``: the build tolerances, the bed's place and the firmware's calibrated values.

        Where the bed sits is free (:data:`BED_TILT`, :data:`BED_HEIGHT`), but a bed tilted moves the
        whole printer rigidly against it, and a bed raised or lowered moves every endstop alike:
        those modes (:func:`bed_modes`) take the bed's prior; each tower's own lean and endstop keep
        their build tolerance (a tower leaning alone is a build error of a tenth of a degree, not the
        half degree a bed may be tilted by). When the start is the firmware's values ``calibrated``
        from the very measurements identified (a saved ``DELTA_CALIBRATE``), the values its own
        calibration fits (:data:`FIRMWARE_VALUES`, :func:`firmware_modes`) take wide priors
        (:data:`FIRMWARE_FREE`): a prior centred on them along their own directions would tell the
        evidence only that the data agree with it (the tolerances' scale would collapse).
        ``calibrated``: True for all of them, or the names of those the firmware fitted
        (:func:`calibrated_values`: Klipper's basic calibration leaves the arms as configured).
        """
        diagonal = self._sigma(tolerances, 0.0, 0.0)
        modes = bed_modes(self, geometry) * np.array([BED_TILT, BED_TILT, BED_HEIGHT])
        cov = np.diag(diagonal**2) + modes @ modes.T
        names = FIRMWARE_VALUES if calibrated is True else tuple(calibrated or ())
        if names:
            kept = [FIRMWARE_VALUES.index(n) for n in names]
            firmware = firmware_modes(self, geometry)[:, kept] * np.array(FIRMWARE_FREE)[kept]
            cov = cov + firmware @ firmware.T
        return np.linalg.cholesky(cov)


class FirmwareErrorModel(ListedParameters, ErrorModel):
    """Klipper's values as deviations of a printer's full geometry (13 parameters)."""

    name = "klipper"
    chain = PRISMATIC
    tilts_plate = False

    def __init__(self) -> None:
        self._names = (["delta_radius"] + [f"angle_{t}" for t in _TOWERS]
                       + [f"arm_length_{t}" for t in _TOWERS]
                       + [f"endstop_{t}" for t in _TOWERS] + [f"scale_{t}" for t in _TOWERS])
        self._units = ["mm", "rad", "rad", "rad"] + ["mm"] * 9

    def moves(self, geometry: DeltaGeometry) -> np.ndarray:
        """M(g): the towers moved out and along, the rods of a tower together, endstops, scales."""
        M = np.zeros((N_ELEMENTARY, len(self._names)))
        r, t = geometry.radial, geometry.tangent
        centre = geometry.axis_point[:, :2].mean(axis=0)
        reach = np.linalg.norm(geometry.axis_point[:, :2] - centre, axis=1) - np.linalg.norm(
            geometry.plate_ball.mean(axis=1)[:, :2], axis=1)  # ρ: tower minus effector radius
        for i in range(3):
            for k in range(3):
                M[axis_point_index(i, k), 0] = r[i, k]
                M[axis_point_index(i, k), 1 + i] = reach[i] * t[i, k]
            M[rod_index(i, 0), 4 + i] = M[rod_index(i, 1), 4 + i] = 1.0
            M[actuator_rotation_index(i, 1), 7 + i] = -1.0
            M[joint_scale_index(i), 10 + i] = 1.0 / SCALE_TRAVEL_MM
        return M

    def prior_sigma(self, tolerances: Tolerances) -> np.ndarray:
        """σ of each value before any measurement, from the build tolerances (n,)."""
        radius = float(np.hypot(tolerances.ball_centre, tolerances.axis_position))
        angle = radius / 100.0  # a tower's tangential place over a delta radius of about 100 mm
        return np.array([radius] + [angle] * 3 + [tolerances.rod_length] * 3
                        + [float(np.hypot(tolerances.encoder_offset, BED_HEIGHT))] * 3
                        + [SCALE_TRAVEL_MM * tolerances.joint_scale] * 3)


def _readings(geometry: DeltaGeometry) -> np.ndarray:
    """Readings of two rings of points, on the bed and half a tower's reach above it [mm], (24, 3)."""
    reach = float(np.mean(np.linalg.norm(geometry.axis_point[:, :2], axis=1)))
    angle = np.linspace(0.0, 2.0 * np.pi, 12, endpoint=False)
    ring = 0.4 * reach * np.column_stack([np.cos(angle), np.sin(angle), np.zeros(12)])
    return exact.inverse(geometry, np.concatenate([ring, ring + [0.0, 0.0, 0.5 * reach]]))


def bed_modes(model: ErrorModel, geometry: DeltaGeometry) -> np.ndarray:
    """The parameters that move a printer rigidly against its bed: tilted about x, about y, raised, (n, 3).

    Per unit: a turn of 1 rad about the x and the y axis through the bed's centre, a rise of 1 mm.
    Each is the least-squares parameters whose plate displacement
    (:meth:`~deltacal.errormodels.ErrorModel.sensitivity`) is the rigid motion's (``(ω × p, ω)`` for
    a turn, ``(z, 0)`` for the rise) at the readings of two rings of points, on the bed and half an
    axis' reach above it (the model holds a rigid motion of the whole printer: its towers or shoulders
    lean and move, its balls stay); but the rise of a model whose ``bed_rise`` parameters raise it (a
    linear printer's endstops) is those alike.
    """
    q = _readings(geometry)
    pose = exact.forward(geometry, q)
    S = model.sensitivity(geometry, q, pose).reshape(-1, model.size)
    motions = [np.concatenate([np.cross(omega, pose.position), np.broadcast_to(omega, pose.position.shape)],
                              axis=1) for omega in np.eye(3)[:2]]
    if not model.bed_rise:
        motions.append(np.broadcast_to([0.0, 0.0, 1.0, 0.0, 0.0, 0.0], pose.position.shape[:1] + (6,)))
    modes = np.zeros((model.size, 3))
    for k, motion in enumerate(motions):
        modes[:, k] = np.linalg.lstsq(S, motion.reshape(-1), rcond=None)[0]
    if model.bed_rise:
        modes[[model.names.index(name) for name in model.bed_rise], 2] = 1.0
    return modes


#: The firmware's own calibrated values (Klipper's ``DELTA_CALIBRATE`` + ``DELTA_ANALYZE``, Marlin's
#: ``G33``, RepRapFirmware's ``G32``: a radius, two towers' angles, the arms, the endstops), as
#: :class:`FirmwareErrorModel`'s names, and their priors' σ in a printer's fit [mm, rad]: wide, since the
#: firmware fits them to the very measurements the printer's fit takes (a prior centred on values
#: fitted to the same data would tell nothing of the tolerances but that the data agree with it).
FIRMWARE_VALUES = ("delta_radius", "angle_a", "angle_b", "arm_length_a", "arm_length_b", "arm_length_c",
                   "endstop_a", "endstop_b", "endstop_c")
FIRMWARE_FREE = (1.0, 0.005, 0.005, 1.0, 1.0, 1.0, 10.0, 10.0, 10.0)
#: What a firmware's calibration from probe heights alone fits (Klipper's basic ``DELTA_CALIBRATE``:
#: ``coordinate_descent_params`` without the arms, which only ``DELTA_ANALYZE``'s distances add).
HEIGHTS_VALUES = ("delta_radius", "angle_a", "angle_b", "endstop_a", "endstop_b", "endstop_c")


def calibrated_values(calibrated: bool, distances: int, model: ErrorModel | None = None) -> tuple[str, ...]:
    """The firmware values a start ``calibrated`` from measurements with ``distances`` distances fitted.

    None when not calibrated; with distances, :data:`FIRMWARE_VALUES` (Klipper's extended calibration);
    from heights alone, :data:`HEIGHTS_VALUES`: the arms keep their build tolerance's prior (7 heights
    cannot tell 9 wide values apart: the endstops' σ was ±2.6 mm, the bed's height known nowhere).
    A model that says what its printer's firmware fits (``firmware_calibrates``: with distances, from
    heights alone) gives its own: a rotary printer's :data:`ROTARY_VALUES`, :data:`ROTARY_HEIGHTS_VALUES`.
    """
    if not calibrated:
        return ()
    extended, heights = getattr(model, "firmware_calibrates", (FIRMWARE_VALUES, HEIGHTS_VALUES))
    return tuple(extended if distances else heights)


def firmware_modes(model: ErrorModel, geometry: DeltaGeometry) -> np.ndarray:
    """The parameters that move the printer as each of the firmware's own calibrated values does, (n, 9).

    Per unit of each of :data:`FIRMWARE_VALUES`: the least-squares parameters whose plate
    displacement is that value's (:class:`FirmwareErrorModel`'s sensitivity) at the readings of
    :func:`bed_modes`.
    """
    firmware = FirmwareErrorModel()
    q = _readings(geometry)
    pose = exact.forward(geometry, q)
    S = model.sensitivity(geometry, q, pose).reshape(-1, model.size)
    F = firmware.sensitivity(geometry, q, pose)[:, :, [firmware.names.index(n) for n in FIRMWARE_VALUES]]
    return np.linalg.lstsq(S, F.reshape(-1, len(FIRMWARE_VALUES)), rcond=None)[0]


#: The turn a rotary printer's ``scale{i}`` parameter is given per [rad]: its value is the error over it.
SCALE_TURN_RAD = float(np.radians(100.0))

#: What Klipper's rotary ``DELTA_CALIBRATE`` fits (``RotaryDeltaCalibration.coordinate_descent_params``):
#: the basic method's shoulder height and endstops, the extended's shoulder radius and arms A and B's
#: angles too [mm, mm, mm, mm, mm, rad, rad]; and their priors' σ in a rotary printer's fit, wide as a
#: linear printer's (:data:`FIRMWARE_FREE`: Klipper fitted them to the very measurements the fit takes).
ROTARY_VALUES = ("shoulder_height", "endstop_a", "endstop_b", "endstop_c", "shoulder_radius", "angle_a",
                 "angle_b")
ROTARY_FREE = (10.0, 10.0, 10.0, 10.0, 1.0, 0.005, 0.005)
#: What the basic method fits (probe heights alone).
ROTARY_HEIGHTS_VALUES = ROTARY_VALUES[:4]
#: The step of the finite differences of :func:`rotary_firmware_modes` [mm, rad].
_ROTARY_STEP = 1e-5


def _rotary_value_moved(geometry: DeltaGeometry, name: str, step: float) -> DeltaGeometry:
    """A rotary printer with one of :data:`ROTARY_VALUES` changed by ``step`` as Klipper's model changes it.

    The shoulders raised (``shoulder_height``) or moved out along their radial (``shoulder_radius``); an
    arm and its effector balls turned about the vertical through the centre (``angle_a``); an arm's
    endstop angle (its encoder offset) turned as a nozzle at the bed's centre, half a shoulder's reach up,
    rises by ``step`` [mm] with that arm alone (``endstop_a``: Klipper's ``position_endstop``).
    """
    axis = np.array(geometry.axis_point, dtype=float)
    if name == "shoulder_height":
        axis[:, 2] += step
        return replace(geometry, axis_point=axis)
    if name == "shoulder_radius":
        return replace(geometry, axis_point=axis + step * geometry.radial)
    i = _TOWERS.index(name[-1])
    if name.startswith("angle"):
        c, s = np.cos(step), np.sin(step)
        turn = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        azimuth, direction = np.array(geometry.limb_azimuth, dtype=float), np.array(geometry.axis_direction)
        plate = np.array(geometry.plate_ball, dtype=float)
        azimuth[i] += step
        axis[i], direction[i], plate[i] = turn @ axis[i], turn @ direction[i], plate[i] @ turn.T
        return replace(geometry, limb_azimuth=azimuth, axis_point=axis, axis_direction=direction,
                       plate_ball=plate)
    reach = float(np.mean(np.linalg.norm(geometry.axis_point[:, :2], axis=1)))
    centre = np.array([[0.0, 0.0, 0.5 * reach], [0.0, 0.0, 0.5 * reach + 1.0]])
    rate = np.diff(exact.inverse(geometry, centre), axis=0)[0, i]  # the arm's turn per mm of the nozzle
    offset = np.array(geometry.encoder_offset, dtype=float)
    offset[i] -= rate * step
    return replace(geometry, encoder_offset=offset)


def rotary_firmware_modes(model: ErrorModel, geometry: DeltaGeometry) -> np.ndarray:
    """The parameters that move a rotary printer as each of Klipper's rotary calibrated values does, (n, 7).

    Per unit of each of :data:`ROTARY_VALUES`: the least-squares parameters whose plate displacement
    (:meth:`~deltacal.errormodels.ErrorModel.sensitivity`) is that value's at the readings of
    :func:`bed_modes` (central differences of the exact kinematics, the printer changed as Klipper's
    model changes with the value: :func:`_rotary_value_moved`).
    """
    q = _readings(geometry)
    pose = exact.forward(geometry, q)
    S = model.sensitivity(geometry, q, pose).reshape(-1, model.size)
    F = np.zeros((len(q), 6, len(ROTARY_VALUES)))
    for k, name in enumerate(ROTARY_VALUES):
        up = exact.forward(_rotary_value_moved(geometry, name, _ROTARY_STEP), q, start=pose)
        down = exact.forward(_rotary_value_moved(geometry, name, -_ROTARY_STEP), q, start=pose)
        turn = np.einsum("nij,nkj->nik", up.rotation, down.rotation)  # R+ R-ᵀ
        F[:, :3, k] = (up.position - down.position) / (2.0 * _ROTARY_STEP)
        F[:, 3:, k] = 0.5 * np.stack([turn[:, 2, 1] - turn[:, 1, 2], turn[:, 0, 2] - turn[:, 2, 0],
                                      turn[:, 1, 0] - turn[:, 0, 1]], axis=1) / (2.0 * _ROTARY_STEP)
    return np.linalg.lstsq(S, F.reshape(-1, len(ROTARY_VALUES)), rcond=None)[0]


class RotaryPrinterModel(ListedParameters, ErrorModel):
    """The complete model of a rotary Delta printer (54 parameters): Savoure's 51 and each arm's step scale.

    The revolute chain's complete model (:class:`~deltacal.errormodels.complete.CompleteModel`: per rod
    its balls and length; per arm ``beta{i}r``, ``beta{i}t``, ``beta{i}z``, its shoulder frame turned
    about the arm's zero direction, about the shoulder axis (the arm's angle at its endstop: the
    encoder offset) and about up [rad]), then per arm ``scale{i}`` [rad]: the arm's true turn over
    :data:`SCALE_TURN_RAD` (100 deg) counted in the nominal step angle, minus that turn (a step angle
    0.2 % large, a gear ratio 0.2 % small, is 0.2 deg: as a linear printer's ``scale{i}`` is per 100 mm).
    The printer is in Klipper's frame, the bed's: its tilt and height are
    the whole printer moved rigidly against it (:func:`bed_modes`, least squares: no parameter
    raises a rotary printer alone).
    """

    name = "rotary_printer"
    chain = REVOLUTE
    tilts_plate = True
    #: What Klipper's rotary calibration fits: with distances (extended), from heights alone (basic).
    firmware_calibrates = (ROTARY_VALUES, ROTARY_HEIGHTS_VALUES)

    def __init__(self) -> None:
        self._complete = CompleteModel()
        names = self._complete.names + [f"scale{i}" for i in range(1, 4)]
        # what bounds each before a measurement (prior_sigma): b, a, l by their first letter
        self._kinds = [("endstop" if n[-1] == "t" else "tilt") if n.startswith("beta") else
                       "scale" if n.startswith("scale") else n[0] for n in names]
        self._names, self._units = names, self._complete.units + ["rad"] * 3
        # an owner adjusts the endstops, the gear ratios, the shoulders' tilts, then rods and balls
        self.preferred = ([f"beta{i}t" for i in range(1, 4)] + [f"scale{i}" for i in range(1, 4)]
                          + [f"beta{i}{a}" for a in "rz" for i in range(1, 4)]
                          + [f"l{i}{j}" for i in range(1, 4) for j in (1, 2)]
                          + [f"b{i}{j}{a}" for i in range(1, 4) for j in (1, 2) for a in "xyz"]
                          + [f"a{i}{j}{a}" for i in range(1, 4) for j in (1, 2) for a in "xyz"])
        self.frame_held_first = self._complete.frame_held_first

    def moves(self, geometry: DeltaGeometry) -> np.ndarray:
        """Each parameter is one elementary move (a constant matrix): the complete model's, the scales."""
        scales = np.zeros((N_ELEMENTARY, 3))
        scales[[joint_scale_index(i) for i in range(3)], range(3)] = 1.0 / SCALE_TURN_RAD
        return np.hstack([self._complete.moves(geometry), scales])

    @staticmethod
    def kit_tolerances() -> Tolerances:
        """Its fit's build tolerances (a rotary kit's: :meth:`Tolerances.rotary_printer_kit`)."""
        return Tolerances.rotary_printer_kit()

    def prior_sigma(self, tolerances: Tolerances) -> np.ndarray:
        """σ of each parameter from the build tolerances alone (n,); the bed's place: :meth:`prior_factor`.

        An effector ball also carries its shoulder's position (Savoure's Eq. 13: every coordinate).
        """
        sigma = {"b": float(np.hypot(tolerances.ball_centre, tolerances.axis_position)),
                 "a": tolerances.ball_centre, "l": tolerances.rod_length, "tilt": tolerances.axis_direction,
                 "endstop": tolerances.encoder_offset, "scale": SCALE_TURN_RAD * tolerances.joint_scale}
        return np.array([sigma[kind] for kind in self._kinds])

    def prior_factor(self, tolerances: Tolerances, geometry: DeltaGeometry,
                     calibrated: bool | Sequence[str] = False) -> np.ndarray:
        """P with ``Σ = P Pᵀ``: the build tolerances, the bed's place, Klipper's calibrated values.

        The bed's tilt and height (:data:`BED_TILT`, :data:`BED_HEIGHT`) are the printer moved rigidly
        against it (:func:`bed_modes`). When the start is Klipper's values ``calibrated`` from the very
        measurements identified (a saved rotary ``DELTA_CALIBRATE``), the values its calibration fitted
        take wide priors (:data:`ROTARY_FREE`) along their own moves (:func:`rotary_firmware_modes`), as
        a linear printer's (:meth:`PrinterModel.prior_factor`). ``calibrated``: True for all of
        :data:`ROTARY_VALUES`, or the names of those fitted (the basic method's
        :data:`ROTARY_HEIGHTS_VALUES`).

        Raises:
            ValueError: a name that is not one of :data:`ROTARY_VALUES`.
        """
        modes = bed_modes(self, geometry) * np.array([BED_TILT, BED_TILT, BED_HEIGHT])
        cov = np.diag(self.prior_sigma(tolerances) ** 2) + modes @ modes.T
        names = ROTARY_VALUES if calibrated is True else tuple(calibrated or ())
        unknown = [n for n in names if n not in ROTARY_VALUES]
        if unknown:
            raise ValueError(f"not a value of Klipper's rotary calibration: {', '.join(unknown)}")
        if names:
            kept = [ROTARY_VALUES.index(n) for n in names]
            firmware = rotary_firmware_modes(self, geometry)[:, kept] * np.array(ROTARY_FREE)[kept]
            cov = cov + firmware @ firmware.T
        return np.linalg.cholesky(cov)


def kit_tolerances(model: ErrorModel) -> Tolerances:
    """The build tolerances a printer's fit takes unless told others: its model's kit.

    A rotary printer's model: a rotary kit's (:meth:`Tolerances.rotary_printer_kit`); a linear
    printer's, and any other model a printer's fit is given: a linear printer kit's
    (:meth:`Tolerances.printer_kit`, as the fit always took).
    """
    if isinstance(model, PrinterModel | RotaryPrinterModel):
        return model.kit_tolerances()
    return Tolerances.printer_kit()
