"""A rotary Delta printer's simulated measurements: ``plan --object``'s templates filled by a true printer.

``deltacal simulate printer.toml probe.csv [distances.csv] --controller printer.cfg`` of a rotary robot
file: the true printer (``--truth``, a geometry in the firmware's frame, the bed's; or ``--perturb``:
the robot file's nominal printer moved into that frame and perturbed at
:meth:`~deltacal.geometry.Tolerances.rotary_printer_kit` tolerances, each arm's step angle (gear ratio)
too) is commanded by the configuration's values and measured as Klipper measures
(:mod:`deltacal.printer.rotary_simulation`): the commanded z at which the nozzle (or the probe's tip)
triggers at each x, y of the probe template, the true distances between the features printed at the
distance template's commanded centres; each with its noise. The filled files (and the true printer)
are written as a linear printer's simulation writes them (:mod:`deltacal.wings.printer.simulate`).
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from ...exceptions import InputError, UsageError
from ...geometry import DeltaGeometry, NominalDelta, Tolerances
from ...io import data_row, load_geometry, save_geometry
from ...printer.files.measurements import (
    read_printed_distances,
    read_probe_heights,
    write_printed_distances,
    write_probe_heights,
)
from ...printer.firmware.config_file import told_firmware
from ...printer.firmware.controller import RotaryFirmwareController
from ...printer.firmware.klipper.rotary_model import KlipperRotaryDelta
from ...printer.rotary_simulation import RotaryPrinter, printed_distances, probe_triggers
from ...simulation import truth_path
from ..base import Done
from ..printer.simulate import SIGMA_DISTANCE, SIGMA_HEIGHT, checked_outputs, rows_named, simulated_lines
from ..requests import SimulateRequest
from .printed import rotary_controller_of


def simulate_rotary_prints(request: SimulateRequest, robot: NominalDelta) -> Done:
    """``deltacal simulate`` of a rotary Delta printer: the filled templates (and the true printer) written.

    Raises:
        UsageError: ``--tolerances`` (a rotary printer's are its kit's), outputs not distinct, a linear
            Delta printer's configuration.
        InputError: a file's first problem; a template's row the firmware or the true printer cannot
            reach, naming it.
    """
    probe_file, distance_file = request.check_printer()
    assert request.controller is not None
    if request.tolerances is not None:
        raise UsageError(f"--tolerances {request.tolerances}: a linear printer's classes; a rotary printer's "
                         "truth is drawn at a rotary printer kit's (Tolerances.rotary_printer_kit)")
    checked_outputs(request)
    firmware = told_firmware(request.controller, request.firmware)
    controller = rotary_controller_of(firmware, request.controller, request.nominal, robot)
    values = _klipper_values(controller, request.controller)
    truth = _truth(request, robot, controller)
    rng = np.random.default_rng(request.seed)
    offset = np.zeros(3) if request.probe_offset is None else np.asarray(request.probe_offset, dtype=float)
    who = f"the true printer ({request.truth})" if request.truth is not None else "the perturbed printer"
    template = read_probe_heights(probe_file, filled=False)
    xy = template.commanded[:, :2]
    _check_reach(values, np.column_stack([xy, template.heights]), str(probe_file), template.lines)
    probing = RotaryPrinter(replace(truth, tool=truth.tool + offset), values)
    with rows_named(str(probe_file), template.lines, xy, who):
        probe = probe_triggers(probing, values, xy, trigger_height=template.heights)
    noise = SIGMA_HEIGHT if request.sigma_height is None else request.sigma_height
    probe[:, 2] += rng.normal(0.0, noise, len(probe))
    measured = None
    if distance_file is not None:
        printed = read_printed_distances(distance_file, filled=False)
        pairs = printed.pairs.reshape(-1, 6)
        _check_reach(values, printed.pairs, str(distance_file), printed.lines)
        with rows_named(str(distance_file), printed.lines, printed.pairs, who):
            measured = printed_distances(RotaryPrinter(truth, values), values, pairs)
        noise = SIGMA_DISTANCE if request.sigma_distance is None else request.sigma_distance
        measured = measured + rng.normal(0.0, noise, len(measured))
    if request.truth is None:
        save_geometry(truth, truth_path(Path(request.output)))
    write_probe_heights(request.output, probe[:, :2], probe[:, 2],
                        trigger_height=template.trigger_height if template.trigger_height.size else None)
    if measured is not None:
        assert request.distances_output is not None
        write_printed_distances(request.distances_output, printed.pairs, measured, printed.balls or None)
    return Done(_said(request, len(probe), None if measured is None else len(measured)))


def _klipper_values(controller: RotaryFirmwareController, config: Any) -> KlipperRotaryDelta:
    """The configuration's values as Klipper's rotary model (the one whose measuring is simulated)."""
    values = controller.firmware
    if not isinstance(values, KlipperRotaryDelta):
        raise UsageError(f"--controller {config}: a rotary printer is simulated as Klipper measures it; "
                         "give Klipper's printer.cfg (kinematics: rotary_delta)")
    return values


def _truth(request: SimulateRequest, robot: NominalDelta,
           controller: RotaryFirmwareController) -> DeltaGeometry:
    """The true printer in the firmware's frame: ``--truth``'s geometry, or the nominal one perturbed.

    ``--perturb SEED``: the robot file's printer moved into the bed's frame, perturbed at a rotary printer
    kit's tolerances, then each arm's step scale drawn (the same random generator).
    """
    if request.truth is not None:
        truth = load_geometry(request.truth)
        if truth.chain != robot.geometry().chain:
            raise InputError(f"a rotary printer's true geometry has revolute chains, got joint = "
                             f"{truth.joint!r} (a linear printer's geometry?)", str(request.truth),
                             "key joint")
        return truth
    tolerances = Tolerances.rotary_printer_kit()
    rng = np.random.default_rng(request.perturb)
    truth = controller.in_bed_frame(robot.geometry()).perturbed(tolerances, rng)
    return replace(truth, joint_scale=1.0 + rng.normal(0.0, tolerances.joint_scale, 3))


def _check_reach(values: KlipperRotaryDelta, commanded: np.ndarray, source: str, lines: np.ndarray) -> None:
    """Refuse, by its row, a commanded position (or pair of them) outside Klipper's rotary limits."""
    points = commanded.reshape(-1, 3)
    unreachable = ~np.all(np.isfinite(values.shoulder_angles(points, check=False)), axis=1)
    bad = (unreachable | (values.outside(points) != 0)).reshape(len(commanded), -1).any(axis=1)
    if np.any(bad):
        rows = np.flatnonzero(bad)
        k = int(rows[0])
        more = f" ({rows.size} rows in all)" if rows.size > 1 else ""
        raise InputError(f"Klipper's rotary_delta limits refuse the commanded position "
                         f"{commanded[k].reshape(-1).tolist()} mm{more}", source, data_row(lines[k], k + 1))


def _said(request: SimulateRequest, probes: int, distances: int | None) -> tuple[str, ...]:
    """What was written."""
    return simulated_lines(request, probes, distances, f"true rotary printer (seed {request.perturb}, rotary "
                                                       "printer kit tolerances, in the bed's frame)")
