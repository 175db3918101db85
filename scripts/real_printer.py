"""Real printers' saved calibrations: identify from each run, predict the same printer's other runs.

Two FLSUN V400s running Klipper saved their ``DELTA_CALIBRATE`` runs in ``SAVE_CONFIG`` blocks
(``tests/data/klipper/real/``: each file one run, its header naming its source): 7 probe heights
and the 12 distances of Klipper's printed calibration object, and the values Klipper fitted to
them. For each run: ``deltacal import`` (the robot file and measurements of that configuration,
nothing by hand), identification of the complete printer model from that run alone (tolerances
scaled by the evidence), then the other runs of the same printer predicted through the identified
printer and through the values Klipper fitted to the same run (its SAVE_CONFIG values): the
heights' residuals (as measured, and less their mean: the probe's trigger height is re-measured
between runs) and the distances' residuals, RMS and max. Writes ``results/real_printer.json``.
No randomness.
"""

from __future__ import annotations

import argparse
import json
import re
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from deltacal.geometry import DeltaGeometry
from deltacal.io.atomic import atomic_write_text
from deltacal.kinematics import exact
from deltacal.printer.files.robot_file import load_printer
from deltacal.printer.firmware.klipper.importer import import_klipper
from deltacal.printer.firmware.klipper.model import KlipperDelta
from deltacal.printer.identification.fit import PrinterMeasurements, identify_printer

REPO_ROOT = Path(__file__).resolve().parents[1]
DATA = REPO_ROOT / "tests" / "data" / "klipper" / "real"
#: The printers, each with its runs' files in time order.
PRINTERS = {name: sorted(DATA.glob(f"flsun-v400-{name}-run*.cfg")) for name in ("a", "b")}


@dataclass(frozen=True)
class Run:
    """One saved run: its measurements (readings [mm]), Klipper's fitted values and the nominal."""

    name: str
    klipper: KlipperDelta
    nominal: DeltaGeometry
    step: np.ndarray
    height_steps: np.ndarray
    height: np.ndarray
    pair_steps: np.ndarray
    distance: np.ndarray

    def measurements(self) -> PrinterMeasurements:
        """The run as identification takes it: readings are steps times the nominal step distance."""
        return PrinterMeasurements(self.height_steps * self.step, self.pair_steps * self.step, self.distance,
                                   trigger_height=self.height)


def read_run(path: Path) -> Run:
    """A run through ``deltacal import``: the configuration's robot file and its saved measurements."""
    imported = import_klipper(path)
    with tempfile.TemporaryDirectory() as folder:
        robot = Path(folder) / "printer.toml"
        robot.write_text(imported.text)
        printer = load_printer(robot)
    saved = imported.saved
    return Run(path.stem, imported.klipper, printer.geometry(), printer.step_distance, saved.height_steps,
               saved.height, saved.pair_steps, saved.distance)


def residuals_identified(geometry: DeltaGeometry, step: np.ndarray,
                         run: Run) -> tuple[np.ndarray, np.ndarray]:
    """Heights and distances of ``run`` less those the identified printer predicts [mm]."""
    z = exact.forward(geometry, run.height_steps * step).point(geometry.tool)[:, 2]
    ends = exact.forward(geometry, run.pair_steps.reshape(-1, 3) * step).point(geometry.tool)
    ends = ends.reshape(-1, 2, 3)
    return run.height - z, run.distance - np.linalg.norm(ends[:, 0] - ends[:, 1], axis=1)


def residuals_klipper(klipper: KlipperDelta, run: Run) -> tuple[np.ndarray, np.ndarray]:
    """Heights and distances of ``run`` less those Klipper's values predict [mm]."""
    z = klipper.positions(run.height_steps)[:, 2]
    ends = klipper.positions(run.pair_steps.reshape(-1, 3)).reshape(-1, 2, 3)
    return run.height - z, run.distance - np.linalg.norm(ends[:, 0] - ends[:, 1], axis=1)


def less_object_scale(distances: np.ndarray, run: Run) -> np.ndarray:
    """Distance residuals less the object's own scale (its shrinkage): ``r − k d``, k fitting them best."""
    k = float(distances @ run.distance) / float(run.distance @ run.distance)
    return distances - k * run.distance


def figures(heights: np.ndarray, distances: np.ndarray, scale_free: np.ndarray) -> dict[str, float]:
    """RMS and max |·| of the heights (as measured and less their mean) and of the distances [mm].

    ``scale_free``: the distances' residuals less each object's own scale (:func:`less_object_scale`).
    """
    flat = heights - np.mean(heights)
    return {"scale_free_distance_rms": float(np.sqrt(np.mean(scale_free**2))),
            "height_rms": float(np.sqrt(np.mean(heights**2))), "height_max": float(np.max(np.abs(heights))),
            "flatness_rms": float(np.sqrt(np.mean(flat**2))), "flatness_max": float(np.max(np.abs(flat))),
            "distance_rms": float(np.sqrt(np.mean(distances**2))),
            "distance_max": float(np.max(np.abs(distances)))}


def scale_of(hints: tuple[str, ...]) -> float:
    """The tolerances' scale the fit took, from its first hint."""
    match = re.search(r"scaled by ([0-9.eE+-]+)", hints[0])
    assert match is not None, hints[0]
    return float(match.group(1))


def cross_validate(runs: list[Run]) -> list[dict]:
    """Each run identified alone, then every other run predicted by it and by Klipper's values of it."""
    out = []
    for i, fit_run in enumerate(runs):
        result = identify_printer(fit_run.nominal, fit_run.measurements(), "printer",
                                  tolerance_scale="evidence", calibrated_start=True)  # as identify does
        others = [runs[j] for j in range(len(runs)) if j != i]
        ours = [residuals_identified(result.geometry, fit_run.step, run) for run in others]
        theirs = [residuals_klipper(fit_run.klipper, run) for run in others]
        out.append({
            "run": fit_run.name, "s0_squared": float(result.variance_factor),
            "tolerance_scale": scale_of(result.hints),
            "own_fit": _pooled([residuals_identified(result.geometry, fit_run.step, fit_run)], [fit_run]),
            "own_klipper": _pooled([residuals_klipper(fit_run.klipper, fit_run)], [fit_run]),
            "predicted": [run.name for run in others],
            "deltacal": _pooled(ours, others), "klipper": _pooled(theirs, others),
            "object_scale_deltacal": [float(np.mean(d / run.distance)) for (_, d), run in zip(ours, others,
                                                                                                strict=True)],
        })
    return out


def _pooled(residuals: list[tuple[np.ndarray, np.ndarray]], runs: list[Run]) -> dict[str, float]:
    """The figures of several runs' residuals together."""
    heights = np.concatenate([h for h, _ in residuals])
    distances = np.concatenate([d for _, d in residuals])
    scale_free = np.concatenate([less_object_scale(d, run)
                                 for (_, d), run in zip(residuals, runs, strict=True)])
    return figures(heights, distances, scale_free)


def main(argv: list[str] | None = None) -> int:
    """Cross-validate every saved run of the two printers and write ``results/real_printer.json``."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-o", "--output", type=Path, default=REPO_ROOT / "results" / "real_printer.json")
    args = parser.parse_args(argv)
    results = {name: cross_validate([read_run(p) for p in paths]) for name, paths in PRINTERS.items()}
    for rows in results.values():
        for row in rows:
            d, k = row["deltacal"], row["klipper"]
            print(f"{row['run']}: s0² {row['s0_squared']:.3g}, scale {row['tolerance_scale']:.3g}; "
                  f"other runs: heights RMS {d['height_rms']:.3f} vs Klipper {k['height_rms']:.3f}, flatness "
                  f"{d['flatness_rms']:.3f} vs {k['flatness_rms']:.3f}, distances {d['distance_rms']:.3f} vs "
                  f"{k['distance_rms']:.3f} (less each object's scale {d['scale_free_distance_rms']:.3f} vs "
                  f"{k['scale_free_distance_rms']:.3f}) mm")
    atomic_write_text(args.output, json.dumps(results, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
