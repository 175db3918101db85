"""The comparison page: what changed in a printer between its calibrations, one self-contained HTML file.

The page of ``deltacal compare OLD NEW -o compare.html``: the same style as the report's (inline CSS,
no script), one table of every owner's quantity (:func:`~deltacal.printer.history.compare_calibrations`)
with both values, the change and its σ, the significant ones first. Of three calibrations or more,
the printer's history (:func:`history_html`, also the report's section of ``report --history``): each
quantity's value in each calibration and each step's change between them. Every text from a file is
escaped.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from ..io import atomic_write_text
from ..printer.history import SIGNIFICANT_SIGMAS, Change, Quantity, significant_in_words
from ..printer.owner import Estimate
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


def _value(e: Estimate, digits: int) -> str:
    if not e.determined:
        return f'<td class="muted">{esc(f"not measured (± {e.sigma:.{digits}f})")}</td>'
    text = f"{e.value:+.{digits}f} ± {e.sigma:.{digits}f}"
    return f'<td class="num" data-value="{esc(repr(e.value))}">{esc(text)}</td>'


def _step(c: Change) -> str:
    css = "warning" if c.significant else "muted"
    text = f"{c.change:+.{c.digits}f} ± {c.sigma:.{c.digits}f}: {_verdict(c)}"
    return f'<td class="{css}" data-value="{esc(repr(c.change))}">{esc(text)}</td>'


def history_html(history: Sequence[Quantity], sources: Sequence[str]) -> str:
    """A printer's history (``sources``: its calibrations' files, oldest first), an HTML fragment.

    Each step's significant changes in words, then one table: per owner's quantity its value ± σ in
    each calibration and, between two, the step's change ± σ and whether it is significant.
    """
    steps = "".join(f"<li>{esc(f'{a} → {b}: {significant_in_words([q.steps[k] for q in history])}')}</li>"
                    for k, (a, b) in enumerate(zip(sources, sources[1:], strict=False)))
    header = ["quantity", "unit", sources[0]]
    for a, b in zip(sources, sources[1:], strict=False):
        header += [f"change {a} → {b}", b]
    rows = []
    for q in history:
        row = [td(q.what), td(q.unit), _value(q.values[0], q.digits)]
        for change, value in zip(q.steps, q.values[1:], strict=True):
            row += [_step(change), _value(value, q.digits)]
        rows.append(row)
    note = ("Each value ± its σ in that calibration; each change is the newer value minus the older, its "
            "σ both calibrations' noise parts in quadrature (what the prior leaves unknown is the same in "
            "both). Significant: measured by both (σ below half the build tolerance) and the change beyond "
            f"{SIGNIFICANT_SIGMAS:g} σ.")
    return (f"<p>{len(sources)} calibrations of this printer, oldest first, all under one prior (the "
            f"newest's controller and robot file).</p><ul>{steps}</ul>" + table(header, rows, "history")
            + f'<p class="muted">{esc(note)}</p>')


def render_history(history: Sequence[Quantity], sources: Sequence[str], firmware: str,
                   said: Sequence[str] = ()) -> str:
    """The whole HTML document of a printer's history (three calibrations or more)."""
    notes = "".join(f'<p class="muted">{esc(line)}</p>' for line in said)
    title = "History of this printer's calibrations"
    return (
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
        "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n"
        f"<title>{esc(title)}</title>\n<style>{CSS}</style>\n</head>\n<body>\n"
        f"<h1>{esc(title)}</h1>\n<p class=\"muted\">deltacal compare of {esc(', '.join(sources))}, "
        f"in {esc(firmware)}'s words</p>\n{notes}{history_html(history, sources)}\n</body>\n</html>\n"
    )


def write_history(path: str | Path, history: Sequence[Quantity], sources: Sequence[str], firmware: str,
                  said: Sequence[str] = ()) -> None:
    """Write the history page, atomically (:func:`render_history`)."""
    atomic_write_text(Path(path), render_history(history, sources, firmware, said))


__all__ = ["history_html", "render_comparison", "render_history", "write_comparison", "write_history"]
