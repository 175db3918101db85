"""A rotary Delta's identification: its tracker (or probe) measurements, one CSV file, into its geometry."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ...exceptions import AssemblyError, ConvergenceError, IdentificationError, InputError
from ...geometry import DeltaGeometry, NominalDelta
from ...identification import FitOptions, PoorFitError, identify
from ...identification.compliance import payload_span
from ...io import lines_text, read_measurement_file, save_calibration, unassembled_rows
from ...observations import Measurements
from ..base import Done, check_files, warn
from ..requests import IdentifyRequest


def identify_rotary(request: IdentifyRequest, nominal: NominalDelta) -> Done:
    """``deltacal identify`` of a rotary Delta: the calibration file written, the report said."""
    options = request.rotary_fit()
    path = request.measurements[0]
    check_files((request.nominal, path), request.output)
    start = nominal.geometry()
    for name in request.free_points:
        if name not in start.point_names:
            raise InputError(f"unknown point {name!r}; the robot's points are {', '.join(start.point_names)}",
                             "--free-points")
    read = read_measurement_file(path, start.point_names)
    measurements, lines = read.measurements, read.lines
    warn(read.warnings)
    if request.distances and np.any(measurements.has_orientation):
        warn(["orientations are ignored when identifying from distances"])
    options, said = _with_compliance_default(request, options, start, read.measurements)
    try:
        result = identify(start, measurements, request.rotary_model, options=options)
    except AssemblyError as exc:
        # at the nominal geometry: the readings themselves are impossible
        if not exc.indices:
            raise
        raise unassembled_rows(exc, path, lines, measurements.q, f"the robot {nominal.name!r}") from exc
    except PoorFitError as exc:
        raise IdentificationError(f"{path}: {exc}; nothing written (--accept-poor-fit keeps such a "
                                  "fit)") from exc
    except IdentificationError as exc:
        at = lines[exc.rows].tolist()
        where = f"line{'s' if len(at) > 1 else ''} {lines_text(at)}: " if at else ""
        raise IdentificationError(f"{path}: {where}{exc.detail}") from exc
    except ConvergenceError as exc:
        raise ConvergenceError(f"{path}: {exc}", exc.residual) from exc
    warn(result.warnings)
    save_calibration(result, request.output, lines)  # saved first: a failing stdout loses no result
    if result.outliers:
        flagged = lines_text(lines[result.outliers].tolist())
        warn([f"{path}: line(s) {flagged} look like outliers (see the report): check them, or remove them "
              "and identify again"])
    return Done((*said, result.report(lines), f"\nwrote {request.output}"))


def _with_compliance_default(request: IdentifyRequest, options: FitOptions, start: DeltaGeometry,
                             measurements: Measurements) -> tuple[FitOptions, tuple[str, ...]]:
    """The options, with the compliances identified where the payloads vary (see conventions.md), and why.

    Payloads that vary with the masses known: the compliances are identified (said on stdout);
    with no ``[masses]``, the choice is the user's (``--compliance`` or ``--rigid``), refused
    otherwise: a rigid fit would spread the deflections over the geometry.
    """
    span = payload_span(measurements)
    if span is None or request.rigid or request.compliance or request.distances:
        return options, ()
    payloads = f"payload_kg varies from {span[0]:g} to {span[1]:g} kg"
    path = request.measurements[0]
    if start.masses.is_zero:
        raise InputError(
            f"{payloads} but {request.nominal} has no [masses]: a rigid fit would take the actuators' "
            "deflections for geometry; give --compliance (the compliances from the payloads' torques alone, "
            "the robot's own weight taken up by the geometry), the robot's [masses], or --rigid",
            str(path), "column payload_kg")
    said = (f"{path}: {payloads} and {request.nominal} gives the masses: the actuators' compliances are "
            "identified too (--rigid fits a rigid robot)")
    return replace(options, compliance=True), (said,)
