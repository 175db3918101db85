"""``deltacal view``: the robot in 3-D (meshcat), served or written as a standalone page."""

from __future__ import annotations

import argparse
import math
import signal
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from ..exceptions import InputError
from ..geometry import Tolerances
from ..io import load_geometry
from ..io.paths import check_input, check_output
from ..robots import load_robot
from ..viz import DEFAULT_EXAGGERATION, build_scene, export_html, meshcat_server, words
from .common import positive_float, seed


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Register ``view``."""
    p = subparsers.add_parser(
        "view",
        help="show a robot in 3-D (meshcat): true robot over its nominal ghost, TCP errors",
        description=(
            "Show the true robot over its nominal ghost at the workspace centre, the plate "
            "tilt exaggerated, TCP error arrows over the workspace and an animation along a path; "
            "a printer (robot file of kind 'linear'): its towers, carriages, rods, effector and nozzle "
            "over the bed. Without --html, serve the scene with meshcat until Ctrl-C."
        ),
    )
    p.add_argument("nominal", metavar="NOMINAL", type=Path, help="nominal robot file (TOML; either kind)")
    source = p.add_mutually_exclusive_group()
    source.add_argument("--truth", metavar="TRUE.toml", type=Path, help="geometry file of the true robot")
    source.add_argument(
        "--calibration", metavar="CAL", type=Path, help="calibration file: show its identified geometry"
    )
    source.add_argument(
        "--perturb",
        metavar="SEED",
        type=seed,
        help="a random robot around the nominal (Bai 2015 tolerances; a printer: a typical kit's)",
    )
    p.add_argument(
        "--exaggerate",
        metavar="K",
        type=positive_float,
        default=DEFAULT_EXAGGERATION,
        help=f"factor on the drawn plate tilt (default {DEFAULT_EXAGGERATION:g})",
    )
    p.add_argument("--html", metavar="OUT.html", type=Path, help="write a standalone HTML page and exit")
    p.set_defaults(func=run)
    return p


def run(args: argparse.Namespace) -> int:
    """Run ``deltacal view``: write the HTML page, or serve the scene until Ctrl-C; returns the status."""
    inputs = (args.nominal, args.truth, args.calibration)
    for path in inputs:
        if path is not None:
            check_input(path)
    if args.html is not None:
        check_output(args.html, inputs)
    nominal = load_robot(args.nominal)
    nominal_geometry = nominal.geometry()
    source = args.truth if args.truth is not None else args.calibration
    if source is not None:
        true_geometry = load_geometry(source)
        true, nominal_chain = true_geometry.chain, nominal_geometry.chain
        if true != nominal_chain:
            raise InputError(f"{true.words.a_robot} ({true.name} chain), while {args.nominal} is "
                             f"{nominal_chain.words.a_robot} ({nominal_chain.name} chain): give a robot file "
                             "of the same kind",
                             str(source), "key joint")
    elif args.perturb is not None:
        tolerances = getattr(Tolerances, nominal_geometry.chain.typical_tolerances)()
        true_geometry = nominal_geometry.perturbed(tolerances, np.random.default_rng(args.perturb))
    else:
        true_geometry = nominal_geometry
    options: dict[str, Any] = {"exaggerate": args.exaggerate, "workspace": nominal.workspace}
    if args.html is not None:
        summary = export_html(nominal_geometry, true_geometry, args.html, animate=True, **options)
        plate, tcp = words(nominal_geometry)
        print(
            f"wrote {args.html}: {plate} tilt {math.degrees(summary.tilt):.4f} deg "
            f"(drawn x{summary.exaggerate:g}), largest {tcp} error {summary.max_error:.3f} mm"
        )
        return 0
    try:
        with meshcat_server() as vis:
            build_scene(vis, nominal_geometry, true_geometry, animate=True, **options)
            print(vis.url(), flush=True)
            print("serving the scene; press Ctrl-C to stop", file=sys.stderr, flush=True)
            _wait_for_interrupt()
    except KeyboardInterrupt:  # before the scene was up; the server is stopped all the same
        return 130
    return 0


def _wait_for_interrupt() -> None:
    """Sleep until Ctrl-C (or SIGTERM, treated the same)."""

    def on_term(signum: int, frame: Any) -> None:
        raise KeyboardInterrupt

    previous = signal.signal(signal.SIGTERM, on_term)
    try:
        while True:
            time.sleep(0.5)
    except KeyboardInterrupt:
        pass
    finally:
        signal.signal(signal.SIGTERM, previous)
