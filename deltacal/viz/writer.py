"""Writing objects into a scene: the shared writer of the robot, plate and text objects."""

from __future__ import annotations

from typing import Any

import numpy as np

from ..geometry import (
    DeltaGeometry,
)
from ._meshcat import import_meshcat
from .meshes import (
    TRUE_COLOURS,
    cylinder_between,
    mesh_transform,
    part_material,
    prism_mesh,
    rotation_y_to,
)
from .state import RobotState


class SceneWriter:
    """Sends the robot's objects to a visualizer under the ``deltacal`` node and notes their paths."""

    def __init__(self, vis: Any) -> None:
        self.vis = vis
        self.root = vis["deltacal"]
        self.paths: list[str] = []
        self.g = import_meshcat().geometry

    def object(
        self, path: str, geometry: Any, material: Any = None, transform: np.ndarray | None = None
    ) -> None:
        """Draw ``geometry`` at ``path`` below the ``deltacal`` node (placed by ``transform``, 4x4)."""
        node = self.root[path]
        node.set_object(geometry, material)
        if transform is not None:
            node.set_transform(transform)
        self.paths.append(path)

    def transform(self, path: str, transform: np.ndarray) -> None:
        """Place the node at ``path`` by ``transform`` (4x4, metres)."""
        self.root[path].set_transform(transform)

    def robot(
        self, name: str, geometry: DeltaGeometry, state: RobotState, ghost: bool, plate_shape: np.ndarray
    ) -> None:
        """Draw one robot (a rotary Delta, or a printer: towers, carriages) at the first pose of ``state``."""
        if geometry.chain.on_bed:
            self._towers(name, geometry, ghost)
        else:
            self._arms(name, geometry, ghost)
        self.plate(f"{name}/plate", geometry, ghost, plate_shape)
        self.pose(name, state, 0)

    def _arms(self, name: str, geometry: DeltaGeometry, ghost: bool) -> None:
        """A rotary Delta's base, actuators, arms with their balls, and rods (posed by :meth:`pose`)."""
        g = self.g
        C = TRUE_COLOURS
        b = float(np.mean(np.linalg.norm(geometry.axis_point[:, :2], axis=1)))
        s, fat = drawn_sizes(geometry, ghost)
        ball_r, rod_r, arm_r = 11.0 * s * fat, 4.5 * s * fat, 13.0 * s * fat
        mat = {k: part_material(v, ghost) for k, v in C.items()}
        # base disc above the actuators
        housing_r = 32.0 * s * fat
        base_T = mesh_transform(rotation_y_to(np.array([0.0, 0.0, 1.0])), [0.0, 0.0, 44.0 * s])
        self.object(f"{name}/base", g.Cylinder(16.0 * s, b + 55.0 * s), mat["base"], base_T)
        R0 = geometry.actuator_rotation()
        for i in range(3):
            limb = f"{name}/limb{i + 1}"
            self.object(
                f"{limb}/actuator",
                g.Cylinder(120.0 * s, housing_r),
                mat["actuator"],
                mesh_transform(R0[i], geometry.axis_point[i]),
            )
            elbow = geometry.arm_ball[i].mean(axis=0)
            R, mid, length = cylinder_between(np.zeros(3), elbow)
            self.object(
                f"{limb}/arm/link", g.Cylinder(1.0, arm_r), mat["arm"], mesh_transform(R, mid, (1, length, 1))
            )
            R, mid, length = cylinder_between(geometry.arm_ball[i, 0], geometry.arm_ball[i, 1])
            self.object(
                f"{limb}/arm/elbow",
                g.Cylinder(1.0, 0.55 * arm_r),
                mat["elbow"],
                mesh_transform(R, mid, (1, length, 1)),
            )
            for j in range(2):
                self.object(
                    f"{limb}/arm/ball{j + 1}",
                    g.Sphere(ball_r),
                    mat["ball"],
                    mesh_transform(np.eye(3), geometry.arm_ball[i, j]),
                )
                self.object(f"{limb}/rod{j + 1}", g.Cylinder(1.0, rod_r), mat["rod"])

    def _towers(self, name: str, geometry: DeltaGeometry, ghost: bool) -> None:
        """A printer's frame top, towers, carriages with their balls, and rods (posed by :meth:`pose`).

        The towers run along the axis lines, from the bed up past the endstops.
        """
        g = self.g
        s, fat = drawn_sizes(geometry, ghost)
        mat = {k: part_material(v, ghost) for k, v in TRUE_COLOURS.items()}
        feet, tops = tower_ends(geometry)
        top_z = float(np.max(tops[:, 2]))
        corners = tops[:, :2] + 30.0 * s * geometry.radial[:, :2]  # the frame's corners round the towers
        vertices, faces = prism_mesh(corners[np.argsort(np.arctan2(corners[:, 1], corners[:, 0]))], 16.0 * s)
        self.object(
            f"{name}/top",
            g.TriangularMeshGeometry(vertices, faces),
            mat["base"],
            mesh_transform(np.eye(3), [0.0, 0.0, top_z + 8.0 * s]),
        )
        for i in range(3):
            limb = f"{name}/limb{i + 1}"
            R, mid, length = cylinder_between(feet[i], tops[i])
            self.object(
                f"{limb}/tower",
                g.Cylinder(1.0, 9.0 * s * fat),
                mat["actuator"],
                mesh_transform(R, mid, (1, length, 1)),
            )
            balls = geometry.arm_ball[i]
            depth = float(np.max(np.abs(balls[:, 2] - balls[:, 2].mean())))
            self.object(
                f"{limb}/carriage/body",
                g.Box([26.0 * s * fat, 60.0 * s * fat, 2.0 * depth]),
                mat["arm"],
                mesh_transform(np.eye(3), balls.mean(axis=0)),
            )
            for j in range(2):
                self.object(
                    f"{limb}/carriage/ball{j + 1}",
                    g.Sphere(11.0 * s * fat),
                    mat["ball"],
                    mesh_transform(np.eye(3), balls[j]),
                )
                self.object(f"{limb}/rod{j + 1}", g.Cylinder(1.0, 4.5 * s * fat), mat["rod"])

    def bed(self, geometry: DeltaGeometry) -> np.ndarray:
        """A printer's bed: a thin disc whose top is the plane z = 0; returns points of its rim [mm]."""
        s, _ = drawn_sizes(geometry, False)
        radius = float(np.max(np.linalg.norm(geometry.axis_point[:, :2], axis=1))) + 30.0 * s
        thickness = 6.0 * s
        material = self.g.MeshPhongMaterial(
            color=TRUE_COLOURS["bed"], opacity=0.55, transparent=True, depthWrite=False, shininess=10
        )
        cylinder_T = mesh_transform(rotation_y_to(np.array([0.0, 0.0, 1.0])), [0.0, 0.0, -0.5 * thickness])
        self.object("bed", self.g.Cylinder(thickness, radius), material, cylinder_T)
        ang = np.linspace(0.0, 2.0 * np.pi, 13)
        return np.column_stack([radius * np.cos(ang), radius * np.sin(ang), np.full_like(ang, -thickness)])

    def plate(self, prefix: str, geometry: DeltaGeometry, ghost: bool, plate_shape: np.ndarray) -> None:
        """Draw the plate and what it carries, in the plate frame, under ``prefix``."""
        g = self.g
        s, fat = drawn_sizes(geometry, ghost)
        mat = {k: part_material(v, ghost) for k, v in TRUE_COLOURS.items()}
        vertices, faces = prism_mesh(plate_shape, 12.0 * s)
        self.object(f"{prefix}/body", g.TriangularMeshGeometry(vertices, faces), mat["plate"])
        for i in range(3):
            for j in range(2):
                self.object(
                    f"{prefix}/ball{i + 1}{j + 1}",
                    g.Sphere(11.0 * s * fat),
                    mat["ball"],
                    mesh_transform(np.eye(3), geometry.plate_ball[i, j]),
                )
        axis_len = 2.5 * float(np.max(np.linalg.norm(plate_shape, axis=1)))
        R, mid, length = cylinder_between(np.zeros(3), np.array([0.0, 0.0, -axis_len]))
        self.object(
            f"{prefix}/axis", g.Cylinder(1.0, 4.0 * s * fat), mat["axis"],
            mesh_transform(R, mid, (1, length, 1)),
        )
        if np.linalg.norm(geometry.tool) > 1e-6:
            R, mid, length = cylinder_between(np.zeros(3), geometry.tool)
            self.object(
                f"{prefix}/tool",
                g.Cylinder(1.0, 6.0 * s * fat),
                mat["tool"],
                mesh_transform(R, mid, (1, length, 1)),
            )
        self.object(
            f"{prefix}/tcp", g.Sphere(9.0 * s * fat), mat["tool"], mesh_transform(np.eye(3), geometry.tool)
        )

    def pose(self, name: str, state: RobotState, k: int, frame: Any = None) -> None:
        """Set the moving parts of a robot to pose k (into an animation frame when given)."""
        target = self.root if frame is None else frame["deltacal"]
        part = state.chain.words.part
        for i in range(3):
            limb = f"{name}/limb{i + 1}"
            arm_T = mesh_transform(state.arm_rotation[k, i], state.arm_origin[k, i])
            target[f"{limb}/{part}"].set_transform(arm_T)
            for j in range(2):
                R, mid, length = cylinder_between(state.arm_balls[k, i, j], state.plate_balls[k, i, j])
                if frame is None:
                    target[f"{limb}/rod{j + 1}"].set_transform(mesh_transform(R, mid, (1, length, 1)))
                else:
                    target[f"{limb}/rod{j + 1}"].set_transform(mesh_transform(R, mid))
                    target[f"{limb}/rod{j + 1}"].set_property("scale", "vector3", [1.0, length, 1.0])
        plate = mesh_transform(state.shown_rotation[k], state.plate.position[k])
        target[f"{name}/plate"].set_transform(plate)

    def inset_pose(self, true_state: RobotState, ghost_state: RobotState, k: int, frame: Any = None) -> None:
        """Set the inset's true plate relative to the ghost plate (at the inset's origin)."""
        target = self.root if frame is None else frame["deltacal"]
        offset = true_state.plate.position[k] - ghost_state.plate.position[k]
        target["inset/true"].set_transform(mesh_transform(true_state.shown_rotation[k], offset))


def drawn_sizes(geometry: DeltaGeometry, ghost: bool) -> tuple[float, float]:
    """Size unit of the drawn parts (1: a 375 mm arm, or a printer's 600 mm rods), the ghost's fattening."""
    # the ghost's round parts sheathe the true ones
    return robot_size(geometry) / 375.0, (1.35 if ghost else 1.0)


def robot_size(geometry: DeltaGeometry) -> float:
    """A robot's size [mm]: its arm length, or (a printer) 375/600 of its rod length."""
    return geometry.chain.drawn_scale * geometry.chain.limb_length(geometry.arm_ball, geometry.rod_length)


def tower_ends(geometry: DeltaGeometry) -> tuple[np.ndarray, np.ndarray]:
    """A printer's towers: where each axis line meets the bed (z = 0) and its top above the endstop [mm].

    Returns:
        Feet and tops, each (3, 3).
    """
    w = geometry.axis_direction
    feet = geometry.axis_point - (geometry.axis_point[:, 2] / w[:, 2])[:, None] * w
    above = 0.15 * float(np.mean(geometry.rod_length))
    return feet, geometry.axis_point + above * w


def plate_polygon(geometry: DeltaGeometry) -> np.ndarray:
    """The plate's outline in its frame: the six plate ball centres in xy, by angle [mm], (6, 2)."""
    xy = geometry.plate_ball.reshape(6, 3)[:, :2]
    order = np.argsort(np.arctan2(xy[:, 1], xy[:, 0]))
    return xy[order]
