"""``deltacal plan PRINTER.toml --object --controller printer.cfg -o DIR``: the printed calibration object.

Writes ``DIR/object.stl`` (the object, in the printer's coordinates), ``DIR/probe.csv`` (the probe
grid, ``z_mm`` to fill in), ``DIR/probe.gcode`` (the firmware's program that probes that grid, its
results on the console), ``DIR/distances.csv`` (the pairs of features to measure, the labels of
their balls, ``distance_mm`` to fill in) and ``DIR/sheet.html`` (the measuring sheet: a top view
with the labels and the pairs in the order of distances.csv), and prints what was planned: what
the probe heights alone identify of the complete model and what the object's distances add.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from ..exceptions import UsageError
from ..io import write_stl
from ..io.atomic import atomic_write_text
from ..printer.files.measurements import write_printed_distances, write_probe_heights
from ..printer.firmware import config_files
from ..printer.printed.object import BALL_DIAMETER, CALIPER_RANGE, MAX_DISTANCES
from ..printer.printed.plan import ObjectPlan, plan_object
from ..printer.printed.sheet import sheet_html
from ..printer.robot import NominalLinearDelta
from ..robots import load_robot
from .common import check_input, check_output_folder, int_at_most, positive_float
from .firmware import add_firmware_argument, controller_firmware

#: The files ``plan --object`` writes in its folder.
OBJECT_FILES = ("object.stl", "probe.csv", "distances.csv", "probe.gcode", "sheet.html")
#: Largest probe grid: 9 across the bed, whose round mesh keeps 49 points (the budget: at most 49 heights).
MAX_PROBE_GRID = 9

#: ``plan`` options of pose planning, which ``--object`` does not take.
POSE_OPTIONS = ("model", "n", "epsilon", "strategy", "measure", "points", "count", "pool", "seed", "payload",
                "n_max")
#: ``plan --object`` options, which pose planning does not take (with their defaults).
OBJECT_OPTIONS = {"controller": None, "firmware": None, "distances": None, "probe_grid": None,
                  "caliper": None}


def probe_grid_size(text: str) -> int:
    """Argparse type: an odd number of probe points across the bed, 3 to :data:`MAX_PROBE_GRID`."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None
    if value < 3 or value > MAX_PROBE_GRID or value % 2 == 0:
        raise argparse.ArgumentTypeError(f"must be odd, 3 to {MAX_PROBE_GRID} (Klipper's round_probe_count; "
                                         f"9 keeps 49 points within the radius), got {value}")
    return value


def add_object_arguments(p: argparse.ArgumentParser) -> None:
    """The ``--object`` options of ``plan``."""
    p.add_argument("--object", action="store_true",
                   help="a linear Delta printer: plan the probe grid and the object to print and measure "
                        "(-o DIR gets object.stl, probe.csv, probe.gcode, distances.csv and sheet.html)")
    p.add_argument("--controller", metavar="SETTINGS",
                   help="--object: the firmware's settings (Klipper's printer.cfg, Marlin's M503 "
                        "capture, RepRapFirmware's config.g) the probing and the print are commanded with")
    add_firmware_argument(p)
    p.add_argument("--distances", type=int_at_most(MAX_DISTANCES, "caliper distances of the object"),
                   metavar="N", help=f"--object: distances to measure (default and most: {MAX_DISTANCES})")
    p.add_argument("--probe-grid", type=probe_grid_size, metavar="N",
                   help="--object: probe points across the bed, odd (default 7: Klipper's round 7 x 7 mesh)")
    p.add_argument("--caliper", type=positive_float, metavar="MM",
                   help=f"--object: the caliper's longest outside reading (default {CALIPER_RANGE:g} mm)")


def refuse_object_options(args: argparse.Namespace) -> None:
    """Pose planning was asked: refuse the options of ``--object``."""
    given = [name for name in OBJECT_OPTIONS if getattr(args, name) is not None]
    if given:
        option = given[0].replace("_", "-")
        raise UsageError(f"--{option} applies to --object (a printer's calibration object)")


def run_object(args: argparse.Namespace) -> int:
    """Run ``deltacal plan --object``: write the files, print what was planned, return 0."""
    given = [name for name in POSE_OPTIONS if getattr(args, name) is not None]
    if given:
        raise UsageError(f"--{given[0].replace('_', '-')} applies to pose planning, not to --object")
    if args.controller is None:
        raise UsageError("--object needs --controller printer.cfg: the firmware the object is printed with")
    check_input(args.controller)
    folder = Path(args.output)
    read = config_files(args.controller, args.firmware)
    outputs = check_output_folder(folder, OBJECT_FILES, (args.nominal, *read), "plan --object")
    printer = load_robot(args.nominal)
    if not isinstance(printer, NominalLinearDelta):
        raise UsageError(f"{args.nominal}: --object plans a linear Delta printer's object; this robot file "
                         "is a rotary Delta's (kind = 'linear' for a printer)")
    kind = controller_firmware(args.controller, args.firmware)
    firmware = kind.read_config(args.controller)
    kind.check_same_printer(kind.nominal(printer), firmware, args.nominal, args.controller)
    travel = kind.probe_travel(args.controller)
    caliper = args.caliper or CALIPER_RANGE
    plan = plan_object(printer, firmware, count=args.distances,
                       probe_count=args.probe_grid or MAX_PROBE_GRID, caliper=caliper)
    mesh = plan.labelled_mesh()
    if not folder.exists():
        folder.mkdir()
    write_stl(outputs[0], mesh)
    write_probe_heights(outputs[1], plan.probe)
    names = plan.names
    write_printed_distances(outputs[2], plan.pair_positions,
                            balls=[(names[i], names[j]) for i, j in plan.pairs.tolist()])
    atomic_write_text(outputs[3], kind.probe_program(
        plan.probe, title=f"deltacal plan --object: the probe grid of {printer.name} ({outputs[1].name})",
        clearance=travel))
    assert printer.workspace is not None  # plan_object refused a printer without one
    atomic_write_text(outputs[4], sheet_html(plan, printer.workspace.radius, f"{printer.name}: the printed "
                                             "object's distances", printer.tower_azimuth))
    print(_report(plan, printer, mesh, caliper))
    if args.distances is None and len(plan.pairs) < MAX_DISTANCES:
        print(f"note: with a caliper of {caliper:g} mm the object offers {len(plan.pairs)} distances that "
              f"can be measured together ({MAX_DISTANCES} with a longer one): planned the {len(plan.pairs)}")
    print(f"wrote {outputs[0]}, {outputs[1]} ({len(plan.probe)} probe points; {outputs[3]} probes them), "
          f"{outputs[2]} ({len(plan.pairs)} distances) and {outputs[4]} (the sheet to measure them with)")
    return 0


def _report(plan: ObjectPlan, printer: NominalLinearDelta, mesh, caliper: float) -> str:
    radius = float(abs(plan.probe[:, :2]).max())
    heights = sorted({float(z) for z in plan.features[:, 2]})
    lengths = plan.lengths
    lines = [
        f"probe grid: {len(plan.probe)} points (Klipper's round mesh, radius {radius:g} mm); run probe.gcode "
        "(it homes, then probes at each) and read its console back (deltacal import LOG), or write the "
        "commanded z at which the probe triggered in probe.csv",
        f"object: {len(plan.features)} balls of {BALL_DIAMETER:g} mm on posts, centres at heights "
        f"{', '.join(f'{z:g}' for z in heights)} mm, each labelled 1 to {len(plan.features)} on a tile "
        "beside it; "
        f"{len(mesh.faces)} facets, "
        f"height {mesh.bounds[1, 2]:g} mm; print object.stl where it stands (printer coordinates, origin at "
        "the bed's centre: the slicer must not move it)",
        f"distances: {len(plan.pairs)} pairs of ball centres, {lengths.min():.1f} to {lengths.max():.1f} mm "
        f"(readings up to {lengths.max() + BALL_DIAMETER:.1f} mm: a {caliper:g} mm caliper, --caliper): "
        "outside jaws across both balls, rocked to the largest reading, minus the balls' mean diameter; "
        "write each in distances.csv",
        f"D-optimal (complete model, in units of the build tolerances): log det {plan.log_det_probe:.4g} "
        f"with the probe heights alone, {plan.log_det:.4g} with the distances",
    ]
    if plan.probe_only is not None and plan.with_distances is not None:
        alone, both = plan.probe_only, plan.with_distances
        lines.append(f"probe heights alone identify {alone.rank} of the {len(alone.names)} complete-model "
                     f"combinations better than the build tolerances: {', '.join(alone.base_names)}")
        added = ", ".join(plan.added_names()) or "none"
        lines.append(f"the distances add {both.rank - alone.rank}: {added}; "
                     f"{len(both.names) - both.rank} stay within their tolerances only")
    return "\n".join(lines)
