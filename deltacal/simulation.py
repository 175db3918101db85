"""Simulated metrology on a true robot, through the Pinocchio closed-loop model.

The true robot is a :class:`~deltacal.geometry.DeltaGeometry`; its plate poses at
the commanded readings come from :class:`deltacal.kinematics.multibody.DeltaMultibody`
(the ground truth, :func:`ground_truth_forward`). On them:

* a **laser tracker** measures the position of one or several reflectors (named
  plate points or ``tcp``) with independent normal noise of σ per axis; each
  measurement is the mean of ``repeats`` readings (Bai §5: three), so its σ is
  ``σ / sqrt(repeats)``;
* a **6-DoF probe** measures the plate orientation: the measured rotation is
  ``exp([ξ]×) R_true`` with ξ normal of σ_angle per component (base frame), also
  averaged over the repeats;
* **distances** need nothing more: identification forms them from the positions
  (:func:`deltacal.observations.build_rows` with ``distances=True``).

Rows are pose-major: at each pose, one row per reflector, in the order given.
The orientation, measured once per pose, is on the row of the first reflector;
the other rows of the pose have NaN orientation, so identification counts it once.

Units: mm and rad inside; the measurements file is in mm and deg.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .geometry import DeltaGeometry
from .kinematics.exact import PlatePose
from .observations import SIGMA_ANGLE, SIGMA_POSITION, Measurements
from .rotations import rotation_from_vector, vector_from_rotation

#: Forward kinematics of a true robot: (geometry, readings (N, 3) [rad]) -> plate poses.
ForwardKinematics = Callable[[DeltaGeometry, np.ndarray], PlatePose]


def ground_truth_forward(geometry: DeltaGeometry, q: np.ndarray) -> PlatePose:
    """Plate poses of a robot at readings q [rad], by the Pinocchio closed-loop model."""
    from .kinematics.multibody import DeltaMultibody

    return DeltaMultibody(geometry).forward(q)


@dataclass(frozen=True)
class Metrology:
    """The measuring instruments.

    Attributes:
        points: Plate points carrying a reflector (``tcp`` or named points of the robot).
        sigma_position: Tracker noise per axis of one reading [mm].
        sigma_angle: Probe noise per rotation-vector component of one reading [rad].
        orientation: Whether the plate orientation is measured (6-DoF probe).
        repeats: Readings averaged per measurement (σ divided by sqrt(repeats)).
    """

    points: tuple[str, ...] = ("tcp",)
    sigma_position: float = SIGMA_POSITION
    sigma_angle: float = SIGMA_ANGLE
    orientation: bool = True
    repeats: int = 1

    def __post_init__(self) -> None:
        object.__setattr__(self, "points", tuple(self.points))
        if not self.points:
            raise ValueError("at least one measured point is needed")
        if len(set(self.points)) != len(self.points):
            raise ValueError(f"points must differ, got {list(self.points)}")
        for key in ("sigma_position", "sigma_angle"):
            value = getattr(self, key)
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f"{key} must be a finite non-negative number, got {value!r}")
        if int(self.repeats) != self.repeats or self.repeats < 1:
            raise ValueError(f"repeats must be a positive integer, got {self.repeats!r}")

    @property
    def position_noise(self) -> float:
        """σ of a measured (averaged) coordinate [mm]."""
        return self.sigma_position / math.sqrt(self.repeats)

    @property
    def angle_noise(self) -> float:
        """σ of a measured (averaged) orientation component [rad]."""
        return self.sigma_angle / math.sqrt(self.repeats)


def simulate_measurements(
    truth: DeltaGeometry,
    q: np.ndarray,
    rng: np.random.Generator,
    metrology: Metrology | None = None,
    forward: ForwardKinematics | None = None,
) -> Measurements:
    """Measurements of the true robot standing at readings q.

    Args:
        truth: The true robot.
        q: Commanded readings [rad], shape (N, 3).
        rng: Random generator of the noise (pass a seeded one).
        metrology: The instruments (default :class:`Metrology`).
        forward: Forward kinematics of the true robot (default :func:`ground_truth_forward`).

    Returns:
        ``len(points) * N`` measurements, pose-major; rotation vectors NaN where not measured.

    Raises:
        GeometryError: a point the robot does not have.
        AssemblyError: readings at which the true robot cannot be assembled.
    """
    metrology = Metrology() if metrology is None else metrology
    forward = ground_truth_forward if forward is None else forward
    q = np.atleast_2d(np.asarray(q, dtype=float))
    N, k = q.shape[0], len(metrology.points)
    local = np.stack([truth.point(p) for p in metrology.points])  # (k, 3)
    pose = forward(truth, q)
    exact_position = pose.position[:, None, :] + np.einsum("nij,kj->nki", pose.rotation, local)
    position = exact_position + rng.normal(0.0, metrology.position_noise, (N, k, 3))
    rotvec = np.full((N, k, 3), np.nan)
    if metrology.orientation:
        xi = rng.normal(0.0, metrology.angle_noise, (N, 3))
        rotvec[:, 0] = vector_from_rotation(rotation_from_vector(xi) @ pose.rotation)
    return Measurements(
        q=np.repeat(q, k, axis=0),
        position=position.reshape(N * k, 3),
        point=[p for _ in range(N) for p in metrology.points],
        rotation_vector=rotvec.reshape(N * k, 3),
    )


def pose_stations(names: Sequence[str], poses: int, rows_per_pose: int = 1) -> list[str]:
    """The station of each measurement row: consecutive blocks of whole poses, one per station.

    A tracker moved during a session measures a run of poses from each place, and every
    reflector of a pose from the same place. Rows are pose-major, ``rows_per_pose`` per pose
    (as :func:`simulate_measurements` gives them); the poses split as evenly as they can
    among the stations, in the order given.

    Args:
        names: The stations, in the order the tracker stood there.
        poses: Number of poses.
        rows_per_pose: Measurement rows of each pose (the reflectors measured).
    """
    blocks = np.array_split(np.arange(poses), len(names))
    rows = [len(block) * rows_per_pose for block in blocks]
    return [name for name, n in zip(names, rows, strict=True) for _ in range(n)]


# --------------------------------------------------------------------------- command line
def truth_path(output: str | Path) -> Path:
    """Where ``simulate --perturb`` writes the true geometry: ``MEAS.csv`` -> ``MEAS.truth.toml``."""
    output = Path(output)
    stem = output.stem if output.suffix.lower() == ".csv" else output.name
    return output.with_name(f"{stem}.truth.toml")
