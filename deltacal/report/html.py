"""The report page: one self-contained HTML file (inline CSS and SVG, no script or request of its own).

Every text that comes from a file or the user is escaped. The 3-D view is meshcat's standalone
page (its viewer script inlined) in an ``<iframe srcdoc>``.
"""

from __future__ import annotations

import html
import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..calibration import Calibration
from ..io.toml import exact_degrees
from ..printer.firmware.base import classical_name
from ..printer.identification.where import holds_in_words, values_in_words
from .accuracy import AccuracyMap
from .controllers import ControllerRoutes
from .deflection import DeflectionMap
from .residuals import MeasurementResiduals

CSS = """
:root { --fg: #1b1b1b; --muted: #5a5a5a; --line: #d0d0d0; --accent: #2166ac; --warn: #b2182b; }
* { box-sizing: border-box; }
body { font-family: system-ui, -apple-system, "Segoe UI", Roboto, "DejaVu Sans", sans-serif; color: var(--fg);
       line-height: 1.45; margin: 0 auto; padding: 0.8rem 1rem 3rem; max-width: 64rem; }
h1 { font-size: 1.5rem; margin: 0.6rem 0; } h2 { font-size: 1.2rem; margin-top: 2rem;
  border-bottom: 1px solid var(--line); padding-bottom: 0.2rem; }
p, li { max-width: 48rem; }
.muted { color: var(--muted); font-size: 0.9em; }
.warning { color: var(--warn); }
.scroll { overflow-x: auto; -webkit-overflow-scrolling: touch; margin: 0.6rem 0; }
table { border-collapse: collapse; font-size: 0.88rem; }
th, td { border-bottom: 1px solid var(--line); padding: 0.25rem 0.5rem; text-align: left;
         vertical-align: top; }
td.num { text-align: right; font-variant-numeric: tabular-nums; white-space: nowrap; }
figure { margin: 1rem 0; break-inside: avoid; page-break-inside: avoid; }
figcaption { font-size: 0.85rem; color: var(--muted); max-width: 48rem; }
svg.figure { display: block; width: 100%; height: auto; max-width: 48rem; }
iframe.scene { width: 100%; height: 36rem; max-height: 80vh; border: 1px solid var(--line); }
.print-only { display: none; }
@media (max-width: 40rem) {
  body { padding: 0.5rem 0.6rem 2rem; } h1 { font-size: 1.25rem; } table { font-size: 0.8rem; }
}
@media print {
  body { max-width: none; padding: 0; font-size: 10pt; }
  iframe.scene { display: none; } .print-only { display: block; }
  h2 { break-after: avoid; page-break-after: avoid; }
  .scroll { overflow: visible; }
  a { color: inherit; text-decoration: none; }
}
"""


def esc(value: object) -> str:
    """HTML-escaped text (quotes too)."""
    return html.escape(str(value), quote=True)


def num(value: float, digits: int = 6) -> str:
    """A number for a table cell: ``digits`` significant digits, NaN as a dash."""
    if not math.isfinite(value):
        return "–"
    return f"{value:.{digits}g}"


def cell(value: float, digits: int = 6) -> str:
    """A numeric ``<td>`` holding the exact value in ``data-value`` and a rounded one as its text."""
    return f'<td class="num" data-value="{esc(repr(float(value)))}">{esc(num(value, digits))}</td>'


def file_degrees(angles: np.ndarray) -> list[float]:
    """Angles [rad] in degrees as a calibration file holds them (:func:`~deltacal.io.toml.exact_degrees`)."""
    return [float(exact_degrees(float(v))) for v in angles]


def table(header: Sequence[str], rows: Sequence[Sequence[str]], ident: str) -> str:
    """A table in a horizontally scrolling box; ``rows`` hold ready ``<td>`` cells."""
    head = "".join(f"<th>{esc(h)}</th>" for h in header)
    body = "".join("<tr>" + "".join(r) + "</tr>" for r in rows)
    return (f'<div class="scroll"><table id="{esc(ident)}"><thead><tr>{head}</tr></thead>'
            f"<tbody>{body}</tbody></table></div>")


def td(text: object) -> str:
    """A text cell."""
    return f"<td>{esc(text)}</td>"


def figure(svg: str, caption: str, ident: str) -> str:
    """A figure with its inline SVG and an escaped caption."""
    return f'<figure id="{esc(ident)}">{svg}<figcaption>{esc(caption)}</figcaption></figure>'


def regrouping_words(regrouping: str, terms: list[str]) -> str:
    """A regrouping said in words."""
    if len(terms) <= 1:
        return f"{terms[0] if terms else regrouping} alone"
    others = ", ".join(terms[1:])
    return (f"{terms[0]} together with {others}: the measurements see only this combination, "
            f"so {terms[0]} carries the effect of {others} too")


@dataclass
class Page:
    """What goes into the page (the figures already drawn as SVG)."""

    calibration: Calibration
    accuracy: AccuracyMap
    figures: dict[str, str]
    residuals: MeasurementResiduals | None = None
    truth_source: str | None = None
    measurements_source: str | None = None
    workspace_text: str = ""
    scene_html: str | None = None
    scene_note: str = ""
    warnings: list[str] = field(default_factory=list)
    controllers: ControllerRoutes | None = None
    deflection: DeflectionMap | None = None
    owner: list[str] | None = None
    history: str | None = None


def _owner(page: Page) -> str:
    """A printer's errors in its owner's words, before the engineer's parameters."""
    assert page.owner is not None
    head, *items = page.owner
    rows = "".join(f"<li>{esc(item.strip())}</li>" for item in items)
    return (f"<p>{esc(head)}</p><ul>{rows}</ul><p class=\"muted\">± one σ of the calibration; \"not "
            "measured\": only the build tolerance bounds it. The engineer's part follows.</p>")


def _summary(page: Page) -> str:
    c = page.calibration
    s0 = c.variance_factor
    if math.isfinite(s0):
        verdict = ("the residuals match the σ given" if 0.5 <= s0 <= 2.0 else
                   f"the σ of the parameters (and the accuracy map) are off by a factor of about "
                   f"{math.sqrt(s0):.3g}")
    else:
        verdict = ""
    rows = [
        [td("robot"), td(c.robot)],
        [td("calibration file"), td(c.source)],
        [td("error model"), td(f"{c.model.name} ({c.parameters} parameters)")],
        [td("method"), td(f"{c.method or '?'}, {c.iterations} iteration(s)")],
        [td("rank (base parameters)"), cell(c.rank)],
        [td("condition number"), cell(c.condition_number)],
        [td("variance factor s0²"), cell(s0, 4)],
        [td("outliers (lines)"), td(", ".join(map(str, c.outlier_lines)) or "none")],
    ]
    if page.measurements_source:
        rows.insert(2, [td("measurement file"), td(page.measurements_source)])
    out = table(["", ""], rows, "summary")
    if verdict:
        out += f"<p>s0² = {esc(num(s0, 4))}: {esc(verdict)} (1 when the measurement σ given were right).</p>"
    if c.frames:
        frows = []
        for name, f in c.frames.items():
            frows.append([td(name)] + [cell(v) for v in file_degrees(f.rotation)]
                         + [cell(v) for v in f.translation]
                         + [td(", ".join(num(v, 3) for v in np.degrees(f.rotation_sigma))),
                            td(", ".join(num(v, 3) for v in f.translation_sigma))])
        out += ("<h3>Instrument frames</h3><p>The measurements were taken in instrument frames {T} "
            "identified "
                "with the robot (one per station): the pose of the robot base {O} in each, "
                "y<sub>T</sub> = R(rotation) y<sub>O</sub> + translation.</p>")
        out += table(["station", "rx [deg]", "ry [deg]", "rz [deg]", "tx [mm]", "ty [mm]", "tz [mm]",
                      "σ rotation [deg]", "σ translation [mm]"], frows, "frames")
    else:
        out += ("<p id=\"frames-none\">Instrument frame: the measurements are in the robot base frame {O} "
                "(no [instrument] table).</p>")
    return out


def _parameters(page: Page) -> str:
    c = page.calibration
    rows = []
    for k, p in enumerate(c.base, start=1):
        # an angle in degrees, as the calibration file writes it
        value, sigma, unit = ((math.degrees(p.value), math.degrees(p.sigma), "deg") if p.unit == "rad"
                              else (p.value, p.sigma, p.unit))
        rows.append([cell(k), td(p.name), td(p.regrouping), cell(value), cell(sigma), td(unit),
                     td(regrouping_words(p.regrouping, p.terms))])
    out = ("<p>Each base parameter is what the measurements identify: a kept parameter, plus any "
        "others whose "
           "effect it cannot be told apart from (the regrouping). Values are deviations from the nominal "
           "geometry; σ from the measurement σ given.</p>")
    out += table(["#", "name", "regrouping", "value", "σ", "unit", "in words"], rows, "base-parameters")
    if c.unidentifiable:
        urows = [[td(name), td(c.explain(name))] for name in c.unidentifiable]
        out += "<h3>Not identifiable</h3>"
        out += table(["parameter", "why"], urows, "unidentifiable")
    else:
        out += "<p>Every parameter of the model is identifiable from these measurements.</p>"
    return out


def _correlation(page: Page) -> str:
    c = page.calibration
    C = c.correlation
    iu = np.triu_indices(len(C), k=1)
    order = np.argsort(-np.abs(C[iu]), kind="stable")[:5]
    items = "".join(
        f"<li>{esc(c.base[iu[0][k]].regrouping)} ~ {esc(c.base[iu[1][k]].regrouping)}: "
        f"{esc(f'{C[iu[0][k], iu[1][k]]:+.3f}')}</li>" for k in order)
    text = figure(page.figures["correlation"], "Correlation of the base parameters (rows and columns in the "
                  "order of the table above). Strong correlations (dark) mean the measurements "
                  "separate these "
                  "parameters poorly: more varied poses help.", "fig-correlation")
    return text + (f"<p>Strongest correlations:</p><ul>{items}</ul>" if items else "")


def _residuals(page: Page) -> str:
    c = page.calibration
    before, after = c.residuals_before.as_dict(), c.residuals_after.as_dict()
    rows = [[td(k), cell(before.get(k, math.nan)), cell(after.get(k, math.nan))]
            for k in sorted(set(before) | set(after))]
    out = "<p>As recorded in the calibration file:</p>" + table(["statistic", "before", "after"], rows,
                                                                 "residual-summary")
    r = page.residuals
    if r is None:
        return out + ("<p class=\"muted\">Give the measurement file (--measurements) to see each "
            "measurement's "
                      "residual.</p>")
    out += (f"<p>Recomputed from {esc(r.source)} ({len(r.lines)} measurements, {esc(r.kind)} residuals): RMS "
            f"{esc(num(r.rms_before, 4))} mm before, {esc(num(r.rms_after, 4))} mm after. ")
    if np.any(r.outlier):
        out += ("Outliers (circled in red) at line(s) "
                f"{esc(', '.join(str(int(n)) for n in r.lines[r.outlier]))} of the file.</p>")
    else:
        out += "No outlier.</p>"
    out += figure(page.figures["residuals_index"], "Residual of each measurement, in file order, at "
        "the nominal "
                  "geometry (top) and at the identified one (bottom).", "fig-residuals-index")
    out += figure(page.figures["residuals_workspace"], "Residual after calibration where each "
        "measurement was "
                  "taken (robot base frame).", "fig-residuals-workspace")
    return out


def _accuracy(page: Page) -> str:
    a = page.accuracy
    w = a.worst_point
    chain = page.calibration.geometry.chain
    out = (
        "<p>The predicted accuracy map is the standard deviation of the TCP position the calibration leaves, "
        f"at each place of the workspace, for the {chain.words.tool} "
        f"({esc(', '.join(num(v, 6) for v in a.tool))}) mm in the {chain.words.plate} "
        "frame: the uncertainty of the "
        "identified base parameters (their σ and correlations) carried through the error model to the TCP. "
        "It is the 3-D RMS, √(σx² + σy² + σz²). It covers what the measurement noise leaves in the "
        "identified "
        "geometry, not modelling errors (joint play, thermal drift, elasticity) nor the repeatability of the "
        "robot.</p>"
        f"<p id=\"worst\">Largest predicted σ: <b>{esc(num(a.worst * 1000.0, 4))} µm</b> at "
        f"x = {esc(num(w[0], 5))}, y = {esc(num(w[1], 5))}, z = {esc(num(w[2], 5))} mm (σx, σy, σz = "
        f"{esc(', '.join(num(v * 1000.0, 3) for v in a.worst_axes))} µm), marked with a star.</p>"
        f"<p class=\"muted\">{esc(page.workspace_text)}</p>"
    )
    out += figure(page.figures["accuracy"], "Predicted σ of the TCP position on three horizontal "
        "slices (top, "
                  "middle, bottom of the workspace) and the vertical slice y = 0. White dots: measured poses "
                  "near the slice. Blank: out of reach.", "fig-accuracy")
    rows = [[td(s.label), cell(float(np.nanmin(v)) * 1000.0, 4), cell(float(np.nanmax(v)) * 1000.0, 4)]
            for s, v in zip(a.slices, a.sigma, strict=True)]
    out += table(["slice", "smallest σ [µm]", "largest σ [µm]"], rows, "accuracy-slices")
    holds = page.calibration.holds
    if holds is not None:
        out += f"<p id=\"holds\"><b>Where it holds.</b> {esc(holds_in_words(holds))}.</p>"
        if holds.values:
            firmware = page.controllers.firmware if page.controllers is not None else None
            words = values_in_words(holds) if firmware is None else values_in_words(
                holds, lambda name: firmware.value_name(classical_name(name)))
            out += f"<p id=\"holds-values\">{esc(words)}.</p>"
    if chain.on_bed:
        out += ("<p><b>How to use it.</b> Where σ is large, the probe heights and printed distances say "
                "little about the printer there: probe the bed there, or print and measure features at those "
                "heights and directions (<code>deltacal plan PRINTER.toml --object</code> designs an object "
                "whose distances identify the complete model), then identify again. Where σ is already below "
                "what the prints need, more measurements there do not help. If s0² is well above 1, the map "
                "is too optimistic by about √s0².</p>")
        return out
    out += ("<p><b>How to use it.</b> Where σ is large, the measurements say little about the robot "
        "there: add "
            "measurement poses in that region (around the star first, and at the edges of the "
            "workspace where "
            "the map rises), or plan with <code>deltacal plan --strategy doptimal</code> over the whole "
            "workspace, then measure and identify again. Where σ is already below what the task needs, more "
            "measurements there do not help. If s0² is well above 1, the map is too optimistic by about "
            "√s0².</p>")
    return out


def _gauge_note(shift: np.ndarray | None) -> str:
    if shift is None:
        return ""
    return ("<p id=\"truth-gauge\">Compared in the calibration's gauge: identified with free instrument "
            "frames, its {O} is where its actuator axes have no net rigid motion from the nominal ones, so "
            "the true robot is moved to its own axes gauge first. A common shift of "
            f"{esc(num(float(np.linalg.norm(shift)) * 1000.0, 4))} µm "
            f"({esc(', '.join(num(v * 1000.0, 4) for v in shift))} µm in x, y, z) is then removed: where "
            "the robot sits relative to its own axes, which no measurement in a station's frame sees "
            "(targets given in a station's frame do not depend on it).</p>")


def _bed_note(motion: np.ndarray | None) -> str:
    if motion is None:
        return ""
    return ("<p id=\"truth-bed\">Compared on the bed: no probe height and no printed distance sees the "
            "printer shifted along its bed or turned about its normal (a printed part is the same part), so "
            f"the shift of {esc(num(float(motion[0]) * 1000.0, 4))}, "
            f"{esc(num(float(motion[1]) * 1000.0, 4))} µm in x, y and the turn of "
            f"{esc(num(math.degrees(float(motion[2])), 4))}° that fit the actual errors "
            "best are removed from them.</p>")


def _truth(page: Page) -> str:
    a = page.accuracy
    assert a.error is not None
    s = np.concatenate([v.ravel() for v in a.sigma])
    e = np.concatenate([v.ravel() for v in a.error])
    ok = np.isfinite(s) & np.isfinite(e)
    ratio = float(np.sqrt(np.mean((e[ok] / s[ok]) ** 2))) if np.any(ok) else math.nan
    within = float(np.mean(e[ok] <= 2.0 * s[ok])) if np.any(ok) else math.nan
    out = (f"<p>The true geometry ({esc(page.truth_source)}) is known (a simulation): commanding "
        f"the readings "
           "that put the identified robot's TCP at each point, the true robot's TCP lands this far from it "
           "(exact kinematics of both).</p>"
           f"<p id=\"truth-summary\">Largest actual error {esc(num(float(np.max(e[ok])) * 1000.0, 4))} µm, "
           f"RMS {esc(num(float(np.sqrt(np.mean(e[ok] ** 2))) * 1000.0, 4))} µm; RMS of error / predicted σ "
           f"{esc(num(ratio, 3))} (about 1 expected, one draw of correlated errors); error below 2σ at "
           f"{esc(num(100.0 * within, 3))} % of the points.</p>")
    out += _gauge_note(a.shift) + _bed_note(a.bed_motion)
    out += figure(page.figures["error"], "Actual TCP error of the calibrated robot on the same slices.",
                  "fig-error")
    out += figure(page.figures["error_vs_sigma"], "Actual error against predicted σ at every slice point.",
                  "fig-error-vs-sigma")
    return out


def _firmware(page: Page) -> str:
    """A printer's controller section: its firmware with the nominal values, fitted, and corrected targets."""
    routes = page.controllers
    assert routes is not None and routes.firmware is not None
    firmware = routes.firmware
    truth = page.accuracy.error is not None
    out = (f"<p>A printer's controller is its firmware ({esc(firmware.title)}), which runs its own model: "
           "vertical towers, one rod per tower, a point effector. Over the same slices as the map, the "
           "nozzle error each way of handing it this calibration leaves: the targets sent as they are (the "
           "firmware with the nominal values); the firmware's values that fit the calibration best "
           f"(<code>deltacal export CAL --controller {esc(firmware.name)}</code>: "
           f"{esc(firmware.values_words)}); corrected targets and G-code through the firmware "
           "(<code>deltacal compensate CAL TARGETS.csv|PART.gcode --controller "
           f"{esc(firmware.config_file)}</code>), which leave what the calibration itself leaves: the "
           "predicted σ above" + (" and the actual errors against the true geometry" if truth else "")
           + ".</p>")
    if not routes.routes:
        return out + f"<p class=\"muted\">{esc(routes.note)}</p>"
    names = {"nominal": "targets sent as they are (nominal firmware)",
             firmware.name: "firmware values fitted"}
    rows = []
    for r in routes.routes:
        row = [td(names.get(r.name, r.name)), cell(r.max_error, 4), cell(r.rms_error, 4)]
        rows.append(row + ([cell(r.true_max_error, 4), cell(r.true_rms_error, 4)] if truth else []))
    a = page.accuracy
    rows.append([td("corrected targets"), cell(a.worst, 4), td("as the map")]
                + ([cell(float(np.nanmax(np.concatenate([e.ravel() for e in a.error]))), 4), td("")]
                   if truth and a.error is not None else []))
    header = ["route", "max [mm]", "RMS [mm]"] + (["true max [mm]", "true RMS [mm]"] if truth else [])
    out += table(header, rows, "controller-routes")
    note = f" {esc(routes.note)}" if routes.note else ""
    out += (f"<p class=\"muted\">{routes.points} points. Errors on the identified printer; corrected "
            f"targets' row: the largest predicted σ (and actual error).{note}</p>")
    return out


def _controllers(page: Page) -> str:
    if page.calibration.geometry.chain.firmware:
        return _firmware(page)
    routes = page.controllers
    assert routes is not None
    out = ("<p>A controller that takes Cartesian targets runs its own classical (perfect-parallelogram) "
           "model. Over the same slices as the map, the TCP error each way of handing it this calibration "
           "leaves: the targets sent as they are; the joint offsets alone, or the per-limb values, fitted "
           "(<code>deltacal export CAL --controller offsets|limbs</code>); corrected targets "
           "(<code>deltacal compensate CAL TARGETS --controller CONTROLLER</code>), which leave what the "
           "calibration itself leaves: the predicted σ above"
           + (" and the actual errors against the true geometry" if page.accuracy.error is not None else "")
           + ".</p>")
    if not routes.routes:
        return out + f"<p class=\"muted\">{esc(routes.note)}</p>"
    names = {"nominal": "targets sent as they are (nominal controller)", "offsets": "joint offsets fitted",
             "limbs": "per-limb values fitted"}
    truth = page.accuracy.error is not None
    rows = []
    for r in routes.routes:
        row = [td(names[r.name]), cell(r.max_error, 4), cell(r.rms_error, 4)]
        row += [cell(r.true_max_error, 4), cell(r.true_rms_error, 4)] if truth else []
        rows.append(row + [td(", ".join(r.held) or "–")])
    a = page.accuracy
    rows.append([td("corrected targets"), cell(a.worst, 4), td("as the map")]
                + ([cell(float(np.nanmax(np.concatenate([e.ravel() for e in a.error]))), 4), td("")]
                   if truth and a.error is not None else []) + [td("–")])
    header = ["route", "max [mm]", "RMS [mm]"] + (["true max [mm]", "true RMS [mm]"] if truth else [])
    out += table(header + ["held at nominal"], rows, "controller-routes")
    out += (f"<p class=\"muted\">{routes.points} points. Errors on the identified robot; corrected "
            "targets' row: the largest predicted σ (and actual error). Values held at nominal cannot be told "
            "apart by the TCP error (b_i and a_i enter only as b_i − a_i).</p>")
    return out


def _scene(page: Page) -> str:
    if page.scene_html is None:
        return f"<p class=\"muted\">{esc(page.scene_note or 'No 3-D view.')}</p>"
    return (f"<p>{esc(page.scene_note)}</p>"
            f'<iframe class="scene" title="3-D view of the identified robot" '
            f'srcdoc="{esc(page.scene_html)}"></iframe>'
            "<p class=\"print-only muted\">The interactive 3-D view is not printed: open the HTML file in a "
            "browser.</p>")


def _compliance(page: Page) -> str:
    c, m = page.calibration, page.deflection
    assert c.compliance is not None and m is not None
    sigma = np.zeros(3) if c.compliance_sigma is None else c.compliance_sigma
    rows = [[td(f"actuator {i + 1}"), cell(1e6 * c.compliance[i]), cell(1e6 * sigma[i]),
             cell(1.0 / c.compliance[i] if c.compliance[i] > 0 else math.nan)] for i in range(3)]
    out = ("<p>Each actuator yields to the gravity torque it holds: true angle = reading + offset + "
           "c<sub>i</sub> τ<sub>i</sub>. σ 0: not identifiable from these measurements (held at zero).</p>")
    out += table(["actuator", "c [µrad/N m]", "σ [µrad/N m]", "stiffness 1/c [N m/rad]"], rows, "compliance")
    header = ["layer z [mm]"] + [f"r = {r:.0f} mm" for r in m.radii]
    for title, values in (("own weight (compliant against rigid actuators)", m.own_weight),
                          (f"a payload of {m.payload_kg:g} kg at the TCP", m.payload)):
        if title.startswith("a payload") and m.payload_kg == 0.0:
            out += "<p class=\"muted\">No payload given (<code>report --payload KG</code> maps one).</p>"
            continue
        out += f"<h3>TCP deflection under {esc(title)}: largest on each ring [µm]</h3>"
        out += table(header, [[cell(z, 5)] + [cell(1e3 * v, 3) for v in row]
                              for z, row in zip(m.layers, values, strict=True)], "deflection")
    return out


def render_page(page: Page) -> str:
    """The whole HTML document."""
    c = page.calibration
    sections = [] if page.owner is None else [("owner", "The printer, in its owner's words", _owner(page))]
    if page.history is not None:
        sections.append(("history", "History of this printer's calibrations", page.history))
    sections += [
        ("overview", "Robot, model and fit", _summary(page)),
        ("parameters", "Base parameters", _parameters(page)),
        ("correlation", "Correlations", _correlation(page)),
        ("residuals", "Residuals", _residuals(page)),
        ("accuracy", "Predicted accuracy map", _accuracy(page)),
    ]
    if page.deflection is not None:
        sections.append(("compliance", "Actuator compliances and deflections", _compliance(page)))
    if page.accuracy.error is not None:
        sections.append(("truth", "Actual errors against the true geometry", _truth(page)))
    if page.controllers is not None:
        sections.append(("controllers", "What a controller can hold", _controllers(page)))
    sections.append(("view", "3-D view of the identified robot", _scene(page)))
    toc = "".join(f'<li><a href="#{k}">{esc(t)}</a></li>' for k, t, _ in sections)
    warn = "".join(f'<p class="warning">warning: {esc(w)}</p>' for w in page.warnings)
    body = "".join(f'<section id="{k}"><h2>{esc(t)}</h2>{text}</section>' for k, t, text in sections)
    title = f"Calibration report: {c.robot}"
    return (
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
        "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n"
        f"<title>{esc(title)}</title>\n<style>{CSS}</style>\n</head>\n<body>\n"
        f"<h1>{esc(title)}</h1>\n<p class=\"muted\">deltacal report of {esc(c.source)}</p>\n{warn}"
        f"<nav><ul>{toc}</ul></nav>\n{body}\n</body>\n</html>\n"
    )
