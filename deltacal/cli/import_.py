"""``deltacal import``: a printer as it is found (its ``printer.cfg``), or its probe results (a log).

``deltacal import printer.cfg -o DIR`` writes ``DIR/printer.toml`` and, from the SAVE_CONFIG
block's ``[delta_calibrate]``, ``DIR/probe.csv`` and ``DIR/distances.csv``;
``deltacal import klippy.log [--config printer.cfg] -o probe.csv`` writes the log's probe results
(Klipper's lines from 2026 need the configuration's probe offsets). The kind of input is
told by its content: Klipper's probe results or a log's marks make a log, anything else is read as
a configuration.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from ..exceptions import InputError, UsageError
from ..io.atomic import atomic_write_text
from ..printer.firmware import log_firmware
from ..printer.firmware.base import Firmware
from ..printer.firmware.klipper.importer import (
    DEFAULT_EFFECTOR_RADIUS,
    DEFAULT_NOZZLE_DROP,
    DEFAULT_ROD_SPACING,
    OUTPUT_FILES,
    import_klipper,
    write_import,
)
from ..printer.firmware.marlin.firmware import MARLIN
from ..printer.firmware.marlin.importer import import_marlin
from ..printer.measurement_files import write_probe_heights
from .common import check_input, check_output, check_output_folder, positive_float


def run(args: argparse.Namespace) -> int:
    """Run ``deltacal import``; returns 0."""
    check_input(args.input)
    try:
        text = Path(args.input).read_text(encoding="utf-8", errors="replace")
    except OSError as exc:
        raise InputError(f"cannot read the file ({exc.strerror})", args.input) from None
    firmware = log_firmware(text)
    if firmware is not None:
        return _run_log(args, text, firmware)
    if args.config is not None:
        raise UsageError(f"--config applies to a log; {args.input} is read as a printer.cfg")
    folder = Path(args.output)
    check_output_folder(folder, OUTPUT_FILES, [args.input], "import of a printer's configuration")
    if MARLIN.is_config(args.input):
        return _run_marlin(args, folder)
    imported = import_klipper(args.input, args.effector_radius, args.rod_spacing, args.nozzle_drop)
    if not folder.exists():
        folder.mkdir()
    written = write_import(imported, folder)
    saved = imported.saved
    defaults = f"; defaults taken: {', '.join(imported.defaults)}" if imported.defaults else ""
    print(f"wrote {written[0]}: Klipper's model of {args.input} (delta_radius "
          f"{imported.klipper.delta_radius:g} mm){defaults}")
    if saved.empty:
        print("no [delta_calibrate] measurements in its SAVE_CONFIG block: no probe.csv, no distances.csv")
    for path in written[1:]:
        rows = saved.height.size if path.name == OUTPUT_FILES[1] else saved.distance.size
        print(f"wrote {path}: {rows} rows saved by Klipper's DELTA_CALIBRATE / DELTA_ANALYZE")
    return 0


def _run_log(args: argparse.Namespace, text: str, firmware: Firmware) -> int:
    """A log's probe results into a probe heights file."""
    flags = ("effector_radius", "rod_spacing", "nozzle_drop")
    given = [flag for flag in flags if getattr(args, flag) is not None]
    if given:
        raise UsageError(f"--{given[0].replace('_', '-')} applies to a printer.cfg; {args.input} is a log")
    output = Path(args.output)
    if output.is_dir():
        raise UsageError(f"{output}: a log's probe results go to a file (-o probe.csv); this is a folder")
    if args.config is not None:
        check_input(args.config)
    check_output(output, [args.input] + ([args.config] if args.config else []))
    log = firmware.read_probe_log(args.input, text, args.config)
    write_probe_heights(output, log.commanded[:, :2], log.commanded[:, 2], log.trigger_height)
    trigger = "" if log.trigger_height is None else \
        f", trigger height {log.trigger_height[0]:g} mm (the probe's offset in {args.config})"
    print(f"wrote {output}: {len(log.commanded)} probe results of {firmware.name.capitalize()} (lines "
          f"{log.lines[0]}..{log.lines[-1]} of {args.input}){trigger}")
    return 0


def _run_marlin(args: argparse.Namespace, folder: Path) -> int:
    """An ``M503`` capture into ``DIR/printer.toml``."""
    given = {"effector radius": (args.effector_radius, DEFAULT_EFFECTOR_RADIUS),
             "rod spacing": (args.rod_spacing, DEFAULT_ROD_SPACING),
             "nozzle drop": (args.nozzle_drop, DEFAULT_NOZZLE_DROP)}
    defaults = tuple(f"{what} {default:g} mm" for what, (value, default) in given.items() if value is None)
    a, c, drop = (default if value is None else float(value) for value, default in given.values())
    text, marlin = import_marlin(args.input, a, c, drop, defaults)
    if not folder.exists():
        folder.mkdir()
    written = atomic_write_text(folder / OUTPUT_FILES[0], text)
    taken = f"; defaults taken: {', '.join(defaults)}" if defaults else ""
    print(f"wrote {written}: Marlin's model of {args.input} (M665 R {marlin.radius:g} mm){taken}")
    return 0


def add_parser(sub) -> None:
    """Register ``import``."""
    p = sub.add_parser("import", help="a printer as it is found: printer.cfg -> DIR/printer.toml (+ "
                                      "probe.csv, distances.csv saved by DELTA_CALIBRATE); klippy.log -> "
                                      "probe.csv")
    p.add_argument("input", metavar="printer.cfg|klippy.log",
                   help="a Klipper configuration, or a log (klippy.log, a saved console) with probe results")
    p.add_argument("-o", "--output", required=True, metavar="DIR|probe.csv",
                   help="a printer.cfg: the folder to write into (made if its parent exists); a log: the "
                        "file")
    p.add_argument("--config", metavar="printer.cfg",
                   help="a log: the printer's configuration, for its probe's offsets ([probe] x_offset, "
                        "y_offset, z_offset): needed by Klipper's 'probe: at X,Y bed will contact at z=Z'")
    p.add_argument("--effector-radius", type=positive_float, metavar="MM",
                   help="effector centre to each ball pair's midpoint [mm] (not in printer.cfg; default 30)")
    p.add_argument("--rod-spacing", type=positive_float, metavar="MM",
                   help="between the two balls of a pair [mm] (not in printer.cfg; default 50)")
    p.add_argument("--nozzle-drop", type=positive_float, metavar="MM",
                   help="the nozzle below the effector's ball plane [mm] (not in printer.cfg; default 30)")
    p.set_defaults(func=run)
