"""Reproduce Bai et al. 2015: calibration of a Delta robot from distance measurements.

On the prototype of ``models/bai2015.toml`` (Bai Table 1):

1. Identifiability (§3.2): rank of the distance regressor of model 18 (one
   reflector, Eq. 11 gauge) and of model 36 (two reflectors), the four parameters
   of model 36 that distances cannot see, and the null space of model 36 written
   on Bai's choice of the four (Eq. 19).
2. The κ(n) rule (§3.3, Eq. 21, Fig. 6-7) for the rough step (encoder offsets,
   middle circle), model 18 and model 32, with ε0 = 1 %.
3. Bai's two-step procedure (§4.2, §5) on a simulated robot: the nominal robot
   perturbed with :meth:`Tolerances.bai2015` (fixed seed) with Table 2's encoder
   offsets imposed, measured by a simulated laser tracker (σ 0.005 mm per axis,
   three readings averaged) through the Pinocchio closed-loop model. Step 1
   (rough): encoder offsets from the distances of the centre and the middle
   circle, identified and compensated until they converge (Table 2). Step 2
   (fine): model 18 (one reflector) and model 32 (two reflectors) identified once
   from distances, compensated with Bai's linear compensator (Eq. 23, 25) and
   with the exact one; accuracy over Bai's 96 validation poses plus home
   (Table 5). For comparison, the same robot identified in one iterated call
   (models bai42 and complete) from the fine step's distances, exact compensation.

Sign convention: Bai's Δθ_i turns about w0 = −t_i, this project's encoder offset
about t_i, so Bai's Δθ_i = −encoder_offset[i].

Writes ``bai2015.json``, ``bai2015_fig6.png`` (κ(n), rough step) and
``bai2015_fig7.png`` (κ(n), models 18 and 32) into ``--out`` and prints the tables.
"""

from __future__ import annotations

import argparse
import json
import math
import time
import zlib
from dataclasses import dataclass, replace
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from deltacal import DeltaGeometry, NominalDelta, Tolerances  # noqa: E402
from deltacal.compensation import LinearCalibration, compensate  # noqa: E402
from deltacal.errormodels import MODEL32_REMOVED, get_model  # noqa: E402
from deltacal.identifiability import base_parameters  # noqa: E402
from deltacal.identification import IdentificationResult, identify  # noqa: E402
from deltacal.io import load_nominal
from deltacal.observations import Measurements  # noqa: E402
from deltacal.planning import (  # noqa: E402
    ConditionCurve,
    PoseSet,
    bai_poses,
    condition_curve,
    identification_matrix,
    planning_model,
    rough_poses,
)
from deltacal.simulation import Metrology, simulate_measurements  # noqa: E402
from deltacal.validation import ValidationMetrics, metrics_from_positions, validation_poses  # noqa: E402

REPO_ROOT = Path(__file__).resolve().parents[1]
DEFAULT_OUT = REPO_ROOT / "results"
ROBOT_FILE = REPO_ROOT / "deltacal" / "models" / "bai2015.toml"
#: Seed of the true robot's manufacturing errors.
ROBOT_SEED = 2015
#: Seed of the tracker noise (each stage draws from its own child stream).
NOISE_SEED = 230
#: Bai's ε0 of Eq. 21 (1 %).
EPSILON0 = 0.01
#: Largest n of the κ(n) curves.
N_MAX = 20
#: Reflectors (named points of the robot file): P of Bai Fig. 5a, and the off-axis one of Fig. 5b.
POINT = "smr_centre"
SECOND_POINT = "smr_offset"
#: Tracker (Bai §5: LEICA AT901-LR, 0.005 mm; three readings averaged).
TRACKER = Metrology(points=(POINT,), sigma_position=0.005, orientation=False, repeats=3)
#: Rough step: converged when every offset moves by less than this [deg]; iterations at most.
ROUGH_THRESHOLD_DEG = 0.002
ROUGH_MAX_ITER = 10
#: Azimuths of the first pose of each circle tried for the sensitivity of the κ(n) rule [deg].
PHASES_DEG = (0.0, 15.0, 30.0, 45.0, 60.0, 90.0)

#: Bai 2015, Table 2: converged encoder offsets Δθ_i [deg] (about w0 = −t_i).
TABLE2_OFFSETS_DEG = (0.911, 1.098, 1.441)
#: The paper's numbers (Bai 2015, §5, Tables 2 and 5, Fig. 6-7), copied here.
PAPER = {
    "rank_model18": 18,
    "rank_model36": 32,
    "unidentifiable_model36": list(MODEL32_REMOVED),
    "n_selected": {"rough": 5, "model18": 7, "model32": 9},
    "table2": {
        "before": {
            "drho": [-3.405, -3.859, -2.863, -4.181, -2.663],
            "dv": [3.769, 3.888, 3.163, 4.962, 2.975],
        },
        "after": {
            "drho": [0.025, -0.061, 0.008, 0.187, -0.011],
            "dv": [0.309, 1.015, 0.961, 0.859, 1.047],
        },
    },
    "encoder_offsets_deg": list(TABLE2_OFFSETS_DEG),
    "table5": {
        "A": {"drho": 5.704, "dv": 6.361},
        "B": {"drho": 0.682, "dv": 1.303},
        "C18": {"drho": 0.167, "dv": 0.386},
        "C32": {"drho": 0.134, "dv": 0.371},
    },
}
#: Curves of the κ(n) rule: key, model, reflectors, title.
CURVES = (
    ("rough", "rough", (POINT,), "rough step (encoder offsets), centre + middle circle"),
    ("model18", "bai18", (POINT,), "model 18, one reflector"),
    ("model32", "bai32", (POINT, SECOND_POINT), "model 32, two reflectors"),
)


# --------------------------------------------------------------------------- identifiability
def identifiability(nominal: NominalDelta, n: int) -> dict[str, object]:
    """Ranks of models 18 and 36 from distances at Bai's 2n + 1 poses, and model 36's deficiency.

    The four unidentifiable parameters are those the column-scaled pivoted QR
    drops. Any four are a valid choice if the remaining 32 columns have full rank,
    i.e. if the 4 x 4 block of the null space on them is invertible; Bai's choice
    is checked that way and by an unpivoted QR that keeps every other parameter
    first. The null space is printed normalised on Bai's four (Eq. 19).
    """
    geometry = nominal.geometry()
    q = bai_poses(nominal, n).q
    two = [POINT, SECOND_POINT]
    m18, m36 = get_model("bai18"), get_model("bai36")
    H18 = identification_matrix(geometry, m18, q, "distance", [POINT])
    H36 = identification_matrix(geometry, m36, q, "distance", two)
    H36_one = identification_matrix(geometry, m36, q, "distance", [POINT])
    H36_centre = identification_matrix(geometry, m36, q, "distance", ["tcp"])
    b18 = base_parameters(H18, m18.names)
    b36 = base_parameters(H36, m36.names)
    b36_one = base_parameters(H36_one, m36.names)
    names = m36.names
    bai_order = [k for k in names if k not in MODEL32_REMOVED] + list(MODEL32_REMOVED)
    b36_bai = base_parameters(H36, names, prefer=bai_order)

    scale = np.linalg.norm(H36, axis=0)
    _, sv, Vt = np.linalg.svd(H36 / scale, full_matrices=False)
    deficiency = len(names) - b36.rank
    null = Vt[len(names) - deficiency :].T / scale[:, None]  # physical units, (36, 4)
    bai_index = [names.index(k) for k in MODEL32_REMOVED]
    block = null[bai_index]
    relations = {}
    if deficiency == len(MODEL32_REMOVED) and np.linalg.cond(block) < 1e8:
        normalised = null @ np.linalg.inv(block)
        for k, name in enumerate(MODEL32_REMOVED):
            col = normalised[:, k]
            keep = np.abs(col) > 1e-6 * np.abs(col).max()
            relations[name] = {names[j]: float(col[j]) for j in np.flatnonzero(keep)}
    involved = np.abs(null).max(axis=1) > 1e-8 * np.abs(null).max()
    nominal_e = nominal.base_radius - nominal.plate_radius
    return {
        "n": n,
        "distances_model18": int(H18.shape[0]),
        "distances_model36": int(H36.shape[0]),
        "rank_model18": b18.rank,
        "rank_model36": b36.rank,
        "rank_model36_one_reflector": b36_one.rank,
        "rank_model36_plate_centre": base_parameters(H36_centre, m36.names).rank,
        "unidentifiable_model36": b36.unidentifiable_names,
        "bai_choice": list(MODEL32_REMOVED),
        "bai_choice_valid": bool(b36_bai.unidentifiable_names == sorted(MODEL32_REMOVED, key=names.index)),
        "bai_choice_null_block_condition": float(np.linalg.cond(block)),
        "qr_choice_null_block_condition": float(np.linalg.cond(null[b36.unidentifiable])),
        "null_space_parameters": [names[j] for j in np.flatnonzero(involved)],
        "null_space_on_bai_choice": relations,
        "La_over_e_mm": nominal.arm_length * nominal.plate_radius / nominal_e,
        "relative_singular_values_model36": [float(s / sv[0]) for s in sv[-6:]],
        "condition_model36_two_reflectors": b36.condition_number,
        "condition_model36_one_reflector": b36_one.condition_number,
    }


# --------------------------------------------------------------------------- κ(n) rule
def condition_curves(nominal: NominalDelta, n_max: int = N_MAX) -> dict[str, dict[str, ConditionCurve]]:
    """κ(n) of the three curves of Fig. 6-7, column-scaled and plain (Bai's), distances."""
    out: dict[str, dict[str, ConditionCurve]] = {}
    for key, model, points, _ in CURVES:
        out[key] = {
            kind: condition_curve(nominal, model, "distance", list(points), n_max=n_max, scaled=scaled)
            for kind, scaled in (("scaled", True), ("plain", False))
        }
    return out


def chosen_n(curves: dict[str, dict[str, ConditionCurve]], kind: str) -> dict[str, int]:
    """Least n of Eq. 21 (ε0 = 1 %, n >= 3) of each curve."""
    return {key: c[kind].least_n(EPSILON0) for key, c in curves.items()}


def least_n_at_phase(nominal: NominalDelta, key: str, phase: float, scaled: bool, n_max: int = N_MAX) -> int:
    """Eq. 21's n for pose sets whose first pose is at azimuth ``phase`` [rad].

    :func:`deltacal.planning.condition_curve` puts the first pose at azimuth 0;
    Bai does not give his (Fig. 4). This repeats its computation (κ of the
    identifiable columns found on the largest set) with the poses turned, to show
    how much the chosen n depends on where the circles start.
    """
    _, model, points, _ = next(c for c in CURVES if c[0] == key)
    error_model = planning_model(model)
    make = rough_poses if model == "rough" else bai_poses
    geometry = nominal.geometry()
    ns = range(2, n_max + 1)
    H = [identification_matrix(geometry, error_model, make(nominal, n, phase=phase).q, "distance",
                               list(points)) for n in ns]
    base = base_parameters(H[-1], error_model.names).base
    kappa = []
    for h in H:
        h = h[:, base]
        if scaled:
            h = h / np.linalg.norm(h, axis=0)
        sv = np.linalg.svd(h, compute_uv=False)
        full = h.shape[0] >= h.shape[1] and sv[-1] > 1e-8 * sv[0]
        kappa.append(sv[0] / sv[-1] if full else math.inf)
    for k in range(1, len(kappa)):
        n = ns[k]
        if n >= 3 and math.isfinite(kappa[k]) and math.isfinite(kappa[k - 1]):
            if abs(kappa[k] - kappa[k - 1]) / kappa[k] <= EPSILON0:
                return n
    raise RuntimeError(f"no n <= {n_max} meets ε0 for {key} at phase {math.degrees(phase):g} deg")


def phase_sensitivity(nominal: NominalDelta, phases_deg=PHASES_DEG, n_max: int = N_MAX) -> dict[str, object]:
    """Eq. 21's n for each curve, κ kind and azimuth of the first pose."""
    out: dict[str, object] = {"phases_deg": list(phases_deg)}
    for key, *_ in CURVES:
        for kind, scaled in (("scaled", True), ("plain", False)):
            out[f"{key}_{kind}"] = [
                least_n_at_phase(nominal, key, math.radians(ph), scaled, n_max) for ph in phases_deg
            ]
    return out


def plot_curves(
    curves: dict[str, dict[str, ConditionCurve]], keys: list[str], title: str, path: Path
) -> None:
    """κ_n and ε_n vs n (scaled: solid, plain: dashed), ε0 and the chosen n marked."""
    fig, axes = plt.subplots(2, len(keys), figsize=(5.5 * len(keys), 6.5), squeeze=False)
    titles = {key: t for key, _, _, t in CURVES}
    for col, key in enumerate(keys):
        top, bottom = axes[0, col], axes[1, col]
        for kind, style in (("scaled", "-o"), ("plain", "--s")):
            c = curves[key][kind]
            ok = np.isfinite(c.kappa)
            n_star = c.least_n(EPSILON0)
            label = f"{'column-scaled' if kind == 'scaled' else 'plain (Bai)'} κ, n* = {n_star}"
            line = top.plot(c.n[ok], c.kappa[ok], style, markersize=3, label=label)[0]
            e_ok = np.isfinite(c.epsilon)
            bottom.plot(c.n[e_ok], 100.0 * c.epsilon[e_ok], style, markersize=3, color=line.get_color(),
                        label=label)
            bottom.axvline(n_star, color=line.get_color(), linewidth=0.8, alpha=0.6)
        bottom.axhline(100.0 * EPSILON0, color="k", linewidth=0.8, label="ε0 = 1 %")
        top.set_yscale("log")
        top.set_ylabel(r"$\kappa_n$")
        top.set_title(titles[key], fontsize=10)
        bottom.set_ylabel(r"$\varepsilon_n = |\kappa_n - \kappa_{n-1}|\,/\,\kappa_n$ [%]")
        bottom.set_xlabel("n (poses per circle)")
        bottom.set_yscale("log")
        for ax in (top, bottom):
            ax.grid(True, alpha=0.3)
            ax.legend(fontsize=8)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


# --------------------------------------------------------------------------- simulated robot
def true_robot(nominal: NominalDelta, seed: int = ROBOT_SEED) -> DeltaGeometry:
    """The nominal robot perturbed like Bai's (Tables 3-4), with Table 2's encoder offsets."""
    perturbed = nominal.geometry().perturbed(Tolerances.bai2015(), np.random.default_rng(seed))
    # Bai's Δθ turns about w0 = -t_i, the project's offsets about t_i
    return replace(perturbed, encoder_offset=-np.radians(TABLE2_OFFSETS_DEG))


def with_offsets(geometry: DeltaGeometry, offsets: np.ndarray) -> DeltaGeometry:
    """The geometry with these encoder offsets [rad] (what the controller assumes)."""
    return replace(geometry, encoder_offset=np.asarray(offsets, dtype=float))


def relative_errors(measured: np.ndarray, targets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Bai's Δρ_k and Δv_k of poses 1.. relative to pose 0 [mm] (as :mod:`deltacal.validation`)."""
    m = metrics_from_positions(measured, targets)
    return m.delta_rho_mm[1:], m.delta_v_mm[1:]


@dataclass(frozen=True)
class RoughStep:
    """Step 1 of Bai §4.2: encoder offsets from distances, compensated until converged.

    Attributes:
        poses: The rough poses (centre first, then the middle circle).
        offsets: Identified encoder offsets [rad] (project sign).
        history: Offsets after each iteration [rad], (iterations, 3).
        before: Measurements at the nominal commands.
        after: Measurements at the compensated commands, after convergence.
    """

    poses: PoseSet
    offsets: np.ndarray
    history: np.ndarray
    before: Measurements
    after: Measurements

    @property
    def iterations(self) -> int:
        """Identify-compensate-measure cycles run."""
        return int(self.history.shape[0])


def rough_step(
    nominal: NominalDelta, truth: DeltaGeometry, n: int, rng: np.random.Generator
) -> RoughStep:
    """Bai's Step 1: identify the encoder offsets (Eq. 26, 17) and compensate, iterated.

    At each cycle the robot is commanded with the readings that put P on the rough
    poses for the current estimate (nominal inverse kinematics minus the offsets),
    P is measured, and the residual offsets are identified linearly from all the
    distances around the current estimate.
    """
    poses = rough_poses(nominal, n, tool=nominal.geometry().point(POINT))
    start = nominal.geometry()
    offsets = np.zeros(3)
    history = []
    before = None
    for _ in range(ROUGH_MAX_ITER):
        current = with_offsets(start, offsets)
        meas = simulate_measurements(truth, poses.q - offsets, rng, TRACKER)
        before = meas if before is None else before
        # the rough step models the encoder offsets only: its fit is poor by design (accepted)
        result = identify(current, meas, planning_model("rough"), method="linear", distances=True,
                          sigma_position=TRACKER.position_noise, accept_poor_fit=True)
        step = result.geometry.encoder_offset - offsets
        offsets = np.array(result.geometry.encoder_offset)
        history.append(offsets)
        if np.max(np.abs(step)) < math.radians(ROUGH_THRESHOLD_DEG):
            break
    after = simulate_measurements(truth, poses.q - offsets, rng, TRACKER)
    assert before is not None
    return RoughStep(poses, offsets, np.array(history), before, after)


@dataclass(frozen=True)
class FineStep:
    """Step 2 of Bai §4.2 with one model.

    Attributes:
        model: ``bai18`` or ``bai32``.
        n: Poses per circle.
        measurements: The tracker measurements (readings are the commands sent).
        result: The linear identification around the rough-step geometry.
    """

    model: str
    n: int
    measurements: Measurements
    result: IdentificationResult


def fine_step(
    nominal: NominalDelta,
    truth: DeltaGeometry,
    offsets: np.ndarray,
    model: str,
    n: int,
    points: tuple[str, ...],
    rng: np.random.Generator,
) -> FineStep:
    """Bai's Step 2: one linear identification (Eq. 17 or 20) from the distances of Bai's poses.

    The robot already runs with the rough step's offsets, so the commands are the
    nominal readings minus them and the model is linearised around that geometry.
    """
    start = with_offsets(nominal.geometry(), offsets)
    poses = bai_poses(nominal, n)
    meas = simulate_measurements(truth, poses.q - offsets, rng, replace(TRACKER, points=points))
    # the paper's one linear step leaves second-order errors: kept, as the paper does
    result = identify(start, meas, model, method="linear", distances=True,
                      sigma_position=TRACKER.position_noise, accept_poor_fit=True)
    return FineStep(model, n, meas, result)


def validation_errors(
    truth: DeltaGeometry, q: np.ndarray, targets: np.ndarray, rng: np.random.Generator
) -> ValidationMetrics:
    """Δρ and Δv of the true robot at readings q, from tracker measurements of P (3 readings)."""
    meas = simulate_measurements(truth, q, rng, TRACKER)
    return metrics_from_positions(meas.position, targets)


def registered_delta_v(actual: np.ndarray, targets: np.ndarray, home: int = 0) -> tuple[np.ndarray, float]:
    """Δv_k after turning the measured displacements by the best rotation (Kabsch), and its angle.

    Distances cannot see the rigid motion of the base frame: a robot identified
    from distances works in its gauge frame (Bai Eq. 11, or the QR's), turned from
    the true {O} by a small rotation that adds ``rotation × |T_k − T_0|`` to Δv
    but nothing to Δρ. Registering the tracker to the calibrated robot (Bai §3.1:
    "robot localization ... according to the environment context") removes it.

    Returns:
        Δv_k [mm] per pose (0 at home), and the rotation angle [deg].
    """
    dP = actual - actual[home]
    dT = targets - targets[home]
    U, _, Vt = np.linalg.svd(dP.T @ dT)
    d = np.sign(np.linalg.det(U @ Vt))
    R = (U @ np.diag([1.0, 1.0, d]) @ Vt).T  # minimises sum |R dP_k - dT_k|^2
    angle = math.degrees(math.acos(np.clip((np.trace(R) - 1.0) / 2.0, -1.0, 1.0)))
    return np.linalg.norm(dP @ R.T - dT, axis=1), angle


def _metrics_dict(m: ValidationMetrics, compensation: str) -> dict[str, object]:
    dv_registered, angle = registered_delta_v(m.actual, m.targets)
    return {
        "drho": m.max_delta_rho_mm,
        "dv": m.max_delta_v_mm,
        "dv_registered": float(dv_registered.max()),
        "frame_rotation_deg": angle,
        "error_max": m.max_mm,
        "error_rms": m.rms_mm,
        "compensation": compensation,
    }


def _bai_deg(offsets: np.ndarray) -> list[float]:
    return [float(v) for v in -np.degrees(offsets)]


def simulate_calibration(
    nominal: NominalDelta, n: dict[str, int], robot_seed: int = ROBOT_SEED, noise_seed: int = NOISE_SEED
) -> dict[str, object]:
    """Bai's two-step procedure and the one-call comparison on a simulated robot (Tables 2 and 5)."""
    truth = true_robot(nominal, robot_seed).with_tool(nominal.geometry().point(POINT))
    rngs = [np.random.default_rng([noise_seed, k]) for k in range(3)]
    rough = rough_step(nominal, truth, n["rough"], rngs[0])
    targets = rough.poses.targets
    before = relative_errors(rough.before.position, targets)
    after = relative_errors(rough.after.position, targets)
    table2 = {
        "points": [f"P{k}" for k in range(1, len(targets))],
        "before": {"drho": before[0].tolist(), "dv": before[1].tolist()},
        "after": {"drho": after[0].tolist(), "dv": after[1].tolist()},
        "iterations": rough.iterations,
        "offsets_deg": _bai_deg(rough.offsets),
        "offsets_history_deg": [_bai_deg(h) for h in rough.history],
        "true_offsets_deg": list(TABLE2_OFFSETS_DEG),
        "distances": len(targets) * (len(targets) - 1) // 2,
    }

    fine18 = fine_step(nominal, truth, rough.offsets, "bai18", n["model18"], (POINT,), rngs[1])
    fine32 = fine_step(nominal, truth, rough.offsets, "bai32", n["model32"], (POINT, SECOND_POINT), rngs[2])

    tool = nominal.geometry().point(POINT)
    valid = validation_poses(nominal, tool=tool)
    T = valid.targets
    nominal_p = nominal.geometry().with_tool(tool)
    rough_p = with_offsets(nominal_p, rough.offsets)
    commands: dict[str, tuple[np.ndarray, str]] = {
        "A": (compensate(nominal_p, T, "exact"), "none (nominal inverse kinematics)"),
        "B": (compensate(rough_p, T, "exact"), "encoder offsets (Eq. 25 with Δp_θ, exact here)"),
    }
    for key, fine in (("C18", fine18), ("C32", fine32)):
        res = fine.result
        linear = LinearCalibration(rough_p, get_model(fine.model), res.base.expand(res.values))
        identified = res.geometry.with_tool(tool)
        eq = "Eq. 25" if fine.model == "bai18" else "Eq. 23"
        commands[key] = (compensate(identified, T, "bai", linear=linear), f"bai ({eq})")
        commands[f"{key}_exact"] = (compensate(identified, T, "exact"), "exact")
        if fine.model == "bai32":
            # Eq. 23 corrects the plate centre; the reflector P is 30 mm below it, so the
            # plate tilt's lever on P is left: Savoure's compensator (tilt × tool) adds it
            commands[f"{key}_savoure"] = (
                compensate(identified, T, "savoure", linear=linear), "savoure (Eq. 23 + tilt × tool)"
            )

    one_call = {}
    both = fine32.measurements
    for model in ("bai42", "complete"):
        t0 = time.perf_counter()
        res = identify(nominal.geometry(), both, model, method="iterated", distances=True,
                       sigma_position=TRACKER.position_noise, accept_poor_fit=True)
        seconds = time.perf_counter() - t0
        commands[f"one_call_{model}"] = (compensate(res.geometry.with_tool(tool), T, "exact"), "exact")
        one_call[model] = {
            "rank": res.rank,
            "parameters": len(res.base.names),
            "iterations": res.iterations,
            "seconds": seconds,
            "distances": res.n_rows,
            "residual_rms_mm": res.after.distance_rms,
        }

    table5 = {}
    for key, (q, how) in commands.items():
        # one noise stream per row, so that adding a row changes no other
        rng = np.random.default_rng([noise_seed, 3, zlib.crc32(key.encode())])
        table5[key] = _metrics_dict(validation_errors(truth, q, T, rng), how)
    for model in one_call:
        one_call[model]["validation"] = table5.pop(f"one_call_{model}")

    fine_report = {}
    for key, fine in (("model18", fine18), ("model32", fine32)):
        res = fine.result
        fine_report[key] = {
            "n": fine.n,
            "poses": 2 * fine.n + 1,
            "distances": res.n_rows,
            "rank": res.rank,
            "condition_number": res.condition_number,
            "residual_rms_before_mm": res.before.distance_rms,
            "residual_rms_after_mm": res.after.distance_rms,
            "parameters": {
                name: (math.degrees(v) if unit == "rad" else v, "deg" if unit == "rad" else "mm")
                for name, v, unit in zip(res.base.base_names, res.values, res.units, strict=True)
            },
        }
    return {
        "robot_seed": robot_seed,
        "noise_seed": noise_seed,
        "true_robot": {
            "tolerances": "Tolerances.bai2015()",
            "encoder_offsets_deg": list(TABLE2_OFFSETS_DEG),
            "errors": truth.deviation_from(nominal.geometry()),
        },
        "tracker": {"sigma_mm": TRACKER.sigma_position, "repeats": TRACKER.repeats},
        "table2": table2,
        "fine": fine_report,
        "validation_poses": len(T),
        "table5": table5,
        "one_call": one_call,
    }


# --------------------------------------------------------------------------- run and print
def run(out_dir: Path, n_max: int = N_MAX, figures: bool = True) -> dict[str, object]:
    """Run everything, write ``bai2015.json`` (and the figures) into ``out_dir``, return it."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    nominal = load_nominal(ROBOT_FILE)
    curves = condition_curves(nominal, n_max)
    n_scaled = chosen_n(curves, "scaled")
    n_plain = chosen_n(curves, "plain")
    phases = phase_sensitivity(nominal, n_max=n_max)
    ident = identifiability(nominal, n_scaled["model32"])
    sim = simulate_calibration(nominal, n_scaled)
    summary: dict[str, object] = {
        "source": "Bai, Mei, Huang, Chetwynd 2015, Proc IMechE C 230(3) 414-424",
        "robot": "models/bai2015.toml",
        "rank_model18": ident["rank_model18"],
        "rank_model36": ident["rank_model36"],
        "unidentifiable_model36": ident["unidentifiable_model36"],
        "identifiability": ident,
        "n_selected": n_scaled,
        "n_selected_plain_kappa": n_plain,
        "epsilon0": EPSILON0,
        "n_selected_by_phase": phases,
        "kappa_curves": {
            key: {
                "model": c["scaled"].model,
                "points": c["scaled"].points,
                "layers": c["scaled"].layers,
                "n": c["scaled"].n.tolist(),
                "kappa_scaled": [float(v) if math.isfinite(v) else None for v in c["scaled"].kappa],
                "kappa_plain": [float(v) if math.isfinite(v) else None for v in c["plain"].kappa],
            }
            for key, c in curves.items()
        },
        **sim,
        "paper": PAPER,
    }
    (out_dir / "bai2015.json").write_text(json.dumps(summary, indent=2, ensure_ascii=False) + "\n")
    if figures:
        plot_curves(curves, ["rough"], "Bai 2015 Fig. 6: κ(n), rough calibration",
                    out_dir / "bai2015_fig6.png")
        plot_curves(curves, ["model18", "model32"], "Bai 2015 Fig. 7: κ(n), fine calibration",
                    out_dir / "bai2015_fig7.png")
    return summary


def format_report(s: dict) -> str:
    """The tables, paper vs deltacal, as text."""
    p = s["paper"]
    ident = s["identifiability"]
    lines = [
        f"Identifiability (distances, Bai poses n = {ident['n']}):",
        f"  rank model 18 (one reflector):  {s['rank_model18']}  (paper {p['rank_model18']})",
        f"  rank model 36 (two reflectors): {s['rank_model36']}  (paper {p['rank_model36']}); "
        f"one reflector: {ident['rank_model36_one_reflector']}, plate centre alone: "
        f"{ident['rank_model36_plate_centre']}",
        f"  unidentifiable (pivoted QR): {', '.join(s['unidentifiable_model36'])}",
        f"  Bai's choice {', '.join(ident['bai_choice'])}: "
        f"{'valid' if ident['bai_choice_valid'] else 'NOT valid'} (same 4-dim null space)",
        "",
        "κ(n) rule, ε0 = 1 %:          rough  model18  model32",
        "  paper                        {rough:>5}  {model18:>7}  {model32:>7}".format(**p["n_selected"]),
        "  deltacal, column-scaled κ    {rough:>5}  {model18:>7}  {model32:>7}".format(**s["n_selected"]),
        "  deltacal, plain κ            {rough:>5}  {model18:>7}  {model32:>7}".format(
            **s["n_selected_plain_kappa"]
        ),
    ]
    ph = s["n_selected_by_phase"]
    lines.append("  first pose at azimuth [deg]  " + " ".join(f"{v:>4g}" for v in ph["phases_deg"]))
    for key, *_ in CURVES:
        for kind in ("scaled", "plain"):
            lines.append(f"    {key + ' ' + kind:<27}" + " ".join(f"{v:>4}" for v in ph[f"{key}_{kind}"]))
    lines.append("")
    t2 = s["table2"]
    lines.append(
        f"Table 2 (rough step, {t2['iterations']} cycles; offsets Δθ [deg] "
        + ", ".join(f"{v:.3f}" for v in t2["offsets_deg"])
        + "; imposed " + ", ".join(f"{v:.3f}" for v in t2["true_offsets_deg"]) + ")"
    )
    lines.append("  [mm]                " + "".join(f"{pt:>9}" for pt in t2["points"]))
    for when in ("before", "after"):
        for key, label in (("drho", "Δρ"), ("dv", "Δv")):
            paper = p["table2"][when][key]
            lines.append(f"  {when:<6} {label} paper   " + "".join(f"{v:>9.3f}" for v in paper))
            lines.append(f"  {when:<6} {label} deltacal" + "".join(f"{v:>9.3f}" for v in t2[when][key]))
    lines.append("")
    lines.append(f"Table 5 (max over {s['validation_poses']} validation poses) [mm]")
    lines.append(
        f"  {'':<19}{'Δρ paper':>9}{'Δρ':>7}{'Δv paper':>9}{'Δv {O}':>8}{'Δv reg':>8}{'rot°':>7}"
        "  compensation"
    )
    rows = [(key, row, row["compensation"]) for key, row in s["table5"].items()]
    rows += [
        (f"one call {model}", row["validation"],
         f"exact (iterated, rank {row['rank']}/{row['parameters']}, {row['iterations']} it.)")
        for model, row in s["one_call"].items()
    ]
    for key, row, how in rows:
        ref = p["table5"].get(key)
        pr = f"{ref['drho']:>9.3f}" if ref else f"{'':>9}"
        pv = f"{ref['dv']:>9.3f}" if ref else f"{'':>9}"
        lines.append(
            f"  {key:<19}{pr}{row['drho']:>7.3f}{pv}{row['dv']:>8.3f}{row['dv_registered']:>8.3f}"
            f"{row['frame_rotation_deg']:>7.3f}  {how}"
        )
    lines.append("  Δv {O}: in the true base frame; Δv reg: after the best rotation of the tracker frame")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT, help=f"output directory ({DEFAULT_OUT})")
    parser.add_argument("--n-max", type=int, default=N_MAX, help=f"largest n of the κ(n) curves ({N_MAX})")
    args = parser.parse_args()
    summary = run(args.out, n_max=args.n_max)
    print(format_report(summary))
    print(f"wrote {args.out / 'bai2015.json'}, bai2015_fig6.png, bai2015_fig7.png")


if __name__ == "__main__":
    main()
