"""``deltacal import``: a printer as it is found (its configuration), or its probe results (a log).

The job is the printer wing's (:mod:`deltacal.wings.printer.importing`): the input's content tells a
configuration (``printer.cfg``, ``config.g``, an ``M503`` capture: ``-o DIR``) from a log (``-o probe.csv``),
or ``--firmware`` names its firmware.
"""

from __future__ import annotations

import argparse

from .. import wings
from ..wings.requests import ImportRequest
from .common import add_firmware_argument, positive_float, request, show


def run(args: argparse.Namespace) -> int:
    """Run ``deltacal import``; returns 0."""
    return show(wings.import_found(request(ImportRequest, args)))


def add_parser(sub) -> None:
    """Register ``import``."""
    p = sub.add_parser("import", help="a printer as it is found: printer.cfg, config.g or an M503 capture -> "
                                      "DIR/printer.toml (+ probe.csv, distances.csv saved by "
                                      "DELTA_CALIBRATE); a log -> probe.csv")
    p.add_argument("input", metavar="printer.cfg|config.g|m503.txt|LOG",
                   help="a Klipper printer.cfg, a RepRapFirmware config.g, Marlin's settings (the printer's "
                        "answer to M503, saved from its console), or a log (klippy.log, a saved console) "
                        "with probe results")
    p.add_argument("-o", "--output", required=True, metavar="DIR|probe.csv",
                   help="a configuration: the folder to write into (made if its parent exists); a log: the "
                        "file")
    p.add_argument("--config", metavar="printer.cfg|config.g|m503.txt",
                   help="a log: the printer's configuration, for its probe's offsets (Klipper's [probe] "
                        "x_offset, y_offset, z_offset, needed by its 'probe: at X,Y bed will contact at "
                        "z=Z'; RepRapFirmware's G31 X Y Z): each row's trigger_height_mm")
    p.add_argument("--effector-radius", type=positive_float, metavar="MM",
                   help="effector centre to each ball pair's midpoint [mm] (in no configuration; default 30)")
    p.add_argument("--rod-spacing", type=positive_float, metavar="MM",
                   help="between the two balls of a pair [mm] (in no configuration; default 50)")
    p.add_argument("--nozzle-drop", type=positive_float, metavar="MM",
                   help="the nozzle below the effector's ball plane [mm] (in no configuration; default 30)")
    add_firmware_argument(p, "INPUT")
    p.set_defaults(func=run)
