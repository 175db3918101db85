"""The ``deltacal`` command line; nothing else in the package imports it."""

from .main import build_parser, main

__all__ = ["build_parser", "main"]
