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
from ..printer.firmware.klipper.config import read_klipper_config
from ..printer.firmware.klipper.importer import OUTPUT_FILES, import_klipper, write_import
from ..printer.firmware.klipper.log import is_probe_log, probe_offsets, read_probe_log
from ..printer.measurement_files import write_probe_heights
from .common import check_input, check_output, check_output_folder, positive_float


def run(args: argparse.Namespace) -> int:
    """Run ``deltacal import``; returns 0."""
    check_input(args.input)
    try:
        text = Path(args.input).read_text(encoding="utf-8", errors="replace")
    except OSError as exc:
        raise InputError(f"cannot read the file ({exc.strerror})", args.input) from None
    if is_probe_log(text):
        return _run_log(args, text)
    if args.config is not None:
        raise UsageError(f"--config applies to a log; {args.input} is read as a printer.cfg")
    folder = Path(args.output)
    check_output_folder(folder, OUTPUT_FILES, [args.input], "import of a printer.cfg")
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


def _run_log(args: argparse.Namespace, text: str) -> int:
    """A log's probe results into a probe heights file."""
    flags = ("effector_radius", "rod_spacing", "nozzle_drop")
    given = [flag for flag in flags if getattr(args, flag) is not None]
    if given:
        raise UsageError(f"--{given[0].replace('_', '-')} applies to a printer.cfg; {args.input} is a log")
    output = Path(args.output)
    if output.is_dir():
        raise UsageError(f"{output}: a log's probe results go to a file (-o probe.csv); this is a folder")
    offsets = None
    if args.config is not None:
        check_input(args.config)
        offsets = probe_offsets(read_klipper_config(args.config))
    check_output(output, [args.input] + ([args.config] if args.config else []))
    log = read_probe_log(args.input, text, offsets)
    write_probe_heights(output, log.commanded[:, :2], log.commanded[:, 2], log.trigger_height)
    trigger = "" if offsets is None else f", trigger height {offsets.z:g} mm (z_offset of {args.config})"
    print(f"wrote {output}: {len(log.commanded)} probe results (lines {log.lines[0]}..{log.lines[-1]} of "
          f"{args.input}){trigger}")
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
