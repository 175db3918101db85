"""``deltacal demo``: the whole job on a simulated robot."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from ..demo import controller_table, run_demo, text_table
from ..exceptions import UsageError
from ..printer.demo import SEED, printer_table, run_printer_demo
from ..printer.firmware import firmware_named, firmwares
from ..printer.firmware.config_file import firmware_names
from .common import seed


def run(args: argparse.Namespace) -> int:
    """Run ``deltacal demo``: progress on stderr, the table on stdout; returns 0."""
    start = time.perf_counter()

    def progress(text: str) -> None:
        print(f"[{time.perf_counter() - start:5.1f} s] {text}", file=sys.stderr, flush=True)

    if args.firmware is not None and not args.printer:
        raise UsageError("--firmware applies to the printer demo (--printer)")
    if args.printer:
        firmware = (firmware_named(args.firmware) if args.firmware else None) or firmwares()[0]  # Klipper
        summary = run_printer_demo(out_dir=Path(args.out or "printer_demo"),
                                   seed=SEED if args.seed is None else args.seed, quick=args.quick,
                                   progress=progress, firmware=firmware)
        print(printer_table(summary))
        return 0
    summary = run_demo(out_dir=Path(args.out or "results"), seed=2015 if args.seed is None else args.seed,
                       quick=args.quick, progress=progress)
    print(text_table(summary) + controller_table(summary))
    return 0


def add_parser(sub) -> None:
    """Register ``demo``."""
    p = sub.add_parser("demo", help="the whole job on a simulated robot (bai2015; --printer: a printer)")
    p.add_argument("--out", help="folder for demo.json and plots (default results; --printer: printer_demo)")
    p.add_argument("--seed", type=seed, help=f"seed of the simulated robot (default 2015; --printer {SEED})")
    p.add_argument("--quick", action="store_true", help="fewer poses (--printer: a shorter part)")
    p.add_argument("--printer", action="store_true",
                   help="a linear Delta printer (models/kossel.toml) through Klipper, beside Klipper's own "
                        "calibration: printer.cfg, the object's files, printer_calibration.toml, "
                        "printer_calibrated.cfg, part_corrected.gcode and printer_demo.json")
    p.add_argument("--firmware", choices=firmware_names(),
                   help="--printer: the firmware the printer runs (default klipper; marlin: m503.txt and "
                        "G33, rrf: config.g and G32)")
    p.set_defaults(func=run)
