"""``deltacal report``: the page's numbers are the calibration file's, it makes no request, every
figure renders in real headless Chromium, it fits a phone, instrument frames are shown, bad input
gives one line."""

from __future__ import annotations

import html
import json
import re
import socket
import subprocess
import tempfile
import threading
import tomllib
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest
from conftest import MODELS

from deltacal.cli import main

ROBOT = str(MODELS / "bai2015.toml")
CHROMIUM = Path("/usr/bin/chromium")
needs_chromium = pytest.mark.skipif(
    not CHROMIUM.exists(), reason="/usr/bin/chromium is missing (apt-get install -y chromium)"
)
#: Hosts Chromium itself calls (time, accounts, updates) even with background networking off.
CHROMIUM_OWN_HOSTS = ("clients2.google.com", "accounts.google.com", "www.google.com",
                      "android.clients.google.com", "update.googleapis.com", "redirector.gvt1.com")
OUTLIER_ROW = 7  # data row given a gross error (line 8 of the file)


@pytest.fixture(scope="module")
def simulated(tmp_path_factory):
    folder = tmp_path_factory.mktemp("report")
    poses, meas, cal = folder / "poses.csv", folder / "meas.csv", folder / "cal.toml"
    assert main(["plan", ROBOT, "--strategy", "doptimal", "--count", "50", "-o", str(poses)]) == 0
    assert main(["simulate", ROBOT, str(poses), "--perturb", "7", "--seed", "3", "-o", str(meas)]) == 0
    lines = meas.read_text().splitlines()
    fields = lines[OUTLIER_ROW].split(",")
    fields[3] = repr(float(fields[3]) + 0.08)  # x_mm off by 0.08 mm: 16 σ
    lines[OUTLIER_ROW] = ",".join(fields)
    meas.write_text("\n".join(lines) + "\n")
    assert main(["identify", ROBOT, str(meas), "--accept-poor-fit", "-o", str(cal)]) == 0
    report = folder / "report.html"
    assert main(["report", str(cal), "-o", str(report), "--measurements", str(meas),
                 "--truth", str(folder / "meas.truth.toml"), "--robot", ROBOT]) == 0
    return folder


class Tables(HTMLParser):
    """Cells of every table with an id: text and data-value."""

    def __init__(self) -> None:
        super().__init__()
        self.tables: dict[str, list[list[tuple[str, str | None]]]] = {}
        self.current: str | None = None
        self.cell: list[str] | None = None
        self.value: str | None = None

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "table" and a.get("id"):
            self.current = a["id"]
            self.tables[self.current] = []
        elif tag == "tr" and self.current:
            self.tables[self.current].append([])
        elif tag == "td" and self.current:
            self.cell, self.value = [], a.get("data-value")

    def handle_endtag(self, tag):
        if tag == "table":
            self.current = None
        elif tag == "td" and self.current and self.cell is not None:
            self.tables[self.current][-1].append(("".join(self.cell), self.value))
            self.cell = None

    def handle_data(self, data):
        if self.cell is not None:
            self.cell.append(data)


def tables_of(text: str) -> dict[str, list[list[tuple[str, str | None]]]]:
    parser = Tables()
    parser.feed(text)
    return {k: [r for r in v if r] for k, v in parser.tables.items()}


@pytest.mark.slow
def test_numbers_in_the_page_are_the_calibration_files(simulated):
    text = (simulated / "report.html").read_text(encoding="utf-8")
    data = tomllib.loads((simulated / "cal.toml").read_text(encoding="utf-8"))["calibration"]
    tables = tables_of(text)
    rows = tables["base-parameters"]
    assert len(rows) == len(data["base_parameter"]) == data["rank"]
    for row, p in zip(rows, data["base_parameter"], strict=True):
        unit = "deg" if "value_deg" in p else "mm"
        assert row[1][0] == p["name"] and row[2][0] == p["regrouping"] and row[5][0] == unit
        for cell, key in ((row[3], f"value_{unit}"), (row[4], f"sigma_{unit}")):
            assert float(cell[1]) == p[key]  # exact, from data-value
            assert float(cell[0]) == pytest.approx(p[key], rel=1e-5, abs=1e-12)  # as shown
    summary = {r[0][0]: r[1] for r in tables["summary"]}
    assert float(summary["rank (base parameters)"][1]) == data["rank"]
    assert float(summary["condition number"][1]) == data["condition_number"]
    assert float(summary["variance factor s0²"][1]) == data["variance_factor"]
    assert [r[0][0] for r in tables["unidentifiable"]] == data["unidentifiable"]
    assert all(r[1][0].startswith(("absorbed by", "not excited")) for r in tables["unidentifiable"])
    residuals = {r[0][0]: (float(r[1][1]), float(r[2][1])) for r in tables["residual-summary"]}
    for key, before in data["residuals_before"].items():
        assert residuals[key] == (before, data["residuals_after"][key])
    # the outlier is flagged in the file and named by its line in the page
    assert data["outlier_lines"] == [OUTLIER_ROW + 1]
    assert f"line(s) {OUTLIER_ROW + 1} of the file" in text
    assert "Largest predicted σ" in text and 'id="fig-accuracy"' in text and 'id="fig-error"' in text


@pytest.mark.slow
def test_the_page_is_self_contained_phone_ready_and_printable(simulated):
    text = (simulated / "report.html").read_text(encoding="utf-8")
    frame = re.search(r'srcdoc="([^"]*)"', text)
    assert frame is not None
    inner = html.unescape(frame.group(1))
    assert "MeshCat.Viewer" in inner
    for doc in (text[: frame.start()] + text[frame.end():], inner):
        remote = re.findall(r"""(?:src|href|action|srcset|poster|data)\s*=\s*["']?\s*(?:https?:)?//""", doc,
                            re.IGNORECASE)
        assert not remote
        assert not re.search(r"""url\(\s*["']?\s*(?:https?:)?//""", doc, re.IGNORECASE)
        assert "@import" not in doc
    assert "<link" not in text.lower()[: frame.start()]
    assert '<meta name="viewport" content="width=device-width, initial-scale=1">' in text
    assert "@media print" in text and "@media (max-width" in text
    assert len(re.findall(r"<svg\b", text[: frame.start()])) == 6


class RequestLog:
    """A proxy that answers nothing and records every request Chromium sends it."""

    def __init__(self) -> None:
        self.sock = socket.socket()
        self.sock.bind(("127.0.0.1", 0))
        self.sock.listen(32)
        self.port = self.sock.getsockname()[1]
        self.requests: list[str] = []
        threading.Thread(target=self._serve, daemon=True).start()

    def _serve(self) -> None:
        while True:
            try:
                conn, _ = self.sock.accept()
            except OSError:
                return
            conn.settimeout(2.0)
            try:
                self.requests.append(conn.recv(300).split(b"\r\n")[0].decode("latin-1"))
            except OSError:
                pass
            finally:
                conn.close()

    def hosts(self) -> list[str]:
        out = []
        for line in self.requests:
            parts = line.split()
            if len(parts) >= 2:
                target = parts[1]
                out.append(re.sub(r"^[a-z]+://", "", target).split("/")[0].split(":")[0])
        return out

    def close(self) -> None:
        self.sock.close()


PROBE = """<script>
window.addEventListener('load', () => setTimeout(() => {
  const out = {figures: [], scrollWidth: document.documentElement.scrollWidth,
               height: document.documentElement.scrollHeight, width: window.innerWidth};
  for (const svg of document.querySelectorAll('svg.figure')) {
    const r = svg.getBoundingClientRect();
    out.figures.push({id: svg.closest('figure').id, w: r.width, h: r.height, x: r.left + scrollX,
                      y: r.top + scrollY, paths: svg.querySelectorAll('path').length,
                      images: svg.querySelectorAll('image').length});
  }
  const f = document.querySelector('iframe.scene');
  const r = f.getBoundingClientRect();
  out.scene = {x: r.left + scrollX, y: r.top + scrollY, w: r.width, h: r.height};
  const pre = document.createElement('pre');
  pre.id = 'probe';
  pre.textContent = JSON.stringify(out);
  document.body.appendChild(pre);
  if (window.parent !== window) window.parent.postMessage(pre.textContent, '*');
}, 300));
</script>"""
#: A phone's screen: the page in a 375 px wide frame (headless Chromium's window is 500 px at least).
PHONE = """<!DOCTYPE html><html><body style="margin:0">
<iframe src="{src}" style="width:375px;height:800px;border:0"></iframe>
<script>
window.addEventListener('message', (e) => {{
  const pre = document.createElement('pre'); pre.id = 'probe'; pre.textContent = e.data;
  document.body.appendChild(pre);
}});
</script></body></html>"""


def chromium(page: Path, *options: str, proxy: int | None = None) -> bytes:
    with tempfile.TemporaryDirectory(prefix="deltacal-test-chromium-") as profile:
        args = [str(CHROMIUM), "--headless", "--no-sandbox", "--disable-gpu", "--use-angle=swiftshader",
                "--enable-unsafe-swiftshader", "--disable-background-networking",
                "--disable-component-update", "--disable-sync", "--no-first-run", "--disable-default-apps",
                "--hide-scrollbars",
                f"--user-data-dir={profile}", "--virtual-time-budget=10000", *options]
        if proxy is not None:
            args += [f"--proxy-server=http://127.0.0.1:{proxy}", "--proxy-bypass-list=<-loopback>"]
        done = subprocess.run([*args, page.resolve().as_uri()], capture_output=True, timeout=240)
    assert done.returncode == 0, done.stderr.decode("utf-8", "replace")[-500:]
    return done.stdout


def probe(report: Path, folder: Path, width: int, proxy: int | None = None, phone: bool = False) -> dict:
    page = folder / f"probe-{width}.html"
    text = report.read_text(encoding="utf-8").replace("</body>", PROBE + "</body>")
    page.write_text(text, encoding="utf-8")
    if phone:
        host = folder / "phone.html"
        host.write_text(PHONE.format(src=page.name), encoding="utf-8")
        page = host
    dom = chromium(page, "--dump-dom", f"--window-size={width},900", proxy=proxy).decode("utf-8")
    found = re.search(r'<pre id="probe">(.*?)</pre>', dom, re.DOTALL)
    assert found, "the probe did not run"
    return json.loads(html.unescape(found.group(1)))


@needs_chromium
@pytest.mark.long
@pytest.mark.browser
def test_chromium_renders_every_figure_and_the_scene_without_any_request(simulated):
    from PIL import Image

    report = simulated / "report.html"
    log = RequestLog()
    try:
        info = probe(report, simulated, 1000, proxy=log.port)
    finally:
        log.close()
    foreign = [h for h in log.hosts() if h not in CHROMIUM_OWN_HOSTS]
    assert not foreign, f"the page made requests: {log.requests}"
    ids = [f["id"] for f in info["figures"]]
    assert ids == ["fig-correlation", "fig-residuals-index", "fig-residuals-workspace", "fig-accuracy",
                   "fig-error", "fig-error-vs-sigma"]
    for f in info["figures"]:
        assert f["w"] > 200 and f["h"] > 150, f
        assert f["paths"] + f["images"] > 20, f  # drawn content, not an empty frame
    assert info["scene"]["w"] > 200 and info["scene"]["h"] > 200
    # the screenshot: each figure and the 3-D view hold a picture, not a blank box
    height = int(min(info["height"] + 50, 16000))
    shot = simulated / "shot.png"
    chromium(report, f"--screenshot={shot}", f"--window-size=1000,{height}")
    with Image.open(shot) as image:
        pixels = np.asarray(image.convert("L"), dtype=float)
    for box in info["figures"] + [info["scene"]]:
        y0, x0 = int(box["y"]), int(box["x"])
        crop = pixels[y0 : y0 + int(box["h"]), x0 : x0 + int(box["w"])]
        assert crop.size and crop.std() > 15.0, (box, crop.std())
    for box in info["figures"]:
        crop = pixels[int(box["y"]) : int(box["y"] + box["h"]), int(box["x"]) : int(box["x"] + box["w"])]
        assert np.mean(crop < 200) > 0.02, box  # some ink on the white page
    # the scene draws the robot: not one flat background (more than a few grey levels)
    s = info["scene"]
    scene = pixels[int(s["y"]) + 40 : int(s["y"] + s["h"]) - 10, int(s["x"]) + 10 : int(s["x"] + s["w"]) - 10]
    assert len(np.unique(scene.astype(int))) > 40


@needs_chromium
@pytest.mark.long
@pytest.mark.browser
def test_a_phone_sees_the_page_without_sideways_scrolling(simulated):
    info = probe(simulated / "report.html", simulated, 600, phone=True)
    assert info["width"] == 375
    assert info["scrollWidth"] <= 376, info["scrollWidth"]  # wide tables scroll in their own box
    for f in info["figures"]:
        assert 0 < f["w"] <= 375 and f["h"] > 50, f
    assert 0 < info["scene"]["w"] <= 375


@pytest.mark.long
def test_a_free_instrument_frame_is_shown(tmp_path):
    poses, meas, cal, out = (tmp_path / n for n in ("poses.csv", "meas.csv", "cal.toml", "r.html"))
    assert main(["plan", ROBOT, "--strategy", "doptimal", "--count", "40", "-o", str(poses)]) == 0
    station = "east:1.1,-1.0,35.0:2680,830,250"
    assert main(["simulate", ROBOT, str(poses), "--perturb", "5", "--station", station, "-o", str(meas)]) == 0
    assert main(["identify", ROBOT, str(meas), "--frame", "free", "-o", str(cal)]) == 0
    assert main(["report", str(cal), "-o", str(out), "--measurements", str(meas), "--no-view"]) == 0
    text = out.read_text(encoding="utf-8")
    data = tomllib.loads(cal.read_text(encoding="utf-8"))
    rows = tables_of(text)["frames"]
    assert [r[0][0] for r in rows] == ["east"]
    east = data["instrument"]["east"]
    values = [float(c[1]) for c in rows[0][1:7]]
    assert values == east["rotation_deg"] + east["translation_mm"]
    assert values[2] == pytest.approx(35.0, abs=0.2) and values[3] == pytest.approx(2680.0, abs=5.0)
    # residuals recomputed through the frame agree with the file
    assert "are these the measurements" not in text
    assert 'id="fig-residuals-index"' in text


def test_bad_input_is_one_line(simulated, tmp_path, capsys):
    cal = simulated / "cal.toml"
    out = tmp_path / "r.html"
    # a wrong value in the calibration file: exit 1, one line naming the file and the key
    bad = tmp_path / "bad.toml"
    bad.write_text(cal.read_text().replace('model = "complete"', 'model = "fancy"'))
    assert main(["report", str(bad), "-o", str(out)]) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and str(bad) in err and "calibration.model" in err and "fancy" in err
    bad.write_text(re.sub(r"sigma_mm = [0-9.e-]+", "sigma_mm = -1.0", cal.read_text(), count=1))
    assert main(["report", str(bad), "-o", str(out)]) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "sigma_mm" in err and "-1.0" in err
    # a geometry file is not a calibration
    assert main(["report", str(simulated / "meas.truth.toml"), "-o", str(out)]) == 1
    assert "format" in capsys.readouterr().err
    # usage errors: exit 2
    for args in (["report", str(tmp_path / "missing.toml"), "-o", str(out)],
                 ["report", str(cal), "-o", str(cal)],
                 ["report", str(cal), "-o", str(out), "--tool", "1,2"],
                 ["report", str(cal), "-o", str(tmp_path / "no" / "r.html")]):
        assert main(args) == 2
        assert len(capsys.readouterr().err.strip().splitlines()) == 1
    assert not out.exists()


@pytest.mark.long
def test_a_printer_report_speaks_of_its_firmware_effector_and_nozzle(tmp_path):
    """A printer's report: the firmware's routes (the targets sent as they are: Klipper's model with the
    nominal values; its values fitted), the nozzle in the effector frame, and the 3-D view of towers
    and bed."""
    from deltacal import Tolerances
    from deltacal.io.calibration import calibration_from_result, load_calibration, save_calibration
    from deltacal.kinematics import exact
    from deltacal.printer.files.robot_file import load_printer
    from deltacal.printer.firmware.klipper.model import KlipperDelta
    from deltacal.printer.identification.fit import PrinterMeasurements, identify_printer
    from deltacal.report import accuracy_map, controller_routes, write_report
    from deltacal.report.accuracy import less_bed_motion

    kossel = load_printer(MODELS / "kossel.toml")
    nominal = kossel.geometry()
    rng = np.random.default_rng(2406)
    truth = nominal.perturbed(Tolerances.printer_kit(), rng)
    u = np.linspace(-115.0, 115.0, 7)
    bed = np.stack(np.meshgrid(u, u), axis=-1).reshape(-1, 2)
    bed = bed[np.hypot(*bed.T) <= 115.0 + 1e-9]
    probe = exact.inverse(truth, np.column_stack([bed, np.zeros(len(bed))]))
    result = identify_printer(nominal, PrinterMeasurements(probe + rng.normal(size=probe.shape) * 0.01))
    save_calibration(calibration_from_result(result), tmp_path / "cal.toml")
    out = tmp_path / "report.html"
    write_report(tmp_path / "cal.toml", out, truth=truth, workspace=kossel.workspace, grid=11)
    text = out.read_text(encoding="utf-8")
    phrases = ("for the nozzle (0, 0, -30) mm in the effector frame", "deltacal plan PRINTER.toml --object",
               "controller is its firmware (Klipper)", "targets sent as they are (nominal firmware)",
               "The identified printer (solid)", "effector tilt exaggerated", "nozzle goes")
    for phrase in phrases:
        assert phrase in text, phrase
    assert "not computed" not in text and "arm_length_" not in text and "endstop_a" not in text
    # where it holds, the firmware's values in its own words (printer.cfg's keys), not the model's names
    assert "[stepper_a] position_endstop" in text
    # the firmware's row is Klipper's own model with the nominal values, on the true printer
    calibration = load_calibration(tmp_path / "cal.toml")
    amap = accuracy_map(calibration, kossel.workspace, None, truth, 11)
    routes = controller_routes(calibration, amap, truth)
    route, fitted = routes.routes
    points = np.concatenate([s.points.reshape(-1, 3) for s in amap.slices])
    sigma = np.concatenate([v.ravel() for v in amap.sigma])
    points = points[np.all(np.isfinite(points), axis=1) & np.isfinite(sigma)]
    assert routes.points == len(points)
    firmware = KlipperDelta.from_printer(kossel)
    q = firmware.inverse(points, kossel.step_distance)
    error, _ = less_bed_motion(points, exact.forward(truth, q).point(truth.tool) - points)
    size = np.linalg.norm(error, axis=1)
    rms = float(np.sqrt(np.mean(size**2)))
    print(f"nominal firmware on the true printer: max {size.max():.4f} mm, RMS {rms:.4f} mm; on the "
          f"identified one: max {route.max_error:.4f} mm")
    assert route.true_max_error == pytest.approx(size.max(), abs=1e-9)
    assert route.true_rms_error == pytest.approx(rms, abs=1e-9)
    assert size.max() > 0.3  # an uncalibrated kit
    # the identified printer sees nearly the same error (to what the calibration leaves)
    assert abs(route.max_error - route.true_max_error) < 0.2 * route.true_max_error
    # the firmware's values fitted (export --controller klipper) hold a part of it, angle_c held
    assert fitted.name == "klipper" and fitted.held == ["angle_c"]
    assert fitted.max_error < 0.5 * route.max_error and fitted.true_max_error < 0.5 * route.true_max_error
    assert "firmware values fitted" in text
