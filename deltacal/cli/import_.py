"""``deltacal import``: a printer as it is found (its configuration), or its probe results (a log).

``deltacal import printer.cfg -o DIR`` (or RepRapFirmware's ``config.g``) writes ``DIR/printer.toml``
and, from Klipper's SAVE_CONFIG block's ``[delta_calibrate]``, ``DIR/probe.csv`` and
``DIR/distances.csv``; ``deltacal import LOG [--config CONFIG] -o probe.csv`` writes the log's probe
results (the configuration gives the probe's offsets: Klipper's lines from 2026 need them). The
kind of input is told by its content, each firmware asked in turn
(:meth:`~deltacal.printer.firmware.base.Firmware.is_probe_log`, then
:meth:`~deltacal.printer.firmware.base.Firmware.is_config`); a file none recognises is read as a
Klipper ``printer.cfg``.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from ..exceptions import InputError, UsageError
from ..io.paths import check_input, check_output, check_output_folder
from ..printer.files.importer import OUTPUT_FILES
from ..printer.files.measurements import write_probe_heights
from ..printer.firmware import config_firmware, firmwares, log_firmware
from ..printer.firmware.base import Firmware
from .common import positive_float


def run(args: argparse.Namespace) -> int:
    """Run ``deltacal import``; returns 0."""
    check_input(args.input)
    try:
        text = Path(args.input).read_text(encoding="utf-8", errors="replace")
    except OSError as exc:
        raise InputError(f"cannot read the file ({exc.strerror})", args.input) from None
    logged = log_firmware(text)
    if logged is not None:
        return _run_log(args, text, logged)
    # a file no firmware recognises is read as the first firmware's (Klipper's printer.cfg)
    firmware = config_firmware(args.input) or firmwares()[0]
    if args.config is not None:
        raise UsageError(f"--config applies to a log; {args.input} is read as {firmware.title}'s "
                         "configuration")
    folder = Path(args.output)
    check_output_folder(folder, OUTPUT_FILES, [args.input], f"import of {firmware.title}'s configuration")
    made = not folder.exists()
    if made:
        folder.mkdir()
    try:
        imported = firmware.import_config(args.input, folder, args.effector_radius, args.rod_spacing,
                                          args.nozzle_drop)
    except BaseException:
        if made and not any(folder.iterdir()):
            folder.rmdir()  # nothing written: no folder left behind either
        raise
    for line in imported.said:
        print(line)
    return 0


def _run_log(args: argparse.Namespace, text: str, firmware: Firmware[Any]) -> int:
    """A log's probe results into a probe heights file."""
    flags = ("effector_radius", "rod_spacing", "nozzle_drop")
    given = [flag for flag in flags if getattr(args, flag) is not None]
    if given:
        raise UsageError(f"--{given[0].replace('_', '-')} applies to a configuration; {args.input} is a log")
    output = Path(args.output)
    if output.is_dir():
        raise UsageError(f"{output}: a log's probe results go to a file (-o probe.csv); this is a folder")
    if args.config is not None:
        check_input(args.config)
    check_output(output, [args.input] + ([args.config] if args.config else []))
    log = firmware.read_probe_log(args.input, args.config, text)
    write_probe_heights(output, log.commanded[:, :2], log.commanded[:, 2], log.trigger_height)
    trigger = ""
    if log.trigger_height is not None:
        trigger = f", trigger height {log.trigger_height[0]:g} mm ({log.trigger_source})"
    print(f"wrote {output}: {len(log.commanded)} probe results of {firmware.title} (lines {log.lines[0]}.."
          f"{log.lines[-1]} of {args.input}){trigger}")
    return 0


def add_parser(sub) -> None:
    """Register ``import``."""
    p = sub.add_parser("import", help="a printer as it is found: printer.cfg or config.g -> DIR/printer.toml "
                                      "(+ probe.csv, distances.csv saved by DELTA_CALIBRATE); a log -> "
                                      "probe.csv")
    p.add_argument("input", metavar="printer.cfg|config.g|LOG",
                   help="a Klipper or RepRapFirmware configuration, or a log (klippy.log, a saved console) "
                        "with probe results")
    p.add_argument("-o", "--output", required=True, metavar="DIR|probe.csv",
                   help="a configuration: the folder to write into (made if its parent exists); a log: the "
                        "file")
    p.add_argument("--config", metavar="printer.cfg|config.g",
                   help="a log: the printer's configuration, for its probe's offsets (Klipper's [probe] "
                        "x_offset, y_offset, z_offset, needed by its 'probe: at X,Y bed will contact at "
                        "z=Z'; RepRapFirmware's G31 X Y Z): each row's trigger_height_mm")
    p.add_argument("--effector-radius", type=positive_float, metavar="MM",
                   help="effector centre to each ball pair's midpoint [mm] (in no configuration; default 30)")
    p.add_argument("--rod-spacing", type=positive_float, metavar="MM",
                   help="between the two balls of a pair [mm] (in no configuration; default 50)")
    p.add_argument("--nozzle-drop", type=positive_float, metavar="MM",
                   help="the nozzle below the effector's ball plane [mm] (in no configuration; default 30)")
    p.set_defaults(func=run)
