"""A printer's simulated measurements: ``plan --object``'s templates filled by a true printer's firmware.

The templates (the commanded x, y of each probe point; the commanded pairs of features; the measured
column empty or not: it is replaced in the output) are run on a true printer through the firmware
(:mod:`deltacal.printer.simulation`), and the filled files written. The readings count steps in the
robot file's nominal step distance, as ``identify`` reads them.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from ...exceptions import AssemblyError, InputError, UnreachableError, UsageError
from ...geometry import DeltaGeometry
from ...io import data_row, load_geometry, save_geometry
from ...io.paths import check_inputs, check_output
from ...printer.files.measurements import (
    read_printed_distances,
    read_probe_heights,
    write_printed_distances,
    write_probe_heights,
)
from ...printer.firmware.base import FirmwareModel
from ...printer.firmware.config_file import read_firmware_config
from ...printer.robot import NominalLinearDelta
from ...printer.simulation import TOLERANCE_CLASSES, printed_distances, probe_heights, random_true_printer
from ...simulation import truth_path
from ..base import Done
from ..requests import SimulateRequest

#: Default σ of a probe height and of a caliper distance [mm] (as ``identify`` assumes them).
SIGMA_HEIGHT = 0.01
SIGMA_DISTANCE = 0.02


def checked_outputs(request: SimulateRequest) -> list[Path]:
    """A printer's simulation's inputs checked, and its outputs (filled files, the truth unless given).

    Raises:
        UsageError: a missing input, an output that would overwrite an input, outputs not distinct.
    """
    inputs = [request.nominal, request.controller, *request.poses, request.truth]
    check_inputs(inputs)
    outputs = [Path(request.output)]
    if request.distances_output is not None:
        outputs.append(Path(request.distances_output))
    if request.truth is None:
        outputs.append(truth_path(Path(request.output)))
    for path in outputs:
        check_output(path, inputs)
    if len({p.resolve() for p in outputs}) != len(outputs):
        raise UsageError(f"the outputs {', '.join(map(str, outputs))} must be different files")
    return outputs


def simulate_prints(request: SimulateRequest, printer: NominalLinearDelta) -> Done:
    """``deltacal simulate`` of a printer: the filled templates (and the true printer) written."""
    probe_file, distance_file = request.check_printer()
    assert request.controller is not None
    checked_outputs(request)
    config = read_firmware_config(request.controller, request.firmware)
    firmware = config.values
    config.firmware.check_same_printer(config.firmware.nominal(printer), firmware, str(request.nominal),
                                       str(request.controller))
    truth = _truth(request, printer)
    step = printer.step_distance
    offset = np.zeros(3) if request.probe_offset is None else request.probe_offset
    rng = np.random.default_rng(request.seed)
    template = read_probe_heights(probe_file, filled=False)
    xy = template.commanded[:, :2]
    noise = SIGMA_HEIGHT if request.sigma_height is None else request.sigma_height
    robot = f"the true printer ({request.truth})" if request.truth is not None else "the perturbed printer"
    with rows_named(str(probe_file), template.lines, xy, robot):
        probe = probe_heights(truth, firmware, step, xy, noise, rng, offset, trigger_height=template.heights)
    _check_travel(firmware, step, probe, str(probe_file), template.lines)
    pairs, measured, balls = None, None, None
    if distance_file is not None:
        printed = read_printed_distances(distance_file, filled=False)
        pairs, balls = printed.pairs, printed.balls or None
        noise = SIGMA_DISTANCE if request.sigma_distance is None else request.sigma_distance
        _check_travel(firmware, step, pairs, str(distance_file), printed.lines)
        with rows_named(str(distance_file), printed.lines, pairs, robot):
            measured = printed_distances(truth, firmware, step, pairs, noise, rng)
    if request.truth is None:
        save_geometry(truth, truth_path(Path(request.output)))
    write_probe_heights(request.output, probe[:, :2], probe[:, 2],
                        trigger_height=template.trigger_height if template.trigger_height.size else None)
    if pairs is not None and measured is not None:
        assert request.distances_output is not None
        # the template's labels kept
        write_printed_distances(request.distances_output, pairs, measured, balls)
    return Done(_said(request, len(probe), None if measured is None else len(measured)))


def _truth(request: SimulateRequest, printer: NominalLinearDelta) -> DeltaGeometry:
    """The true printer: the geometry file of ``--truth``, or the nominal one perturbed (``--perturb``)."""
    if request.truth is not None:
        truth = load_geometry(request.truth)
        if truth.chain != printer.geometry().chain:
            raise InputError(f"a printer's true geometry has prismatic chains, got joint = {truth.joint!r} "
                             "(a rotary Delta's geometry?)", str(request.truth), "key joint")
        return truth
    tolerances, tilt = TOLERANCE_CLASSES[request.tolerances or "printer-kit"]
    return random_true_printer(printer, np.random.default_rng(request.perturb), tolerances(), tilt).geometry


def _check_travel(firmware: FirmwareModel, step_distance: np.ndarray | float, commanded: np.ndarray,
                  source: str, lines: np.ndarray) -> None:
    """Refuse, by its row, a commanded position (or pair of them) the firmware cannot reach.

    Out of the rods' reach, or a carriage above its endstop (a negative travel).
    """
    readings = firmware.inverse(commanded.reshape(-1, 3), step_distance, check=False)
    readings = readings.reshape(len(commanded), -1)
    bad = np.flatnonzero(~np.all(np.nan_to_num(readings, nan=-1.0) >= 0.0, axis=1))
    if bad.size:
        k = int(bad[0])
        why = "out of the rods' reach" if np.isnan(readings[k]).any() else "a carriage above its endstop"
        more = f" ({bad.size} rows in all)" if bad.size > 1 else ""
        raise InputError(f"the firmware cannot reach the commanded position {commanded[k].tolist()} mm "
                         f"({why}){more}", source, data_row(lines[k], k + 1))


@contextmanager
def rows_named(source: str, lines: np.ndarray, rows: np.ndarray, robot: str) -> Iterator[None]:
    """A position the firmware or the true printer cannot reach becomes one line naming its row."""
    try:
        yield
    except (UnreachableError, AssemblyError) as exc:
        if not exc.indices:
            raise
        k = int(exc.indices[0])
        who = "the firmware" if isinstance(exc, UnreachableError) else robot
        more = f" ({len(exc.indices)} rows in all)" if len(exc.indices) > 1 else ""
        raise InputError(f"{who} cannot reach the commanded position {rows[k].tolist()} mm{more}",
                         source, data_row(lines[k], k + 1)) from exc


def _said(request: SimulateRequest, probes: int, distances: int | None) -> tuple[str, ...]:
    """What was written."""
    tolerances = request.tolerances or "printer-kit"
    return simulated_lines(request, probes, distances, f"true printer (seed {request.perturb}, {tolerances} "
                                                       "tolerances, on its true bed)")


def simulated_lines(request: SimulateRequest, probes: int, distances: int | None,
                    truth: str) -> tuple[str, ...]:
    """What a printer's simulation wrote: the filled files, then ``truth`` (its words) unless given."""
    line = f"simulated {probes} probe heights -> {request.output}"
    if distances is not None:
        line += f"; {distances} distances -> {request.distances_output}"
    if request.truth is not None:
        return (line,)
    return (line, f"{truth} -> {truth_path(Path(request.output))}")
