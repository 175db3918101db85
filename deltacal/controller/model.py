"""A robot controller's own model: the classical Delta with per-limb values (conventions, "Controllers").

Industrial Delta controllers, PLC Delta transforms and printer firmwares take Cartesian targets and
run a perfect-parallelogram model of their own. :class:`Controller` is that model as the
project's conventions fix it: limb i at azimuth ``phi_i`` (``r_i``, ``t_i``), actuator axis through
``b_i r_i`` along ``t_i``, arm of length ``L_i`` (direction ``cos θ r_i − sin θ z``), virtual rod of
length ``l_i`` to the plate point ``p + a_i r_i``, the plate kept parallel to the base, and the
controller's TCP ``tool`` in the plate frame.

Inverse kinematics, exactly as the conventions state it: for a TCP target x, ``p = x − tool``;
``θ_i`` solves ``|b_i r_i + L_i (cos θ_i r_i − sin θ_i z) − (p + a_i r_i)| = l_i``, the solution
with the larger ``cos θ_i`` (knee out); the commanded reading is ``θ_i − o_i``. Forward kinematics:
the intersection of the three spheres of centres ``E_i − a_i r_i`` and radii ``l_i``, the solution
below the base, plus the tool. Both are those of the equivalent :class:`VirtualDelta` (actuator frame
``[r_i t_i z]``, elbow ``(L_i, 0, 0)`` in the arm frame, attachment ``a_i r_i``, encoder offset
``o_i``: the same equations), so the compensation's singularity margin applies to it unchanged.
Readings are returned in [−π, π). Units: mm and rad.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from ..exceptions import GeometryError
from ..geometry import DeltaGeometry, NominalDelta, radial_vectors, tangent_vectors
from ..kinematics.closed_form import VirtualDelta

#: How far a geometry may be from the controller's form to be read as one [mm, rad].
FORM_TOLERANCE = 1e-9

#: Decimals of the lengths read from a geometry [mm] (1e-12 mm: round-off of its projections removed).
LENGTH_DECIMALS = 12

#: The per-limb values, in the order of the controller file's keys (and of the fit's parameters).
LIMB_VALUES = ("limb_azimuth", "base_radius", "plate_radius", "arm_length", "rod_length", "joint_offset")


@dataclass(frozen=True, eq=False)
class Controller:
    """A controller's classical Delta model with per-limb values.

    Attributes:
        limb_azimuth: phi_i [rad], (3,).
        base_radius: b_i, actuator axis to the centre [mm], (3,).
        plate_radius: a_i, plate centre to the virtual rod's end [mm], (3,).
        arm_length: L_i [mm], (3,).
        rod_length: l_i [mm], (3,).
        joint_offset: o_i [rad], (3,): the controller commands reading = θ_i − o_i.
        tool: The controller's TCP in the plate frame [mm], (3,).
        name: A name for the controller (its cell).
    """

    limb_azimuth: np.ndarray
    base_radius: np.ndarray
    plate_radius: np.ndarray
    arm_length: np.ndarray
    rod_length: np.ndarray
    joint_offset: np.ndarray = field(default_factory=lambda: np.zeros(3))
    tool: np.ndarray = field(default_factory=lambda: np.zeros(3))
    name: str = ""

    #: How the controller moves between two targets: a straight line of its model's TCP (the
    #: Cartesian interpolation of industrial controllers, as the G-code route assumes).
    interpolation = "cartesian"
    #: Where a homing puts the TCP: not known for a rotary Delta (its controller's own routine).
    home = None
    #: The limits it puts on its commands: none known (its own cell's).
    limits = None

    def __post_init__(self) -> None:
        for key in (*LIMB_VALUES, "tool"):
            value = np.array(getattr(self, key), dtype=float)
            if value.shape != (3,):
                raise GeometryError(f"{key} must hold 3 values, got shape {value.shape}")
            if not np.all(np.isfinite(value)):
                raise GeometryError(f"{key} must be finite, got {value.tolist()}")
            value.setflags(write=False)
            object.__setattr__(self, key, value)
        for key in ("base_radius", "arm_length", "rod_length"):
            if np.any(getattr(self, key) <= 0.0):
                raise GeometryError(f"{key} must be positive lengths, got {getattr(self, key).tolist()}")
        if np.any(self.plate_radius < 0.0):
            raise GeometryError(f"plate_radius must not be negative, got {self.plate_radius.tolist()}")

    @classmethod
    def from_geometry(cls, geometry: DeltaGeometry | NominalDelta, name: str = "") -> Controller:
        """The controller of a robot built to its model: a nominal robot (all limbs alike, offsets zero).

        Any geometry of the controller's form is accepted (perfect parallelograms, axes along the
        tangents through the radial lines, elbows on the arms' zero direction, plate attachments
        on the radial lines); its encoder offsets become the joint offsets.

        Raises:
            GeometryError: the geometry is not of that form (an identified robot: fit a controller
                to it with :func:`deltacal.controller.fit_controller` instead).
        """
        if isinstance(geometry, NominalDelta):  # its values as written (the geometry's round off 1e-14)
            n = geometry
            values = (n.base_radius, n.plate_radius, n.arm_length, n.rod_length)
            b, a, L, l_rod = (np.full(3, v) for v in values)
            return cls(n.limb_azimuth, b, a, L, l_rod, np.zeros(3), n.tool, name or n.name)
        virtual = VirtualDelta.from_geometry(geometry)
        r = radial_vectors(geometry.limb_azimuth)
        # lengths to LENGTH_DECIMALS: 51.0, not the projection's 51.00000000000001
        b = np.round(np.sum(virtual.axis_point * r, axis=1), LENGTH_DECIMALS)
        a = np.round(np.sum(virtual.plate_attachment * r, axis=1), LENGTH_DECIMALS)
        L, l_rod = (np.round(v, LENGTH_DECIMALS) for v in (virtual.elbow[:, 0], virtual.rod_length))
        built = cls(geometry.limb_azimuth, b, a, L, l_rod, virtual.encoder_offset, geometry.tool).virtual
        off = max(float(np.max(np.abs(getattr(built, k) - getattr(virtual, k))))
                  for k in ("axis_point", "actuator_rotation", "elbow", "plate_attachment"))
        if off > FORM_TOLERANCE or not geometry.is_perfect(FORM_TOLERANCE):
            raise GeometryError(
                f"the geometry {geometry.name or ''!r} is not of a controller's classical form (elements "
                f"off it by up to {off:.3g}, or imperfect parallelograms): fit a controller to it instead")
        return cls(geometry.limb_azimuth, b, a, L, l_rod, virtual.encoder_offset, geometry.tool,
                   name or geometry.name)

    @cached_property
    def virtual(self) -> VirtualDelta:
        """The same model as a :class:`VirtualDelta` (whose equations are the conventions' ones)."""
        r, t = radial_vectors(self.limb_azimuth), tangent_vectors(self.limb_azimuth)
        z = np.broadcast_to([0.0, 0.0, 1.0], (3, 3))
        elbow = np.zeros((3, 3))
        elbow[:, 0] = self.arm_length
        return VirtualDelta(
            axis_point=self.base_radius[:, None] * r,
            actuator_rotation=np.stack([r, t, z], axis=-1),
            encoder_offset=np.array(self.joint_offset),
            elbow=elbow,
            plate_attachment=self.plate_radius[:, None] * r,
            rod_length=np.array(self.rod_length),
        )

    def inverse(self, targets: np.ndarray, check: bool = True) -> np.ndarray:
        """The readings the controller commands for TCP targets [mm], (N, 3) -> (N, 3) [rad].

        Args:
            targets: TCP targets in {O} [mm], (N, 3) or (3,).
            check: Raise UnreachableError for targets out of the model's reach (else NaN rows).
        """
        targets = np.atleast_2d(np.asarray(targets, dtype=float))
        return self.virtual.inverse(targets - self.tool, check=check)

    def forward(self, readings: np.ndarray, check: bool = True) -> np.ndarray:
        """The TCP position the controller's model puts at readings [rad], (N, 3) -> (N, 3) [mm].

        Args:
            readings: Readings [rad], (N, 3) or (3,).
            check: Raise AssemblyError where the model has no assembly (else NaN rows).
        """
        return self.virtual.forward(readings, check=check) + self.tool

    def replace(self, **values) -> Controller:
        """A copy with some values changed (keys of the dataclass)."""
        fields = {k: getattr(self, k) for k in (*LIMB_VALUES, "tool", "name")}
        fields.update(values)
        return Controller(**fields)
