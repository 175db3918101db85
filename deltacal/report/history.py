"""The comparison page: what changed in a printer between two calibrations, one self-contained HTML file.

The page of ``deltacal compare OLD NEW -o compare.html``: the same style as the report's (inline CSS,
no script), one table of every owner's quantity (:func:`~deltacal.printer.history.compare_calibrations`)
with both values, the change and its σ, the significant ones first. Every text from a file is escaped.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from ..io import atomic_write_text
from ..printer.history import SIGNIFICANT_SIGMAS, Change
from .html import CSS, esc, table, td


def _cell(value: float, digits: int) -> str:
    return f'<td class="num" data-value="{esc(repr(float(value)))}">{esc(f"{value:+.{digits}f}")}</td>'


def _verdict(change: Change) -> str:
    if not change.measured:
        return "not measured by both"
    return "significant" if change.significant else "not significant"


def render_comparison(changes: Sequence[Change], old: str, new: str, firmware: str,
                      said: Sequence[str] = ()) -> str:
    """The whole HTML document of a comparison (``firmware``: the name the owner reads, ``Klipper``)."""
    ordered = sorted(changes, key=lambda c: (not c.significant, not c.measured))
    rows = [[td(c.what), _cell(c.old, c.digits), _cell(c.new, c.digits), _cell(c.change, c.digits),
             f'<td class="num">{esc(f"{c.sigma:.{c.digits}f}")}</td>', td(c.unit),
             f'<td class="{"warning" if c.significant else "muted"}">{esc(_verdict(c))}</td>']
            for c in ordered]
    found = [c.what for c in changes if c.significant]
    summary = (f"Significant: {', '.join(found)}." if found else "No significant change between them.")
    notes = "".join(f'<p class="muted">{esc(line)}</p>' for line in said)
    title = "What changed in the printer"
    return (
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
        "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n"
        f"<title>{esc(title)}</title>\n<style>{CSS}</style>\n</head>\n<body>\n"
        f"<h1>{esc(title)}</h1>\n<p class=\"muted\">deltacal compare of {esc(old)} (old) and {esc(new)} "
        "(new), "
        f"in {esc(firmware)}'s words</p>\n{notes}<p><strong>{esc(summary)}</strong></p>\n"
        f"<p>Each change is the new value minus the old; its σ combines both calibrations' σ in quadrature "
        f"(independent measurements). Significant: measured by both calibrations (σ below half the build "
        f"tolerance) and the change beyond {SIGNIFICANT_SIGMAS:g} σ.</p>\n"
        + table(("quantity", "old", "new", "change", "σ", "unit", ""), rows, "changes")
        + "\n</body>\n</html>\n"
    )


def write_comparison(path: str | Path, changes: Sequence[Change], old: str, new: str, firmware: str,
                     said: Sequence[str] = ()) -> None:
    """Write the comparison page, atomically (:func:`render_comparison`)."""
    atomic_write_text(Path(path), render_comparison(changes, old, new, firmware, said))


__all__ = ["render_comparison", "write_comparison"]
