"""``deltacal demo``: the whole job on a simulated robot."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from ..demo import controller_table, run_demo, text_table
from .common import seed


def run(args: argparse.Namespace) -> int:
    """Run ``deltacal demo``: progress on stderr, the table on stdout; returns 0."""
    start = time.perf_counter()

    def progress(text: str) -> None:
        print(f"[{time.perf_counter() - start:5.1f} s] {text}", file=sys.stderr, flush=True)

    summary = run_demo(out_dir=Path(args.out), seed=args.seed, quick=args.quick, progress=progress)
    print(text_table(summary) + controller_table(summary))
    return 0


def add_parser(sub) -> None:
    """Register ``demo``."""
    p = sub.add_parser("demo", help="the whole job on a simulated robot (bai2015)")
    p.add_argument("--out", default="results", help="folder for demo.json and plots (default results)")
    p.add_argument("--seed", type=seed, default=2015, help="seed of the simulated robot (default 2015)")
    p.add_argument("--quick", action="store_true", help="fewer poses, for a fast check")
    p.set_defaults(func=run)
