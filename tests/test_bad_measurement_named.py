"""Issue 47 item 3: one misread caliper distance in Klipper's saved run named, not blamed on the probe.

Klipper's saved ``DELTA_CALIBRATE`` (7 probe heights, 12 distances) leaves the data snooping blind:
one distance 1 mm off raises every distance's residual alike and the kind's robust spread takes the
error for noise; the fit was then refused as poor, "probe.csv: ... a probe biased across the bed ...".
The leave-one-out with the build tolerances as rows (:func:`lone_misfit`) names the row.
"""

from __future__ import annotations

import dataclasses
import importlib.util
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from deltacal.cli.main import main
from deltacal.printer.identification.fit import PrinterFitOptions, identify_printer, printer_outliers
from deltacal.printer.identification.outliers import lone_misfit

ROOT = Path(__file__).resolve().parents[1]
REAL = ROOT / "tests" / "data" / "klipper" / "real"
RUN = REAL / "flsun-v400-a-run1.cfg"
SCRIPT = ROOT / "scripts" / "where_it_holds.py"


@pytest.fixture(scope="module")
def script():
    spec = importlib.util.spec_from_file_location("where_it_holds", SCRIPT)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclasses look their module up
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        spec.loader.exec_module(module)
    return module


def _imported(tmp_path: Path, row: int, by: float) -> tuple[Path, list[str]]:
    """The saved run through ``deltacal import``, its distance data row ``row`` (from 1) ``by`` mm off."""
    out = tmp_path / "v400"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert main(["import", str(RUN), "-o", str(out)]) == 0
    rows = (out / "distances.csv").read_text().splitlines()
    cells = rows[row].split(",")
    cells[6] = f"{float(cells[6]) + by:.4f}"
    rows[row] = ",".join(cells)
    (out / "distances.csv").write_text("\n".join(rows) + "\n")
    return out, ["identify", str(out / "printer.toml"), str(out / "probe.csv"), str(out / "distances.csv"),
                 "--controller", str(RUN), "-o", str(tmp_path / "cal.toml")]


@pytest.mark.long
def test_a_misread_distance_is_named_by_file_row_value_and_what_the_others_give(tmp_path, capsys):
    """Data row 2 (97.636 mm) read 1 mm short: named with what the rest imply; without it the run fits."""
    out, args = _imported(tmp_path, 2, -1.0)
    assert main(args) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "poor fit" not in err and "probe" not in err
    assert "distances.csv: line 3 (data row 2), column distance_mm: distance_mm = 96.636 mm" in err
    given = float(err.split("they give ")[1].split(" mm")[0])
    assert abs(given - 97.636) < 0.05  # the others imply the reading it had
    assert "measure it again" in err and "delete the row to identify without it" in err
    assert not (tmp_path / "cal.toml").exists()
    rows = (out / "distances.csv").read_text().splitlines()  # the row deleted, as the owner is told
    (out / "distances.csv").write_text("\n".join(rows[:2] + rows[3:]) + "\n")
    assert main(args) == 0
    assert (tmp_path / "cal.toml").exists()


def test_the_leave_one_out_names_the_one_row_the_others_contradict():
    """A linear case of Klipper's size: 19 rows, 14 combinations seen (priors as rows), one row 50 σ off."""
    rng = np.random.default_rng(4703)
    W = rng.normal(size=(19, 30)) * np.r_[np.full(14, 5.0), np.full(16, 0.05)]
    values = rng.normal(size=30) * 0.5
    r = rng.normal(size=19) - W @ values  # the fit at ``values``, the measurements at their noise
    measurement = np.arange(19)
    assert lone_misfit(W, r, values, measurement).named.size == 0
    bad = r.copy()
    bad[11] -= 50.0
    found = lone_misfit(W, bad, values, measurement)
    assert found.named.tolist() == [11] and found.undecided.size == 0


def test_two_rows_alike_are_left_undecided_and_a_row_nothing_checks_is_unseen():
    """Two rows alone to see a combination: an error in either is told but not which; a row alone on its
    combination is unseen."""
    rng = np.random.default_rng(4704)
    W = rng.normal(size=(19, 6)) * 3.0
    W[:, 4] = 0.0
    W[4, 4] = W[5, 4] = 300.0  # only rows 4 and 5 see this one: each checks only the other
    W[0] = 0.0
    W[0, 5] = 300.0  # the only row to see the last combination: nothing checks it
    W[1:, 5] = 0.0
    values = np.zeros(6)
    r = rng.normal(size=19) * 0.3
    r[4] += 40.0
    found = lone_misfit(W, r, values, np.arange(19))
    assert found.named.size == 0 and found.undecided.tolist() == [4, 5]
    assert found.unseen.tolist() == [0]


@pytest.mark.long
def test_a_misfit_of_the_whole_names_its_file_not_a_row(tmp_path, capsys):
    """A bed that moved (probe heights 0.6 mm up from the fourth point): poor, named by its file."""
    out, args = _imported(tmp_path, 1, 0.0)
    rows = (out / "probe.csv").read_text().splitlines()
    for k in range(4, len(rows)):
        cells = rows[k].split(",")
        cells[3] = repr(float(cells[3]) + 0.6)
        rows[k] = ",".join(cells)
    (out / "probe.csv").write_text("\n".join(rows) + "\n")
    assert main(args) == 1
    err = capsys.readouterr().err.strip()
    assert "probe.csv (its rows hold" in err and "% of the misfit): a poor fit" in err
    assert "distances.csv" not in err


@pytest.mark.long
def test_on_simulated_printers_a_1mm_error_in_any_one_measurement_is_named(script, tmp_path):
    """Klipper's saved data of 2 simulated printers (a kit, a well-built one): each of the 7 probe
    heights 1 mm high and each of the 12 distances 1 mm short in turn; that one named, no other."""
    options = PrinterFitOptions(calibrated_start=True)
    wrong = []
    for seed, label in ((38200, "typical kit"), (38300, "well built")):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            run = script.simulate(seed, label, "plain", tmp_path)
        data, N = run.data, run.data.probe.shape[0]
        assert printer_outliers(run.nominal, data, "printer", options).indices.size == 0
        for k in range(N + data.distance.size):
            one = np.arange(N + data.distance.size) == k
            if k < N:  # the probe's z_mm 1 mm high: each carriage 1 mm up
                bad = dataclasses.replace(data, probe=data.probe + one[:N, None])
            else:
                bad = dataclasses.replace(data, distance=data.distance - one[N:])
            found = printer_outliers(run.nominal, bad, "printer", options)
            if found.indices.tolist() != [k]:
                wrong.append((label, k, found.indices.tolist()))
    assert not wrong


@pytest.mark.long
def test_the_library_says_the_named_row_without_refusing_it(script):
    """identify_printer keeps the row (the caller decides) and says it: the outliers, the others' s0²."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        run = script.read_real_run(RUN)
    distance = run.data.distance.copy()
    distance[1] -= 1.0
    result = identify_printer(run.nominal, dataclasses.replace(run.data, distance=distance),
                              calibrated_start=True)
    assert result.outliers == [run.data.probe.shape[0] + 1]
    assert result.inlier_variance_factor < 3.0 < result.variance_factor
