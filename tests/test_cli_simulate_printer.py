"""``deltacal simulate`` of a printer: plan's templates filled through the firmware, then identified."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import copy_object_plan, kossel_printer_cfg

from deltacal.cli.main import main
from deltacal.geometry import Tolerances
from deltacal.io import load_calibration, load_geometry, load_nominal, save_geometry
from deltacal.kinematics import exact
from deltacal.printer.files.measurements import read_printed_distances, read_probe_heights
from deltacal.printer.files.robot_file import load_printer
from deltacal.printer.firmware.klipper.config import load_klipper
from deltacal.printer.simulation import probe_heights, random_printer

MODELS = Path(__file__).resolve().parents[1] / "deltacal" / "models"
KOSSEL = MODELS / "kossel.toml"


@pytest.fixture(scope="module")
def planned(tmp_path_factory, kossel_object_plan) -> Path:
    """A folder with printer.cfg and plan --object's templates in plan/."""
    folder = tmp_path_factory.mktemp("printsim")
    copy_object_plan(kossel_object_plan, folder)
    return folder


def _simulate(folder: Path, *extra: str) -> int:
    plan = folder / "plan"
    return main(["simulate", str(KOSSEL), str(plan / "probe.csv"), str(plan / "distances.csv"),
                 "--controller", str(folder / "printer.cfg"), *extra])


def _one_line_error(capsys) -> str:
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1, err
    return err


def test_plan_simulate_identify(planned, tmp_path, capsys):
    probe, distances = tmp_path / "probe.csv", tmp_path / "d.csv"
    assert _simulate(planned, "--perturb", "24", "--seed", "5", "-o", str(probe),
                     "--distances-output", str(distances)) == 0
    truth = load_geometry(tmp_path / "probe.truth.toml")
    assert truth.joint == "prismatic"
    template = read_probe_heights(planned / "plan" / "probe.csv", filled=False)
    filled = read_probe_heights(probe)
    np.testing.assert_array_equal(filled.commanded[:, :2], template.commanded[:, :2])
    planned_pairs = read_printed_distances(planned / "plan" / "distances.csv", filled=False)
    simulated = read_printed_distances(distances)
    np.testing.assert_array_equal(simulated.pairs, planned_pairs.pairs)
    assert simulated.balls == planned_pairs.balls and len(simulated.balls) == len(simulated.pairs)
    out = tmp_path / "cal.toml"
    assert main(["identify", str(KOSSEL), str(probe), str(distances), "--controller",
                 str(planned / "printer.cfg"), "-o", str(out)]) == 0
    calibration = load_calibration(out)
    assert calibration.model.name == "printer" and calibration.geometry.joint == "prismatic"
    # the identified printer's first layer is flat on the true bed
    xy = template.commanded[:, :2]
    layer = np.column_stack([xy * 0.8, np.full(len(xy), 0.2)])
    landed = exact.forward(truth, exact.inverse(calibration.geometry, layer)).point(truth.tool)
    assert np.ptp(landed[:, 2]) < 0.05


def test_a_truth_file_gives_the_library_heights(planned, tmp_path):
    printer = load_printer(KOSSEL)
    truth = random_printer(printer, np.random.default_rng(7), Tolerances.printer_kit())
    save_geometry(truth, tmp_path / "true.toml")
    out = tmp_path / "probe.csv"
    assert main(["simulate", str(KOSSEL), str(planned / "plan" / "probe.csv"), "--controller",
                 str(planned / "printer.cfg"), "--truth", str(tmp_path / "true.toml"), "--sigma-height", "0",
                 "-o", str(out)]) == 0
    assert not (tmp_path / "probe.truth.toml").exists()
    xy = read_probe_heights(planned / "plan" / "probe.csv", filled=False).commanded[:, :2]
    expected = probe_heights(load_geometry(tmp_path / "true.toml"), load_klipper(planned / "printer.cfg"),
                             printer.step_distance, xy, 0.0, np.random.default_rng(0))
    np.testing.assert_allclose(read_probe_heights(out).commanded, expected, atol=1e-9)


def test_a_filled_file_is_read_and_its_values_replaced(planned, tmp_path):
    first, second = tmp_path / "a.csv", tmp_path / "b.csv"
    args = ["--perturb", "3", "--controller", str(planned / "printer.cfg")]
    assert main(["simulate", str(KOSSEL), str(planned / "plan" / "probe.csv"), *args, "-o", str(first)]) == 0
    assert main(["simulate", str(KOSSEL), str(first), *args, "--seed", "1", "-o", str(second)]) == 0
    a, b = read_probe_heights(first).commanded, read_probe_heights(second).commanded
    np.testing.assert_array_equal(a[:, :2], b[:, :2])
    assert not np.array_equal(a[:, 2], b[:, 2])  # the noise of seed 1, not the file's heights


@pytest.mark.parametrize("flag", [["--points", "tcp"], ["--payload", "0,3"], ["--no-orientation"]])
def test_rotary_options_are_refused_for_a_printer(planned, tmp_path, capsys, flag):
    code = _simulate(planned, "--perturb", "1", "-o", str(tmp_path / "p.csv"),
                     "--distances-output", str(tmp_path / "d.csv"), *flag)
    assert code == 2 and "applies to a rotary Delta's simulation" in _one_line_error(capsys)
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("flag", [["--sigma-height", "0.1"], ["--tolerances", "well-built"]])
def test_printer_options_are_refused_for_a_rotary_robot(planned, tmp_path, capsys, flag):
    poses = tmp_path / "poses.csv"
    assert main(["plan", str(MODELS / "bai2015.toml"), "-o", str(poses)]) == 0
    capsys.readouterr()
    code = main(["simulate", str(MODELS / "bai2015.toml"), str(poses), "--perturb", "1",
                 "-o", str(tmp_path / "m.csv"), *flag])
    assert code == 2 and "applies to a printer's simulation" in _one_line_error(capsys)
    assert not (tmp_path / "m.csv").exists()


def test_a_linear_printers_configuration_is_refused_for_a_rotary_robot(planned, tmp_path, capsys):
    """``--controller`` of a rotary robot file is a rotary printer's configuration (issue 48): a linear
    printer's printer.cfg is refused, naming it, nothing written."""
    poses = tmp_path / "poses.csv"
    assert main(["plan", str(MODELS / "bai2015.toml"), "-o", str(poses)]) == 0
    capsys.readouterr()
    cfg = kossel_printer_cfg(tmp_path / "printer.cfg")
    code = main(["simulate", str(MODELS / "bai2015.toml"), str(poses), "--perturb", "1",
                 "-o", str(tmp_path / "m.csv"), "--controller", str(cfg)])
    assert code == 2 and "not Klipper's configuration of a rotary Delta printer" in _one_line_error(capsys)
    assert not (tmp_path / "m.csv").exists()


def test_an_unreachable_row_is_named(planned, tmp_path, capsys):
    probe = tmp_path / "probe.csv"
    probe.write_text((planned / "plan" / "probe.csv").read_text() + "400.0,0.0,\n")
    rows = len(read_probe_heights(probe, filled=False).commanded)
    code = main(["simulate", str(KOSSEL), str(probe), "--controller", str(planned / "printer.cfg"),
                 "--perturb", "1", "-o", str(tmp_path / "out.csv")])
    err = _one_line_error(capsys)
    assert code == 1 and f"{probe}: line {rows + 1} (data row {rows})" in err and "cannot reach" in err
    assert not (tmp_path / "out.csv").exists() and not (tmp_path / "out.truth.toml").exists()


def test_a_pair_the_firmware_cannot_reach_is_named(planned, tmp_path, capsys):
    pairs = tmp_path / "pairs.csv"
    pairs.write_text("x1_mm,y1_mm,z1_mm,x2_mm,y2_mm,z2_mm,distance_mm\n0,0,10,10,0,10,\n0,0,10,0,0,900,\n")
    code = main(["simulate", str(KOSSEL), str(planned / "plan" / "probe.csv"), str(pairs), "--controller",
                 str(planned / "printer.cfg"), "--perturb", "1", "-o", str(tmp_path / "p.csv"),
                 "--distances-output", str(tmp_path / "d.csv")])
    err = _one_line_error(capsys)
    assert code == 1 and f"{pairs}: line 3 (data row 2): the firmware cannot reach" in err
    assert "(a carriage above its endstop)" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["pairs.csv"]


@pytest.mark.parametrize("case", ["output is input", "no distances output", "same outputs", "rotary truth"])
def test_bad_usage(planned, tmp_path, capsys, case):
    template = str(planned / "plan" / "probe.csv")
    out = ["-o", str(tmp_path / "p.csv"), "--distances-output", str(tmp_path / "d.csv")]
    truth = ["--perturb", "1"]
    if case == "output is input":
        out = ["-o", template, "--distances-output", str(tmp_path / "d.csv")]
    elif case == "no distances output":
        out = out[:2]
    elif case == "same outputs":
        out = ["-o", str(tmp_path / "p.csv"), "--distances-output", str(tmp_path / "p.csv")]
    else:  # a rotary Delta's geometry file given as a printer's truth
        save_geometry(load_nominal(MODELS / "bai2015.toml").geometry(), tmp_path / "rotary.toml")
        truth = ["--truth", str(tmp_path / "rotary.toml")]
    before = sorted(p.name for p in tmp_path.iterdir())
    code = _simulate(planned, *truth, *out)
    err = _one_line_error(capsys)
    assert code == (1 if case == "rotary truth" else 2), err
    assert sorted(p.name for p in tmp_path.iterdir()) == before
    if case == "rotary truth":
        assert "key joint: a printer's true geometry has prismatic chains" in err
