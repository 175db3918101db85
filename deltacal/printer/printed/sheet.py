"""The measuring sheet of a printed object: a top view with the balls' labels and the pairs to measure.

``plan --object`` writes it as ``sheet.html``: one self-contained page (inline SVG and CSS, nothing
fetched), printable on A4, so that a person with a caliper knows which balls each row of
distances.csv means. The top view is in the printer's coordinates seen from above, its front (−y)
at the bottom, as the labels read on the bed: each ball, its pad, its label's tile and name where
the object has them (:mod:`.labels`), the measured lines faint. The table lists the pairs in the
order of distances.csv: its row, ``ball1``, ``ball2``, the nominal distance between the centres,
the caliper's expected reading (the distance plus a ball) and an empty cell for the reading.
Units: mm.
"""

from __future__ import annotations

from html import escape

import numpy as np

from .object import BALL_DIAMETER, footprint_radius
from .plan import ObjectPlan

#: Room around the bed in the top view [mm].
VIEW_MARGIN = 12.0

_STYLE = """
body { font-family: sans-serif; margin: 12mm; color: #111; }
h1 { font-size: 16pt; margin: 0 0 4mm; }
p, li { font-size: 10pt; line-height: 1.35; }
svg { width: 100%; max-width: 170mm; display: block; margin: 4mm auto; }
table { border-collapse: collapse; font-size: 10pt; margin-top: 4mm; }
th, td { border: 1px solid #444; padding: 1.5mm 3mm; text-align: right; }
td.reading { width: 35mm; }
tr { page-break-inside: avoid; }
.view { page-break-after: always; }
@media print { body { margin: 8mm; } }
"""


def _svg(plan: ObjectPlan, radius: float, towers: np.ndarray | None) -> str:
    """The top view: bed, pads, balls, labels' tiles and names, measured lines (x right, y up)."""
    extent = radius + VIEW_MARGIN
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" viewBox="{-extent:g} {-extent:g} {2 * extent:g} '
           f'{2 * extent:g}" role="img" aria-label="top view of the object with the balls\' labels">',
           f'<circle cx="0" cy="0" r="{radius:g}" fill="#f4f4f4" stroke="#888" stroke-width="0.5"/>',
           f'<text x="0" y="{radius + 8:g}" font-size="5" text-anchor="middle">front (-Y)</text>']
    if towers is not None:
        for name, angle in zip("ABC", towers, strict=True):
            x, y = (radius + 6.0) * np.cos(angle), (radius + 6.0) * np.sin(angle)
            out.append(f'<text x="{x:.3f}" y="{-y:.3f}" font-size="6" text-anchor="middle" '
                       f'dominant-baseline="middle">{name}</text>')
    f = plan.features
    for i, j in plan.pairs.tolist():
        out.append(f'<line x1="{f[i, 0]:.3f}" y1="{-f[i, 1]:.3f}" x2="{f[j, 0]:.3f}" y2="{-f[j, 1]:.3f}" '
                   'stroke="#9ab" stroke-width="0.3"/>')
    for k, (x, y, z) in enumerate(f):
        shade = "#357" if z > f[:, 2].min() else "#8ac"
        out.append(f'<circle class="pad" cx="{x:.3f}" cy="{-y:.3f}" r="{footprint_radius(float(z)):.3f}" '
                   'fill="#ddd" stroke="#777" stroke-width="0.3"/>')
        out.append(f'<circle class="ball" data-ball="{k}" cx="{x:.3f}" cy="{-y:.3f}" '
                   f'r="{0.5 * BALL_DIAMETER:g}" fill="{shade}"><title>z = {z:g} mm</title></circle>')
    for label in plan.labels:
        (x0, y0), (x1, y1) = label.corners
        cx, cy = label.centre
        out.append(f'<rect class="tile" x="{x0:.3f}" y="{-y1:.3f}" width="{x1 - x0:.3f}" '
                   f'height="{y1 - y0:.3f}" fill="#fff" stroke="#111" stroke-width="0.3"/>')
        out.append(f'<text class="label" data-ball="{label.ball}" x="{cx:.3f}" y="{-cy:.3f}" font-size="6" '
                   'font-weight="bold" text-anchor="middle" dominant-baseline="central">'
                   f'{escape(label.name)}</text>')
    out.append("</svg>")
    return "\n".join(out)


def _table(plan: ObjectPlan) -> str:
    """The pairs to measure, in the order of distances.csv, with an empty cell for each reading."""
    names = plan.names
    rows = ["<table>", "<thead><tr><th>row</th><th>ball1</th><th>ball2</th><th>nominal distance (mm)</th>"
                       "<th>expected reading (mm)</th><th>reading (mm)</th></tr></thead>", "<tbody>"]
    for k, ((i, j), length) in enumerate(zip(plan.pairs.tolist(), plan.lengths, strict=True), start=1):
        rows.append(f'<tr class="pair"><td>{k}</td><td>{escape(names[i])}</td><td>{escape(names[j])}</td>'
                    f'<td>{length:.2f}</td><td>{length + BALL_DIAMETER:.1f}</td>'
                    '<td class="reading"></td></tr>')
    rows += ["</tbody>", "</table>"]
    return "\n".join(rows)


def sheet_html(plan: ObjectPlan, radius: float, title: str = "", towers: np.ndarray | None = None) -> str:
    """The measuring sheet of ``plan`` as one self-contained HTML page.

    Args:
        plan: The plan (its features, pairs and labels).
        radius: The printable radius [mm] (the bed drawn).
        title: The page's title (the printer's name, say).
        towers: The towers' azimuths [rad], (3,), drawn as A, B, C around the bed; None: not drawn.
    """
    heading = escape(title or "deltacal: the printed object's distances")
    steps = [
        "Measure with the object still on the bed, once the bed is at room temperature.",
        f"Measure each ball's diameter across its equator (nominal {BALL_DIAMETER:g} mm).",
        "For each row: close the caliper's outside jaws across the two balls named, rock the caliper about "
        "the line joining them and write the largest reading.",
        "In distances.csv (same rows, same ball1, ball2), write distance_mm = reading minus the mean of the "
        "two balls' diameters.",
    ]
    return "\n".join([
        "<!DOCTYPE html>", '<html lang="en">', "<head>", '<meta charset="utf-8">',
        f"<title>{heading}</title>", f"<style>{_STYLE}</style>", "</head>", "<body>",
        '<section class="view">', f"<h1>{heading}</h1>",
        f"<p>{len(plan.features)} balls, each labelled on a tile beside it; {len(plan.pairs)} distances to "
        "measure. Top view, the printer's front at the bottom; dark balls stand higher.</p>",
        _svg(plan, radius, towers), "</section>", "<section>", "<ol>",
        *[f"<li>{escape(step)}</li>" for step in steps], "</ol>", _table(plan), "</section>", "</body>",
        "</html>",
    ]) + "\n"
