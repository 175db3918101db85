"""A printer's history: ``deltacal report CAL --history OLDER ...`` and ``deltacal compare A B C``.

Three calibrations of one simulated Kossel, oldest first: the session's (``kossel_identified``), the same
true printer measured again (other noise), then tower B's endstop moved up 0.2 mm (test_compare's
``moved``: its ``new.toml``). Only the step from the second to the third changed the printer.
"""

from __future__ import annotations

import re

import pytest
from conftest import MODELS, complete_fit
from test_compare import MOVED_MM, _edited, _one_line, moved  # noqa: F401  (moved: a fixture used here)

from deltacal.cli import main
from deltacal.io import load_calibration
from deltacal.io.calibration import save_calibration
from deltacal.printer.history import SIGNIFICANT_SIGMAS, calibration_history, under_one_prior


@pytest.fixture(scope="module")
def three(moved):  # noqa: F811
    """The three calibrations' files, oldest first: unchanged, measured again, tower B's endstop moved."""
    kossel, cfg, plan = str(MODELS / "kossel.toml"), str(moved / "printer.cfg"), moved / "obj"
    probe, distances = str(moved / "probe_again.csv"), str(moved / "d_again.csv")
    assert main(["simulate", kossel, str(plan / "probe.csv"), str(plan / "distances.csv"), "--controller",
                 cfg, "--truth", str(moved / "probe.truth.toml"), "--seed", "3", "-o", probe,
                 "--distances-output", distances]) == 0
    again = str(moved / "again.toml")
    assert main(["identify", kossel, probe, distances, "--controller", cfg, "-o", again]) == 0
    return [str(moved / name) for name in ("cal.toml", "again.toml", "new.toml")]


@pytest.fixture(scope="module")
def history(three):
    """Each owner's quantity through the three, as the report and compare compute it."""
    cals, _, _ = under_one_prior([load_calibration(f) for f in three], three)
    return {q.what: q for q in calibration_history(cals)}


@pytest.mark.slow
def test_only_the_moved_endstop_changed_and_only_in_its_step(history):
    b = history["tower B's endstop"]
    first, second = b.steps
    assert second.significant, second.words()
    assert abs(second.change - MOVED_MM) < SIGNIFICANT_SIGMAS * second.sigma, second.words()
    assert not first.significant, first.words()
    assert [w for w, q in history.items() if q.steps[0].significant] == []
    assert [w for w, q in history.items() if q.steps[1].significant] == ["tower B's endstop"]
    # each value is the calibration's own, its σ the whole one: the step is the difference of the two values
    assert second.change == pytest.approx(b.values[2].value - b.values[1].value)
    assert all(v.determined and v.sigma > 0.0 for v in b.values)


@pytest.mark.long  # the report's own pages (accuracy map, figures): 3 s
def test_the_report_shows_the_history(three, tmp_path, capsys):
    capsys.readouterr()
    page = tmp_path / "r.html"
    assert main(["report", three[2], "-o", str(page), "--no-view", "--history", three[0], three[1]]) == 0
    out = capsys.readouterr().out
    assert f"history, {three[0]} -> {three[1]}: no significant change between them" in out, out
    assert f"history, {three[1]} -> {three[2]}: significant: tower B's endstop" in out, out
    html = page.read_text()
    section = html[html.index('<section id="history">'):]
    section = section[:section.index("</section>")]
    assert "History of this printer&#x27;s calibrations" in section
    assert html.index('<section id="owner">') < html.index('<section id="history">') < html.index(
        '<section id="overview">')
    row = next(r for r in section[section.index("<tbody>"):].split("<tr>") if "tower B&#x27;s endstop" in r)
    steps = re.findall(r"([+-][0-9.]+) ± ([0-9.]+): (significant|not significant)", row)
    assert [s[2] for s in steps] == ["not significant", "significant"], row
    assert abs(float(steps[1][0]) - MOVED_MM) < SIGNIFICANT_SIGMAS * float(steps[1][1]), row
    assert len(re.findall(r"± [0-9.]+</td>", row)) == 3, row  # its value in each calibration, with σ
    assert "<script" not in section


@pytest.mark.slow
def test_compare_takes_three_calibrations_step_by_step(three, tmp_path, capsys):
    capsys.readouterr()
    page = tmp_path / "h.html"
    assert main(["compare", *three, "-o", str(page)]) == 0
    out = capsys.readouterr().out
    blocks = out.split("What changed in the printer from ")[1:]
    assert [b.split(",")[0] for b in blocks] == [f"{three[0]} to {three[1]}", f"{three[1]} to {three[2]}"]
    assert blocks[0].strip().splitlines()[-1] == "no significant change between them", blocks[0]
    assert "significant: tower B's endstop\n" in blocks[1], blocks[1]
    assert 'id="history"' in page.read_text()


@pytest.fixture(scope="module")
def bad(kossel_identified, tmp_path_factory, bai):
    """Files that are not a printer's calibration of this firmware: a Marlin one, a geometry file, a rotary
    Delta's calibration."""
    folder = tmp_path_factory.mktemp("history_bad")
    cal = kossel_identified / "cal.toml"
    marlin = _edited(cal, folder / "marlin.toml", 'firmware = "klipper"', 'firmware = "marlin"')
    save_calibration(complete_fit(bai, 5), folder / "rotary.toml")
    return {"cal": str(cal), "marlin": marlin, "geometry": str(kossel_identified / "probe.truth.toml"),
            "rotary": str(folder / "rotary.toml"), "missing": str(folder / "missing.toml")}


@pytest.mark.parametrize(("which", "status", "said"), [
    ("marlin", 1, ("Marlin", "Klipper")),
    ("geometry", 1, ("geometry file",)),
    ("rotary", 1, ("rotary",)),
    ("missing", 2, ("missing.toml",)),
])
def test_a_bad_history_file_is_refused_in_one_line_and_nothing_written(bad, tmp_path, capsys, which, status,
                                                                       said):
    capsys.readouterr()
    page = tmp_path / "r.html"
    args = ["report", bad["cal"], "-o", str(page), "--no-view", "--history", bad["cal"], bad[which]]
    assert main(args) == status
    err = _one_line(capsys)
    assert all(word in err for word in said) and bad[which].rsplit("/", 1)[-1] in err, err
    assert not page.exists()
    assert main(["compare", bad["cal"], bad["cal"], bad[which], "-o", str(page)]) == status
    err = _one_line(capsys)
    assert all(word in err for word in said), err
    assert not page.exists()


def test_history_of_a_rotary_calibration_is_refused(bad, tmp_path, capsys):
    capsys.readouterr()
    page = tmp_path / "r.html"
    assert main(["report", bad["rotary"], "-o", str(page), "--no-view", "--history", bad["cal"]]) == 2
    err = _one_line(capsys)
    assert "--history" in err and "rotary" in err, err
    assert not page.exists()
