"""Reproduce Savoure et al. 2006, Section III: the planar parallelogram mechanism.

Table 2's geometric errors are put on the Pinocchio model of the mechanism (the
"true" robot). For each tool length h, 19 configurations q = -45°..45° (5° steps)
are measured with Gaussian noise (0.003 mm, 0.003°); the simplified model
(δq0, δl; Eq. 38) and the complete model (base parameters of Eq. 73 found by QR,
regroupings Eq. 70-72) are identified; then the tool is sent to the x of every
q = -45°..45° (1° steps) with no calibration, the classical one (corrected IPR_S)
and the improved one (Eq. 29-33), and the x error is measured on the true model.

Writes ``savoure2006.json`` and the figures ``savoure2006_fig5.png`` (h = 0),
``savoure2006_fig6.png`` (h = 200 mm) and ``savoure2006_fig7.png`` (h = 200 mm,
91 measurement configurations) into ``--out``.
"""

from __future__ import annotations

import argparse
import json
from dataclasses import dataclass
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from deltacal.planar import (  # noqa: E402
    PARAMETER_NAMES,
    CompleteIdentification,
    PlanarGeometry,
    PlanarMultibody,
    SimplifiedIdentification,
    SimplifiedModel,
    command_classical,
    command_improved,
    identify_complete,
    identify_simplified,
    table2_errors,
)

REPO_ROOT = Path(__file__).resolve().parents[1]
DEFAULT_OUT = REPO_ROOT / "results"
SEED = 2006
#: Measurement configurations of Sec. III-B [rad].
MEASURED_Q = np.deg2rad(np.arange(-45.0, 45.0 + 1e-9, 5.0))
#: Configurations at which the compensation is judged [rad].
EVALUATED_Q = np.deg2rad(np.arange(-45.0, 45.0 + 1e-9, 1.0))
#: Measurement noise (x [mm], y [mm], alpha [rad]).
NOISE_STD = np.array([0.003, 0.003, np.deg2rad(0.003)])
#: Tool lengths h [mm]: Figs. 5 and 6 use 0 and 200; Table 2's 100 is added.
TOOLS = (0.0, 100.0, 200.0)
METHODS = ("none", "classical", "improved")


@dataclass(frozen=True)
class Trial:
    """One calibration and its judgement with one tool.

    Attributes:
        h: Tool length [mm].
        q: Evaluated readings [rad], shape (n,).
        errors: TCP x error of each method [mm], each shape (n,).
        simplified: The classical identification.
        complete: The complete identification.
    """

    h: float
    q: np.ndarray
    errors: dict[str, np.ndarray]
    simplified: SimplifiedIdentification
    complete: CompleteIdentification

    def max_errors(self) -> dict[str, float]:
        """Largest |x error| of each method [mm]."""
        return {m: float(np.max(np.abs(e))) for m, e in self.errors.items()}

    def rms_errors(self) -> dict[str, float]:
        """RMS x error of each method [mm]."""
        return {m: float(np.sqrt(np.mean(e**2))) for m, e in self.errors.items()}


def calibrate(
    h: float,
    rng: np.random.Generator,
    measured_q: np.ndarray = MEASURED_Q,
    noise_std: np.ndarray | None = NOISE_STD,
) -> Trial:
    """Measure, identify both models and judge the three compensations, tool length h."""
    nominal = PlanarGeometry(h=h)
    true = PlanarMultibody(nominal.perturbed(table2_errors()))
    measured = true.tcp_pose(measured_q)
    if noise_std is not None:
        measured = measured + rng.normal(size=measured.shape) * noise_std
    simplified = identify_simplified(
        measured_q, measured, SimplifiedModel.from_geometry(nominal), noise_std=noise_std
    )
    complete = identify_complete(measured_q, measured, nominal, noise_std=noise_std)

    nominal_simple = SimplifiedModel.from_geometry(nominal)
    x_desired = nominal_simple.forward(EVALUATED_Q)
    commands = {
        "none": command_classical(x_desired, nominal_simple),
        "classical": command_classical(x_desired, simplified.model),
        "improved": command_improved(x_desired, nominal, complete),
    }
    errors = {m: true.tcp_pose(q)[:, 0] - x_desired for m, q in commands.items()}
    return Trial(h=h, q=EVALUATED_Q, errors=errors, simplified=simplified, complete=complete)


def plot(trial: Trial, title: str, path: Path) -> None:
    """TCP x error vs q for the three methods, and the improved one enlarged."""
    q_deg = np.rad2deg(trial.q)
    colours = {"none": "tab:red", "classical": "tab:blue", "improved": "tab:green"}
    labels = {"none": "no calibration", "classical": "classical", "improved": "improved"}
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(7.0, 6.5), sharex=True)
    for method in METHODS:
        top.plot(q_deg, trial.errors[method], color=colours[method], label=labels[method])
    bottom.plot(q_deg, trial.errors["improved"], color=colours["improved"], label=labels["improved"])
    top.set_ylabel("TCP error along x_b [mm]")
    bottom.set_ylabel("improved only [mm]")
    bottom.set_xlabel("q [deg]")
    top.set_title(title)
    top.legend()
    for ax in (top, bottom):
        ax.grid(True, alpha=0.3)
        ax.axhline(0.0, color="k", linewidth=0.5)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def _base_table(complete: CompleteIdentification) -> list[dict[str, object]]:
    true_base = complete.base.project(table2_errors())
    units = ["rad" if PARAMETER_NAMES[k] == "q0" else "mm" for k in complete.base.base]
    return [
        {"label": label, "unit": unit, "true": float(t), "identified": float(e), "std": float(s)}
        for label, unit, t, e, s in zip(
            complete.labels(), units, true_base, complete.estimate, complete.std, strict=True
        )
    ]


def run(out_dir: Path, seed: int = SEED, figures: bool = True) -> dict[str, object]:
    """Run the reproduction, write the JSON (and figures) into ``out_dir``, return the summary."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    trials = {f"h{h:g}": calibrate(h, rng) for h in TOOLS}
    noise_free = {f"h{h:g}": calibrate(h, rng, noise_std=None) for h in TOOLS}
    dense_q = np.deg2rad(np.arange(-45.0, 45.0 + 1e-9, 1.0))
    dense = calibrate(200.0, rng, measured_q=dense_q)

    reference = trials["h100"].complete  # Table 2's tool
    summary: dict[str, object] = {
        "source": "Savoure et al. 2006, Sec. III (planar parallelogram mechanism, Table 2)",
        "seed": seed,
        "measurement_configurations": int(MEASURED_Q.size),
        "noise_std": {"position_mm": float(NOISE_STD[0]), "angle_deg": float(np.rad2deg(NOISE_STD[2]))},
        "parameters": len(PARAMETER_NAMES),
        "identifiable": int(reference.base.rank),
        "regroupings": reference.regroupings(),
        "base_parameters": reference.labels(),
        "identified_h100": _base_table(reference),
        "classical_h100": {
            "dq0_rad": float(trials["h100"].simplified.delta[0]),
            "dl_mm": float(trials["h100"].simplified.delta[1]),
        },
        "max_error_mm": {key: t.max_errors() for key, t in trials.items()},
        "rms_error_mm": {key: t.rms_errors() for key, t in trials.items()},
        "max_error_noise_free_mm": {key: t.max_errors() for key, t in noise_free.items()},
        "max_error_h200_91_configurations_mm": dense.max_errors(),
    }
    (out_dir / "savoure2006.json").write_text(json.dumps(summary, indent=2, ensure_ascii=False) + "\n")
    if figures:
        plot(trials["h0"], "Fig. 5: h = 0 mm, 19 configurations", out_dir / "savoure2006_fig5.png")
        plot(trials["h200"], "Fig. 6: h = 200 mm, 19 configurations", out_dir / "savoure2006_fig6.png")
        plot(dense, "Fig. 7: h = 200 mm, 91 configurations", out_dir / "savoure2006_fig7.png")
    return summary


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT, help=f"output directory ({DEFAULT_OUT})")
    parser.add_argument("--seed", type=int, default=SEED, help=f"random seed ({SEED})")
    args = parser.parse_args()
    summary = run(args.out, seed=args.seed)
    print(f"identifiable {summary['identifiable']} of {summary['parameters']}: {summary['regroupings']}")
    for key, errors in summary["max_error_mm"].items():  # type: ignore[attr-defined]
        print(f"{key}: max |x error| " + ", ".join(f"{m} {v:.4f} mm" for m, v in errors.items()))
    print(f"wrote {args.out / 'savoure2006.json'}")


if __name__ == "__main__":
    main()
