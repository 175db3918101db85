"""``deltacal compare`` of a rotary Delta printer's calibrations, arm by arm.

Three calibrations of one simulated rotary printer (Klipper's example rotary configuration imported, a
rotary kit's errors), oldest first, all identified through the same configuration: the printer measured
(noise seed 1), measured again (seed 2), then arm B's endstop angle moved (its encoder offset, 0.3 deg) and
measured (seed 3). Each fit chooses its own tolerances' scale: compare identifies them again under one prior.

Then the first against a calibration through re-calibrated values (Klipper's own DELTA_CALIBRATE run on the
printer, its values pasted over the example's): the first's readings counted again as the new values count
the same steps, both identified again under one prior (:func:`~deltacal.printer.history.under_one_prior`).
"""

from __future__ import annotations

import re
from dataclasses import replace

import numpy as np
import pytest
from conftest import MODELS

from deltacal.calibration import Calibration
from deltacal.cli import main
from deltacal.errormodels import get_model
from deltacal.exceptions import InputError
from deltacal.geometry import Tolerances
from deltacal.io import load_calibration, save_calibration
from deltacal.io.robot import load_nominal
from deltacal.printer.files.measurements import write_printed_distances, write_probe_heights
from deltacal.printer.files.robot_file import load_printer
from deltacal.printer.firmware.klipper.config import read_klipper_config
from deltacal.printer.firmware.klipper.rotary_calibrate import klipper_rotary_basic, klipper_rotary_extended
from deltacal.printer.firmware.klipper.rotary_config import rotary_config_text, rotary_from_config
from deltacal.printer.firmware.klipper.rotary_controller import KlipperRotaryController
from deltacal.printer.history import SIGNIFICANT_SIGMAS, calibration_history, under_one_prior
from deltacal.printer.rotary_simulation import RotaryPrinter, printed_distances, probe_triggers
from tests.test_klipper_rotary import EXAMPLE
from tests.test_klipper_rotary_compensate import MEASURED
from tests.test_rotary_printer_identification import _plan

#: Arm B's endstop angle moved between the second and third calibrations [deg].
MOVED_DEG = 0.3


def _printer(folder):
    """Klipper's example rotary configuration imported into ``folder`` and a simulated printer of it (a rotary
    kit's errors): the robot file, the example's values, the truth, the planned probe points and pairs."""
    assert main(["import", str(EXAMPLE), "-o", str(folder / "imp"), *MEASURED]) == 0
    robot = folder / "imp" / "printer.toml"
    k = rotary_from_config(read_klipper_config(EXAMPLE))
    nominal = KlipperRotaryController(k).in_bed_frame(load_nominal(robot).geometry())
    tolerances = Tolerances.rotary_printer_kit()
    rng = np.random.default_rng(4801)
    truth = nominal.perturbed(tolerances, rng)
    truth = replace(truth, joint_scale=1.0 + rng.normal(0.0, tolerances.joint_scale, 3))
    xy, pairs = _plan(k, nominal, tolerances)
    return robot, k, truth, xy, pairs


def _moved(truth, k, degrees: float) -> RotaryPrinter:
    """The true printer with arm B's endstop angle (its encoder offset) moved by ``degrees``, its readings
    counted by the example's values ``k`` (whatever values command it)."""
    offset = np.array(truth.encoder_offset, dtype=float)
    offset[1] += np.radians(degrees)
    return RotaryPrinter(replace(truth, encoder_offset=offset), k)


def _measured(folder, printer: RotaryPrinter, k, xy, pairs, seed: int):
    """The printer probed and its object printed and measured through the values ``k`` (noise ``seed``)."""
    noise = np.random.default_rng(seed)
    probe = probe_triggers(printer, k, xy)
    probe[:, 2] += noise.normal(0.0, 0.01, len(probe))
    distances = np.round(printed_distances(printer, k, pairs) + noise.normal(0.0, 0.02, len(pairs)), 3)
    write_probe_heights(folder / f"probe{seed}.csv", probe[:, :2], probe[:, 2])
    write_printed_distances(folder / f"distances{seed}.csv", pairs, distances)
    return probe, distances


def _identified(folder, robot, config, seed: int) -> str:
    """``deltacal identify`` of measurements ``seed`` through ``config``: the calibration file."""
    cal = folder / f"cal{seed}.toml"
    assert main(["identify", str(robot), str(folder / f"probe{seed}.csv"),
                 str(folder / f"distances{seed}.csv"), "--controller", str(config), "-o", str(cal)]) == 0
    return str(cal)


@pytest.fixture(scope="module")
def first(tmp_path_factory):
    """The simulated printer (:func:`_printer`) and its first calibration, through the example's values."""
    folder = tmp_path_factory.mktemp("rotary-compare")
    robot, k, truth, xy, pairs = _printer(folder)
    _measured(folder, _moved(truth, k, 0.0), k, xy, pairs, 1)
    return {"folder": folder, "robot": robot, "k": k, "truth": truth, "xy": xy, "pairs": pairs,
            "cal": _identified(folder, robot, EXAMPLE, 1)}


@pytest.fixture(scope="module")
def three(first):
    """The three calibrations' files, oldest first: measured, measured again, arm B's endstop moved."""
    folder, robot, k, truth = first["folder"], first["robot"], first["k"], first["truth"]
    files = [first["cal"]]
    for seed, moved in ((2, 0.0), (3, MOVED_DEG)):
        _measured(folder, _moved(truth, k, moved), k, first["xy"], first["pairs"], seed)
        files.append(_identified(folder, robot, EXAMPLE, seed))
    return files


def _recalibrated(first, folder, degrees: float, extended: bool) -> list[str]:
    """Two calibrations of one printer through two configurations: the first's (through Klipper's example
    values); then arm B's endstop angle moved by ``degrees`` in the true printer, Klipper's DELTA_CALIBRATE
    (extended: 7 values; else basic: 4) run on it (fresh probing and print, the example's values probing),
    its values pasted over the example (``recalibrated.cfg``), the printer measured and identified through
    them."""
    k, xy, pairs = first["k"], first["xy"], first["pairs"]
    moved = _moved(first["truth"], k, degrees)
    probe, distances = _measured(folder, moved, k, xy, pairs, 4)
    values = (klipper_rotary_extended(k, probe, pairs, distances) if extended
              else klipper_rotary_basic(k, probe))
    again = folder / "recalibrated.cfg"
    again.write_text(EXAMPLE.read_text() + "\n" + rotary_config_text(values, "DELTA_CALIBRATE again"))
    _measured(folder, moved, rotary_from_config(read_klipper_config(again)), xy, pairs, 2)
    return [first["cal"], _identified(folder, first["robot"], again, 2)]


@pytest.fixture(scope="module")
def recalibrated_moved(first, tmp_path_factory):
    """:func:`_recalibrated` with arm B's endstop moved 0.3 deg, Klipper's extended calibration."""
    return _recalibrated(first, tmp_path_factory.mktemp("rotary-recalibrated-moved"), MOVED_DEG, True)


@pytest.fixture(scope="module")
def recalibrated_same(first, tmp_path_factory):
    """:func:`_recalibrated` with the printer unchanged, Klipper's basic calibration (cheaper)."""
    return _recalibrated(first, tmp_path_factory.mktemp("rotary-recalibrated-same"), 0.0, False)


@pytest.mark.slow
def test_only_arm_b_endstop_changed_and_only_in_its_step(three):
    """Under one prior, arm B's endstop is the one significant change, in the step that moved it, within
    3 σ of the move (+0.227 ± 0.040 deg); measured again with fresh noise, nothing is significant."""
    cals, _, said = under_one_prior([load_calibration(f) for f in three], three)
    assert "identified again under one prior" in said[-1], said
    history = {q.what: q for q in calibration_history(cals)}
    b = history["arm B's endstop"]
    first, second = b.steps
    assert second.unit == "deg" and second.significant, second.words()
    assert abs(second.change - MOVED_DEG) < SIGNIFICANT_SIGMAS * second.sigma, second.words()
    assert [w for w, q in history.items() if q.steps[0].significant] == []
    assert [w for w, q in history.items() if q.steps[1].significant] == ["arm B's endstop"]
    assert {"arm A's gear ratio", "arm C's lower arms apart"} <= set(history)


@pytest.mark.slow
def test_compare_says_it_arm_by_arm(three, capsys):
    capsys.readouterr()
    assert main(["compare", *three]) == 0
    out = capsys.readouterr().out
    assert "arm B's endstop moved +" in out, out
    steps = [line for line in out.splitlines() if line.startswith(("significant", "no significant"))]
    assert steps == ["no significant change between them", "significant: arm B's endstop"], out



def test_a_linear_and_a_rotary_printers_calibrations_are_refused_together():
    """Two calibrations of different kinds (a linear Kossel's, a rotary Delta's): one line naming both files,
    before anything is identified again."""
    linear = load_printer(MODELS / "kossel.toml").geometry()
    rotary = load_nominal(MODELS / "bai2015.toml").geometry()
    cals = [Calibration(geometry=g, nominal=g, model=get_model("complete"), base=[],
                        correlation=np.zeros((0, 0))) for g in (linear, rotary)]
    with pytest.raises(InputError) as refused:
        under_one_prior(cals, ["old.toml", "new.toml"])
    line = str(refused.value)
    assert len(line.splitlines()) == 1 and "old.toml" in line and "new.toml" in line and "rotary" in line


def _compared(files, capsys) -> tuple[str, dict[str, tuple[float, float]]]:
    """``deltacal compare`` of the files: its output (exit 0 asserted), each change's value and σ by name."""
    capsys.readouterr()
    assert main(["compare", *files]) == 0
    out = capsys.readouterr().out
    changes = {}
    for line in out.splitlines():
        found = re.search(r"(arm .+?|the .+?) moved ([-+][0-9.]+) ± ([0-9.]+) ", line)
        if found:
            changes[found.group(1).strip()] = (float(found.group(2)), float(found.group(3)))
    return out, changes


@pytest.mark.slow
def test_through_recalibrated_values_arm_b_endstop_is_the_one_change(recalibrated_moved, capsys):
    """Issue 46 item 6 on a rotary printer: calibrated through the example's values; then arm B's endstop
    angle moved 0.3 deg AND the printer.cfg's values re-calibrated by Klipper's extended DELTA_CALIBRATE
    (shoulder height and radius, angles A and B, the three endstops changed: stepper_b's takes the move),
    calibrated through those. ``compare`` exits 0, says in one line that it re-anchored the older to the
    newer's values, naming the keys changed, and arm B's endstop is the only significant change, within
    3 σ of 0.3 deg. Measured: arm B's endstop +0.308 ± 0.038 deg; arm A's -0.000 ± 0.038, arm C's
    -0.050 ± 0.041 deg; the largest other, arm A's shoulder tilted -0.084 ± 0.038 deg. (Before: refused,
    "identified through other rotary values ... compare does not count again".)"""
    out, changes = _compared(recalibrated_moved, capsys)
    said = [line for line in out.splitlines() if "re-anchored" in line]
    assert len(said) == 1 and "stepper_b.position_endstop" in said[0], out
    steps = [line for line in out.splitlines() if line.startswith(("significant", "no significant"))]
    assert steps == ["significant: arm B's endstop"], out
    change, sigma = changes["arm B's endstop"]
    assert abs(change - MOVED_DEG) < SIGNIFICANT_SIGMAS * sigma, out


@pytest.mark.slow
def test_through_recalibrated_values_an_unchanged_printer_shows_nothing(recalibrated_same, capsys):
    """The same printer unchanged, only its printer.cfg's values re-calibrated between the calibrations
    (Klipper's basic DELTA_CALIBRATE: shoulder height and the three endstops): re-anchored, nothing
    significant. Measured: arm B's endstop +0.016 ± 0.038 deg, arm A's -0.002 ± 0.038, arm C's -0.051 ±
    0.042; the largest, arm A's shoulder tilted -0.081 ± 0.038 deg (2.1 σ). (Before: refused.)"""
    out, _ = _compared(recalibrated_same, capsys)
    assert any("re-anchored" in line for line in out.splitlines()), out
    steps = [line for line in out.splitlines() if line.startswith(("significant", "no significant"))]
    assert steps == ["no significant change between them"], out


@pytest.mark.slow
def test_another_printers_rotary_values_are_refused_naming_the_key(first, tmp_path, capsys):
    """A calibration whose recorded rotary values are another printer's (arm A's upper arm 200 mm against
    the example's 170: beyond a build's tolerance) is not re-anchored: ``compare`` refuses it in one line
    naming the key, both values and the file, exit non-zero. (Before: refused as any change of the values,
    "identified through other rotary values", naming no value apart.)"""
    cal = load_calibration(first["cal"])
    assert cal.controller is not None
    values = {**cal.controller.values, "stepper_a.upper_arm_length": 200.0}
    other = tmp_path / "other.toml"
    save_calibration(replace(cal, controller=replace(cal.controller, values=values)), other)
    capsys.readouterr()
    assert main(["compare", str(other), first["cal"]]) != 0
    out, err = capsys.readouterr()
    assert len(err.strip().splitlines()) == 1 and "upper_arm_length (arm A) is 200 mm" in err, (out, err)
    assert "170 mm in" in err and "other.toml" in err and "re-anchored" not in out, (out, err)
