"""``deltacal compensate``: joint readings that put the TCP at target positions."""

from __future__ import annotations

import argparse

import numpy as np

from ..compensation import METHODS, compensate
from ..exceptions import InputError, UnreachableError, UsageError
from ..io import (
    data_row,
    load_geometry,
    load_instrument,
    load_linear_calibration,
    read_target_table,
    write_joints,
)
from .common import check_input, check_output, lines_text, warn


def run(args: argparse.Namespace) -> int:
    """Run ``deltacal compensate``; returns the exit status."""
    for path in (args.calibration, args.targets):
        check_input(path)
    check_output(args.output, (args.calibration, args.targets))
    geometry = load_geometry(args.calibration)
    table = read_target_table(args.targets)
    warn(table.warnings)
    targets = np.column_stack([table.numbers[c] for c in ("x_mm", "y_mm", "z_mm")])
    frames = load_instrument(args.calibration)
    if frames and args.method != "exact":
        raise UsageError(
            f"{args.calibration}: identified with a free instrument frame: its base parameters are in the "
            "fit's own gauge, which savoure and bai cannot follow; use --method exact"
        )
    if args.frame == "instrument":
        if not frames:
            raise UsageError(f"{args.calibration}: no [instrument] table: --frame instrument needs a "
                             "calibration identified with --frame free")
        station = args.station
        if station is None:
            if len(frames) > 1:
                raise UsageError(f"--station is needed: the calibration has stations {', '.join(frames)}")
            station = next(iter(frames))
        if station not in frames:
            raise UsageError(f"--station {station!r}: the calibration's stations are {', '.join(frames)}")
        targets_in_base = frames[station].to_base(targets)
    elif args.station is not None:
        raise UsageError("--station applies to --frame instrument only")
    else:
        targets_in_base = targets
    linear = load_linear_calibration(args.calibration) if args.method != "exact" else None
    try:
        q = compensate(geometry, targets_in_base, args.method, linear)
    except UnreachableError as exc:
        if not exc.indices:
            raise
        lines = table.lines[exc.indices].tolist()
        k = exc.indices[0]
        more = f"; {len(lines)} targets in all, lines {lines_text(lines)}" if len(lines) > 1 else ""
        raise InputError(
            f"target {np.round(targets[k], 6).tolist()} mm is {UnreachableError.WORDS[exc.reason]}{more}",
            args.targets, f"{data_row(lines[0], k + 1)}, columns x_mm..z_mm",
        ) from exc
    write_joints(args.output, targets, q)
    print(f"wrote {len(targets)} joint readings to {args.output}")
    return 0


def add_parser(sub) -> None:
    """Register ``compensate``."""
    p = sub.add_parser("compensate", help="joint readings that put the TCP at target positions")
    p.add_argument("calibration", help="calibration file written by identify (TOML)")
    p.add_argument("targets", help="targets (CSV: x_mm,y_mm,z_mm)")
    p.add_argument("-o", "--output", required=True, help="joints file to write (CSV)")
    p.add_argument("--method", choices=METHODS, default="exact",
                   help="exact (default), or a linear compensator: savoure (Eq. 29-33), bai (Eq. 22-25)")
    p.add_argument("--frame", choices=("base", "instrument"), default="base",
                   help="targets in the robot base frame {O} (default), or in the instrument frame {T} of a "
                        "calibration identified with --frame free")
    p.add_argument("--station", help="with --frame instrument: the station whose frame the targets are in")
    p.set_defaults(func=run)
