"""``deltacal compare`` of a rotary Delta printer's calibrations, arm by arm.

Three calibrations of one simulated rotary printer (Klipper's example rotary configuration imported, a
rotary kit's errors), oldest first, all identified through the same configuration: the printer measured
(noise seed 1), measured again (seed 2), then arm B's endstop angle moved (its encoder offset, 0.3 deg) and
measured (seed 3). Each fit chooses its own tolerances' scale: compare identifies them again under one prior.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from conftest import MODELS

from deltacal.calibration import Calibration
from deltacal.cli import main
from deltacal.errormodels import get_model
from deltacal.exceptions import InputError
from deltacal.geometry import Tolerances
from deltacal.io import load_calibration
from deltacal.io.robot import load_nominal
from deltacal.printer.files.measurements import write_printed_distances, write_probe_heights
from deltacal.printer.files.robot_file import load_printer
from deltacal.printer.firmware.klipper.config import read_klipper_config
from deltacal.printer.firmware.klipper.rotary_config import rotary_from_config
from deltacal.printer.firmware.klipper.rotary_controller import KlipperRotaryController
from deltacal.printer.history import SIGNIFICANT_SIGMAS, calibration_history, under_one_prior
from deltacal.printer.rotary_simulation import RotaryPrinter, printed_distances, probe_triggers
from tests.test_klipper_rotary import EXAMPLE
from tests.test_klipper_rotary_compensate import MEASURED
from tests.test_rotary_printer_identification import _plan

#: Arm B's endstop angle moved between the second and third calibrations [deg].
MOVED_DEG = 0.3


@pytest.fixture(scope="module")
def three(tmp_path_factory):
    """The three calibrations' files, oldest first: measured, measured again, arm B's endstop moved."""
    folder = tmp_path_factory.mktemp("rotary-compare")
    assert main(["import", str(EXAMPLE), "-o", str(folder / "imp"), *MEASURED]) == 0
    robot = folder / "imp" / "printer.toml"
    k = rotary_from_config(read_klipper_config(EXAMPLE))
    nominal = KlipperRotaryController(k).in_bed_frame(load_nominal(robot).geometry())
    tolerances = Tolerances.rotary_printer_kit()
    rng = np.random.default_rng(4801)
    truth = nominal.perturbed(tolerances, rng)
    truth = replace(truth, joint_scale=1.0 + rng.normal(0.0, tolerances.joint_scale, 3))
    xy, pairs = _plan(k, nominal, tolerances)
    files = []
    for seed, moved in ((1, 0.0), (2, 0.0), (3, MOVED_DEG)):
        offset = np.array(truth.encoder_offset, dtype=float)
        offset[1] += np.radians(moved)
        printer = RotaryPrinter(replace(truth, encoder_offset=offset), k)
        noise = np.random.default_rng(seed)
        probe = probe_triggers(printer, k, xy)
        probe[:, 2] += noise.normal(0.0, 0.01, len(probe))
        distances = np.round(printed_distances(printer, k, pairs) + noise.normal(0.0, 0.02, len(pairs)), 3)
        write_probe_heights(folder / f"probe{seed}.csv", probe[:, :2], probe[:, 2])
        write_printed_distances(folder / f"distances{seed}.csv", pairs, distances)
        cal = folder / f"cal{seed}.toml"
        assert main(["identify", str(robot), str(folder / f"probe{seed}.csv"),
                     str(folder / f"distances{seed}.csv"), "--controller", str(EXAMPLE), "-o", str(cal)]) == 0
        files.append(str(cal))
    return files


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
