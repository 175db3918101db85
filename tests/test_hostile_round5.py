"""Issue 49, items 4 and 6: a printer's calibration without its limits; the Python API's commonest mistakes.

A printer's calibration file without its ``[holds]`` table (written before it existed, or cut by hand)
is refused in one line by every route that corrects only where it holds (compensate --controller, a
program, export, export --live, the Python API), nothing written; a rotary Delta's, which has none, is
not. ``compensate``, ``validate`` and ``corrected_targets`` given targets of another shape than (N, 3)
(or (3,)) say so naming the argument, and take a calibration as its geometry.
"""

from __future__ import annotations

import math
import re
import shutil

import numpy as np
import pytest
from conftest import MODELS

import deltacal
from deltacal.calibration import BaseParameter, Calibration
from deltacal.cli import main
from deltacal.controller import Controller, corrected_targets, weighted_targets
from deltacal.errormodels import get_model
from deltacal.exceptions import InputError
from deltacal.io import load_calibration, load_nominal, save_geometry
from deltacal.printer.firmware.klipper.config import load_klipper
from deltacal.printer.firmware.klipper.firmware import KLIPPER
from deltacal.printer.firmware.klipper.live.field import LiveVolume, correction_field
from deltacal.robots import load_robot

KOSSEL = MODELS / "kossel.toml"
BAI = load_robot(MODELS / "bai2015.toml").geometry()


def _without_holds(text: str) -> str:
    """A calibration file's text with its ``[holds]`` table and its sub-tables cut out."""
    kept, cutting = [], False
    for line in text.splitlines(keepends=True):
        if line.startswith("["):
            cutting = re.match(r"\[\[?holds[.\]]", line) is not None
        if not cutting:
            kept.append(line)
    return "".join(kept)


@pytest.fixture(scope="module")
def printer(tmp_path_factory, kossel_identified):
    """A Kossel identified through its printer.cfg, and the same calibration file cut of ``[holds]``."""
    folder = tmp_path_factory.mktemp("round5")
    shutil.copytree(kossel_identified, folder, dirs_exist_ok=True)
    cfg = folder / "printer.cfg"
    text = (folder / "cal.toml").read_text()
    assert "\n[holds]\n" in text
    cut = _without_holds(text)
    assert "[holds" not in cut and "[controller]" in cut and "[geometry]" in cut
    (folder / "unheld.toml").write_text(cut)
    (folder / "targets.csv").write_text("x_mm,y_mm,z_mm\n0,0,5\n20,10,6\n0,0,120\n")
    (folder / "part.gcode").write_text("G28\nG90\nG1 X0 Y0 Z5 F3000\nG1 X20 Y10 Z6\n")
    return {"folder": folder, "cfg": cfg, "held": folder / "cal.toml", "unheld": folder / "unheld.toml"}


def _one_line(capsys) -> str:
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert "Traceback" not in err
    return err


def _says_identify_again(err: str, calibration) -> None:
    assert f"error: {calibration}: key holds: no [holds] table" in err, err
    assert "identify the printer again" in err and "deltacal identify" in err


# ------------------------------------------------------------- 4. a printer's calibration without [holds]
@pytest.mark.parametrize("options", [[], ["--sigma-bound", "0.2"], ["--refuse-unheld"]])
def test_compensate_refuses_a_printer_calibration_without_holds(printer, tmp_path, capsys, options):
    """Before: the targets were corrected wholly and the options ignored without a word."""
    held = tmp_path / "held.csv"  # the refusal is the table's: the file it was cut from is corrected
    assert main(["compensate", str(printer["held"]), str(printer["folder"] / "targets.csv"), "--controller",
                 str(printer["cfg"]), "-o", str(held)]) == 0
    assert "corrections applied where their σ is at most" in capsys.readouterr().out and held.exists()
    for source in ("targets.csv", "part.gcode"):
        out = tmp_path / f"out{source[-6:]}"
        assert main(["compensate", str(printer["unheld"]), str(printer["folder"] / source),
                     "--controller", str(printer["cfg"]), "-o", str(out), *options]) == 1
        _says_identify_again(_one_line(capsys), printer["unheld"])
        assert not out.exists()


def test_export_refuses_a_printer_calibration_without_holds(printer, tmp_path, capsys):
    """Before: the values were fitted over the whole volume; --live wrote a module without a σ grid."""
    out = tmp_path / "k.cfg"
    assert main(["export", str(printer["unheld"]), "--controller", "klipper", "--config", str(printer["cfg"]),
                 "-o", str(out)]) == 1
    _says_identify_again(_one_line(capsys), printer["unheld"])
    assert not out.exists()
    live = tmp_path / "live"
    assert main(["export", str(printer["unheld"]), "--controller", "klipper", "--config", str(printer["cfg"]),
                 "--live", "-o", str(live)]) == 1
    _says_identify_again(_one_line(capsys), printer["unheld"])
    assert not live.exists()


def test_the_python_api_refuses_a_printer_calibration_without_holds(printer):
    """weighted_targets, corrected_targets, correction_field: an InputError (a ValueError), the file named."""
    unheld, held = load_calibration(printer["unheld"]), load_calibration(printer["held"])
    assert unheld.holds is None and held.holds is not None
    klipper = load_klipper(printer["cfg"])
    controller = KLIPPER.controller(klipper, held.geometry.step_distance)
    targets = np.array([[0.0, 0.0, 5.0], [20.0, 10.0, 6.0]])
    assert weighted_targets(held, controller, targets).weights.shape == (2, 2)
    named = re.escape(str(printer["unheld"]))
    for call in (lambda: weighted_targets(unheld, controller, targets),
                 lambda: corrected_targets(unheld, controller, targets, bound=math.inf),
                 lambda: correction_field(unheld, controller, LiveVolume.of(klipper), step=1e9)):
        with pytest.raises(InputError, match=rf"{named}: key holds: no \[holds\]"):
            call()
    with pytest.raises(ValueError, match="identify the printer again"):
        unheld.where_held()
    # the identified geometry alone (no calibration) is corrected everywhere, as before
    assert np.all(weighted_targets(unheld.geometry, controller, targets).weights == 1.0)


def test_a_rotary_calibration_has_no_holds_and_is_not_refused():
    """A rotary Delta's identification says nothing of where it holds: corrected everywhere, as before."""
    base = [BaseParameter("a1", "δa1", 0.1, 0.01, "mm")]
    rotary = Calibration(BAI, BAI, get_model("complete"), base, np.eye(1))
    assert rotary.holds is None and rotary.where_held() is None
    targets = np.array([[0.0, 0.0, -800.0], [30.0, -20.0, -850.0]])
    held = weighted_targets(rotary, Controller.from_geometry(BAI), targets)
    assert np.all(held.weights == 1.0)
    np.testing.assert_allclose(held.commands, targets, atol=1e-9)  # the robot is its controller's model


# ------------------------------------------------------------------ 6. the Python API's commonest mistakes
BAD_SHAPES = [(4, 2), (3, 1), (2, 2, 3), (2,), (4,)]


@pytest.mark.parametrize("shape", BAD_SHAPES)
def test_compensate_names_the_targets_shape(shape):
    """Before: "operands could not be broadcast", or (3, 1) read as 3 targets out of reach."""
    shown = re.escape(str(shape))
    message = rf"^targets must have shape \(N, 3\), or \(3,\) for one target; got shape {shown}$"
    with pytest.raises(ValueError, match=message):
        deltacal.compensate(BAI, np.zeros(shape))


def test_compensate_and_validate_take_a_calibration_as_its_geometry():
    """Before: AttributeError: 'Calibration' object has no attribute 'tool'."""
    calibration = Calibration(BAI, BAI, get_model("complete"), [], np.zeros((0, 0)))
    targets = np.array([[0.0, 0.0, -800.0], [30.0, -20.0, -850.0]])
    q = deltacal.compensate(BAI, targets)
    np.testing.assert_array_equal(deltacal.compensate(calibration, targets), q)
    np.testing.assert_array_equal(deltacal.compensate(BAI, targets[1]), q[1:])  # one target: (3,)
    assert deltacal.validate(calibration, q, targets).max_mm < 1e-9
    with pytest.raises(TypeError, match="geometry must be a DeltaGeometry .* got str"):
        deltacal.compensate("bai2015.toml", targets)


@pytest.mark.parametrize("shape", [(2, 2), (3, 1), (2, 2, 3)])
def test_validate_names_the_readings_and_targets_shapes(shape):
    """Before: "operands could not be broadcast" (q), "axes don't match array", or "actual" (targets)."""
    targets = np.array([[0.0, 0.0, -800.0], [30.0, -20.0, -850.0]])
    q = deltacal.compensate(BAI, targets)
    shown = re.escape(str(shape))
    with pytest.raises(ValueError, match=rf"^q must have shape \(N, 3\), or \(3,\) for one reading; got "
                                         rf"shape {shown}$"):
        deltacal.validate(BAI, np.zeros(shape), targets)
    with pytest.raises(ValueError, match=rf"^targets must have shape \(N, 3\).* got shape {shown}$"):
        deltacal.validate(BAI, q, np.zeros(shape))
    with pytest.raises(ValueError, match="^q and targets must have a row per pose each: 2 readings for 3"):
        deltacal.validate(BAI, q, np.vstack([targets, targets[:1]]))
    with pytest.raises(ValueError, match=r"home must be the index of a target \(0 to 1\), got 2"):
        deltacal.validate(BAI, q, targets, home=2)


@pytest.mark.parametrize("shape", [(4, 2), (3, 1), (2, 2, 3)])
def test_corrected_targets_names_the_targets_shape(shape):
    """Before: a broadcast error inside numpy (or (3, 1) read as three targets)."""
    shown = re.escape(str(shape))
    with pytest.raises(ValueError, match=rf"^targets must have shape \(N, 3\).* got shape {shown}$"):
        corrected_targets(BAI, Controller.from_geometry(BAI), np.zeros(shape))


# ------------------------------------------------------------- 7. what else a hostile look found
def test_compensate_of_a_printer_calibration_without_controller_says_to_give_it(printer, tmp_path, capsys):
    """Before: "values must be finite and below 9,007 to be written exactly to 12 decimals" (carriage
    travels in mm written as degrees), exit 1."""
    out = tmp_path / "joints.csv"
    targets = printer["folder"] / "targets.csv"
    assert main(["compensate", str(printer["held"]), str(targets), "-o", str(out)]) == 2
    err = _one_line(capsys)
    assert f"{printer['held']} is a printer's calibration: give --controller" in err, err
    assert not out.exists()


@pytest.mark.parametrize("option", [["--refuse-unheld"], ["--sigma-bound", "0.2"]])
def test_the_holds_options_without_a_controller_are_refused(tmp_path, capsys, option):
    """Before: a rotary Delta's joints were written, the option ignored without a word."""
    rotary, targets, out = tmp_path / "r.toml", tmp_path / "t.csv", tmp_path / "j.csv"
    save_geometry(load_nominal(MODELS / "bai2015.toml").geometry(), rotary)
    targets.write_text("x_mm,y_mm,z_mm\n0,0,-900\n")
    assert main(["compensate", str(rotary), str(targets), "-o", str(out), *option]) == 2
    err = _one_line(capsys)
    assert f"{' '.join(option)} applies with --controller" in err, err
    assert not out.exists()
    assert main(["compensate", str(rotary), str(targets), "-o", str(out)]) == 0  # without it: the joints
