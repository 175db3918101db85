"""Gravity and payload (issue 23): deflections, the two statics, and the elastic calibration's figures.

A mid-size pick-and-place Delta (arms 0.31 m and 0.35 kg, rods 0.82 m and 0.04 kg, plate 0.4 kg)
with compliant actuators. Ground truth: the Pinocchio closed-loop model's statics
(:func:`deltacal.kinematics.statics.multibody_gravity_torque`). Writes ``results/gravity.json``;
docs/tracker.md quotes it. Fixed seeds.
"""

from __future__ import annotations

import argparse
import json
from dataclasses import replace
from pathlib import Path

import numpy as np

from deltacal.compensation import compensate
from deltacal.geometry import Masses, NominalDelta, Tolerances, Workspace
from deltacal.identification import FitOptions, identify
from deltacal.kinematics import exact, statics
from deltacal.simulation import compliant_forward, simulate_measurements

REPO_ROOT = Path(__file__).resolve().parents[1]
NOMINAL = NominalDelta(
    name="midsize", base_radius=160.0, plate_radius=40.0, arm_length=310.0, rod_length=820.0,
    rod_spacing=60.0, limb_azimuth=np.radians([90.0, 210.0, 330.0]), tool=np.array([0.0, 0.0, -80.0]),
    workspace=Workspace(radius=300.0, height=200.0, top_z=-650.0),
    masses=Masses(arm=0.35, rod=0.04, plate=0.4),
)


def workspace_points(n: int, rng: np.random.Generator) -> np.ndarray:
    """Random TCP targets [mm] in the workspace cylinder."""
    ws = NOMINAL.workspace
    assert ws is not None
    r = ws.radius * np.sqrt(rng.uniform(0.0, 1.0, n))
    a = rng.uniform(0.0, 2.0 * np.pi, n)
    return np.stack([r * np.cos(a), r * np.sin(a), rng.uniform(ws.bottom_z, ws.top_z, n)], axis=1)


def deflections(n: int) -> dict:
    """How far own weight and 3 kg move the TCP of the nominal robot with 5e4 N m/rad reducers [µm]."""
    g = replace(NOMINAL.geometry(), compliance=np.full(3, 2e-5))
    q = exact.inverse(g, workspace_points(n, np.random.default_rng(1)))
    rigid = exact.forward(g, q).point(g.tool)
    own = compliant_forward(g, q, 0.0).point(g.tool)
    loaded = compliant_forward(g, q, 3.0).point(g.tool)
    um = lambda a, b: 1e3 * np.linalg.norm(a - b, axis=1)  # noqa: E731
    exact_loaded = compliant_forward(g, q, 3.0, exact.forward).point(g.tool)
    tau_exact = statics.gravity_torque(g, q, 3.0)
    tau_truth = statics.multibody_gravity_torque(g, q, 3.0)
    return {
        "poses": n,
        "own_weight_um": [float(um(own, rigid).min()), float(um(own, rigid).max())],
        "payload_3kg_um": [float(um(loaded, own).min()), float(um(loaded, own).max())],
        "payload_3kg_and_own_weight_um": [float(um(loaded, rigid).min()), float(um(loaded, rigid).max())],
        "torque_3kg_nm": [float(tau_truth.min()), float(tau_truth.max())],
        "torque_relative_difference": float(np.abs(tau_exact - tau_truth).max() / np.abs(tau_truth).max()),
        "equilibrium_tcp_difference_mm": float(np.abs(exact_loaded - loaded).max()),
    }


def calibration(poses: int) -> dict:
    """Rigid and elastic calibrations of a perturbed robot measured at 0 and 3 kg."""
    start = NOMINAL.geometry()
    rng = np.random.default_rng(2023)
    compliance = 2e-5 * rng.uniform(0.8, 1.2, 3)
    truth = replace(start.perturbed(Tolerances.bai2015(), rng), compliance=compliance)
    rigid_truth = replace(truth, compliance=np.zeros(3))
    q = exact.inverse(start, workspace_points(poses, np.random.default_rng(2024)))
    readings, payload = np.vstack([q, q]), np.repeat([0.0, 3.0], poses)
    measured = simulate_measurements(truth, readings, np.random.default_rng(2025), payload=payload)
    rigid_measured = simulate_measurements(rigid_truth, readings, np.random.default_rng(2025),
                                           payload=payload)
    targets = workspace_points(200, np.random.default_rng(2026))

    def error(geometry, robot, load: float, commanded: float) -> float:
        reached = compliant_forward(robot, compensate(geometry, targets, payload=commanded), load)
        return float(1e3 * np.linalg.norm(reached.point(robot.tool) - targets, axis=1).max())

    elastic = identify(start, measured, "complete", options=FitOptions(compliance=True))
    rigid = identify(start, measured, "complete", options=FitOptions(accept_poor_fit=True))
    floor = error(identify(start, rigid_measured, "complete").geometry, rigid_truth, 0.0, 0.0)
    sigma = dict(zip(elastic.base.base_names, elastic.sigma, strict=True))
    unloaded = measured.subset(np.flatnonzero(measured.payload_kg == 0.0))
    one = identify(start, unloaded, "complete", options=FitOptions(compliance=True, accept_poor_fit=True))
    one_sigma = dict(zip(one.base.base_names, one.sigma, strict=True))
    return {
        "poses": poses, "payloads_kg": [0.0, 3.0],
        "true_compliance_rad_per_nm": compliance.tolist(),
        "identified_compliance_rad_per_nm": elastic.geometry.compliance.tolist(),
        "sigma_rad_per_nm": [float(sigma[n]) for n in ("c1", "c2", "c3")],
        "one_payload_sigma_rad_per_nm": [float(one_sigma.get(n, float("nan"))) for n in ("c1", "c2", "c3")],
        "one_payload_not_identifiable": list(one.confounded),
        "variance_factor": {"elastic": float(elastic.variance_factor), "rigid": float(rigid.variance_factor)},
        "rigid_fit_warnings": list(rigid.warnings),
        "validation_targets": len(targets),
        "noise_floor_max_um": floor,
        "elastic_max_um": {"0 kg": error(elastic.geometry, truth, 0.0, 0.0),
                           "3 kg": error(elastic.geometry, truth, 3.0, 3.0)},
        "rigid_max_um": {"0 kg": error(rigid.geometry, truth, 0.0, 0.0),
                         "3 kg": error(rigid.geometry, truth, 3.0, 0.0)},
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=REPO_ROOT / "results")
    args = parser.parse_args()
    out = {"deflections": deflections(400), "calibration": calibration(60)}
    args.out.mkdir(parents=True, exist_ok=True)
    path = args.out / "gravity.json"
    path.write_text(json.dumps(out, indent=2) + "\n")
    print(json.dumps(out, indent=2))
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
