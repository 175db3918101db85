"""The columns of an identification: one typed record per parameter fitted.

The regressor's columns are, in order, the error model's parameters (``geometry``), six per
station's instrument frame (``frame``, see :mod:`.frames`), three per free plate point
(``point``, see :mod:`.points`) and, when fitted, the three actuators' compliances
(``compliance``, ``c1..c3`` [rad/N m], see :mod:`deltacal.kinematics.statics`). Code tells
them apart by :attr:`Column.kind`, never by name.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

from ..errormodels import ErrorModel
from .frames import FRAME_UNITS, frame_parameter_names
from .points import POINT_PARAMETERS, point_parameter_names

ParameterKind = Literal["geometry", "frame", "point", "compliance"]
GEOMETRY: ParameterKind = "geometry"
FRAME: ParameterKind = "frame"
POINT: ParameterKind = "point"
COMPLIANCE: ParameterKind = "compliance"
#: Names of the compliance parameters, actuator 1 to 3 [rad/N m].
COMPLIANCE_NAMES = ("c1", "c2", "c3")
#: Their unit.
COMPLIANCE_UNIT = "rad/Nm"


@dataclass(frozen=True)
class Column:
    """One parameter fitted.

    Attributes:
        name: Its name (``b1x``, ``T[A].rx``, ``P[smr].z``...).
        kind: ``"geometry"`` (the error model's), ``"frame"`` (a station's instrument frame),
            ``"point"`` (a free plate point's coordinate in the plate frame) or ``"compliance"``
            (an actuator's).
        unit: ``"mm"``, ``"rad"`` or ``"rad/Nm"``.
    """

    name: str
    kind: ParameterKind
    unit: str


@dataclass(frozen=True)
class Columns:
    """The columns of a fit, in the regressor's order.

    Attributes:
        columns: One record per column.
        stations: The stations whose frames are fitted, in order (6 columns each).
        points: The free points, in order (3 columns each).
    """

    columns: tuple[Column, ...]
    stations: tuple[str, ...] = ()
    points: tuple[str, ...] = ()

    @property
    def names(self) -> list[str]:
        """Every column's name."""
        return [c.name for c in self.columns]

    @property
    def units(self) -> list[str]:
        """Every column's unit."""
        return [c.unit for c in self.columns]

    @property
    def n_model(self) -> int:
        """Columns of the error model (first)."""
        return sum(c.kind == GEOMETRY for c in self.columns)

    @property
    def n_fixed(self) -> int:
        """Columns before the free points (the model's and the frames')."""
        return self.n_model + 6 * len(self.stations)

    @property
    def compliance(self) -> bool:
        """Whether the actuators' compliances are fitted (the last three columns)."""
        return any(c.kind == COMPLIANCE for c in self.columns)

    def __len__(self) -> int:
        return len(self.columns)


def build_columns(model: ErrorModel, stations: Sequence[str] = (), points: Sequence[str] = (),
                  compliance: bool = False) -> Columns:
    """The columns of a fit of ``model`` with these stations' frames and free points.

    Args:
        model: The error model (its names and units first).
        stations: Stations whose instrument frames are fitted.
        points: Free plate points.
        compliance: Fit the actuators' compliances (three columns, last).

    Returns:
        The columns.
    """
    columns = [Column(n, GEOMETRY, u) for n, u in zip(model.names, model.units, strict=True)]
    frame_names = frame_parameter_names(list(stations))
    columns += [Column(n, FRAME, u) for n, u in zip(frame_names, FRAME_UNITS * len(stations), strict=True)]
    columns += [Column(n, POINT, "mm") for n in point_parameter_names(points)]
    assert len(columns) == len(model.names) + 6 * len(stations) + len(POINT_PARAMETERS) * len(points)
    if compliance:
        columns += [Column(n, COMPLIANCE, COMPLIANCE_UNIT) for n in COMPLIANCE_NAMES]
    return Columns(tuple(columns), tuple(stations), tuple(points))
