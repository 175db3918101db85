"""``deltacal compare``: what changed in a printer between two of its calibrations, in its owner's words."""

from __future__ import annotations

import argparse

from .. import wings
from ..wings.requests import CompareRequest
from .common import request, show


def run(args: argparse.Namespace) -> int:
    """Run ``deltacal compare``; returns the exit status."""
    return show(wings.compare(request(CompareRequest, args)))


def add_parser(sub) -> None:
    """Register ``compare``."""
    p = sub.add_parser(
        "compare",
        help="what changed in a printer between two of its calibrations, each change with its σ",
        description=(
            "Compare two calibrations of one printer (identify's, through the same firmware configuration): "
            "each tower's endstop, travel, leans and rods and the bed's slope, the change new - old with its "
            "σ (both calibrations' in quadrature) and whether it is significant (measured by both and beyond "
            "3 σ). Three or more: the printer's history, each step between consecutive calibrations, all "
            "under the newest's prior."
        ),
    )
    p.add_argument("old", metavar="OLD.toml", help="the older calibration file")
    p.add_argument("new", metavar="NEW.toml", nargs="+",
                   help="the newer calibration file; several: each newer than the one before (oldest first), "
                        "each step between consecutive ones compared")
    p.add_argument("-o", "--output", metavar="COMPARE.html", help="also write the changes as an HTML page")
    p.set_defaults(func=run)
