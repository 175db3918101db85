"""``deltacal export CAL --controller klipper --config rotary.cfg -o out.cfg``: Klipper's rotary_delta values
fitted to a rotary Delta printer's calibration, written as its keys.

The printer: Klipper's example-rotary-delta.cfg, imported; the calibration: a geometry file of it with the
complete error model's deviations (as tests/test_klipper_rotary_compensate.py builds it). The values the file
holds, read back by the rotary reader pasted over the configuration, are fit_klipper_rotary's over the
configuration's volume ([delta_calibrate] radius 50 mm, up to Klipper's limit_z), in Klipper's frame.
"""

from __future__ import annotations

import numpy as np
import pytest

from deltacal.cli import main
from deltacal.geometry import Workspace
from deltacal.io.geometry_file import save_geometry
from deltacal.printer.firmware.klipper.config import read_klipper_config
from deltacal.printer.firmware.klipper.rotary_config import rotary_from_config
from deltacal.printer.firmware.klipper.rotary_fit import RotaryCommands, fit_klipper_rotary, values_of
from deltacal.robots import load_robot
from tests.test_klipper_rotary import EXAMPLE
from tests.test_klipper_rotary_compensate import KLIPPER_DIR, _truth

#: Half the written decimals: 6 for lengths [mm], 4 for angles [deg], in the order of ROTARY_NAMES.
HALF_DIGIT = 0.5 * np.array([1e-6, 1e-6] + [np.radians(1e-4)] * 3 + [1e-6] * 9) + 1e-12


def _values(klipper) -> np.ndarray:
    return values_of(RotaryCommands(klipper, klipper.endstop_angles))


def _written(tmp_path, out) -> np.ndarray:
    """The values of ``out`` pasted over the example configuration, read back by the rotary reader."""
    pasted = tmp_path / "pasted.cfg"
    pasted.write_text(EXAMPLE.read_text() + "\n" + out.read_text())
    return _values(rotary_from_config(read_klipper_config(pasted)))


def _export(tmp_path, capsys, *more: str) -> tuple[str, object, object]:
    nominal, truth = _truth(tmp_path)
    save_geometry(truth, tmp_path / "cal.toml")
    capsys.readouterr()
    assert main(["export", str(tmp_path / "cal.toml"), "--controller", "klipper", "--config", str(EXAMPLE),
                 "-o", str(tmp_path / "out.cfg"), *more]) == 0
    return capsys.readouterr().out, nominal, truth


def test_export_writes_the_fitted_rotary_values_and_says_what_they_leave(tmp_path, capsys):
    """Exit 0; the file's values are fit_klipper_rotary's (to the written decimals), in Klipper's keys; the
    figures said are the fit's: 3-D max 0.248 -> 0.094 mm, first layer 0.106 -> 0.003 mm (seed 3)."""
    said, nominal, truth = _export(tmp_path, capsys)
    start = rotary_from_config(read_klipper_config(EXAMPLE))
    fit = fit_klipper_rotary(truth, start, Workspace(50.0, start.limit_z, start.limit_z),
                             nozzle_drop_of=nominal)
    written = _written(tmp_path, tmp_path / "out.cfg")
    assert np.all(np.abs(written - _values(fit.values)) <= HALF_DIGIT)
    assert np.max(np.abs(written - _values(start))) > 0.1  # not the configuration's values
    lines = said.splitlines()
    assert lines[0] == f"wrote the Klipper rotary values that best fit {tmp_path / 'cal.toml'} to " \
                       f"{tmp_path / 'out.cfg'}"
    assert "bed (z = 0) at z = -452.9 mm" in lines[1]
    assert "radius 50 mm, z from 0.2 to 211.652 mm" in lines[2] and "[delta_calibrate] radius" in lines[2]
    assert lines[3] == (f"  these values: 3-D max {fit.after.max_3d:.3f} mm, RMS {fit.after.rms_3d:.3f} mm; "
                        f"first layer (z 0.2 mm) max |dz| {fit.after.flatness:.3f} mm, peak to valley "
                        f"{fit.after.flatness_pv:.3f} mm")
    assert lines[4].startswith(f"  the --config values: 3-D max {fit.before.max_3d:.3f} mm")
    assert fit.after.max_3d < 0.5 * fit.before.max_3d and fit.after.flatness < fit.before.flatness
    assert lines[-1].startswith("to apply: Replace these keys in printer.cfg")
    text = (tmp_path / "out.cfg").read_text()
    assert text.startswith("# Klipper rotary_delta values fitted by deltacal to") and lines[3] in text
    assert "[stepper_c]\nangle: 270.0000\n" in text  # the printed part's turn, held


def test_the_robot_files_workspace_is_the_same_volume_moved_into_klippers_frame(tmp_path, capsys):
    """--robot printer.toml (the import's [workspace]: the same volume, in {O}, 452.9 mm below Klipper's
    bed): the same values as the configuration's volume, the robot file named."""
    said, nominal, truth = _export(tmp_path, capsys, "--robot", str(tmp_path / "imp" / "printer.toml"))
    assert f"211.652 mm of {tmp_path / 'imp' / 'printer.toml'})" in said
    start = rotary_from_config(read_klipper_config(EXAMPLE))
    fit = fit_klipper_rotary(truth, start, Workspace(50.0, start.limit_z, start.limit_z),
                             nozzle_drop_of=nominal)
    assert np.all(np.abs(_written(tmp_path, tmp_path / "out.cfg") - _values(fit.values)) <= HALF_DIGIT)


@pytest.mark.parametrize("which", ["no --config", "linear cfg, rotary calibration",
                                   "rotary cfg, linear calibration", "--keep-rotation-distance"])
def test_bad_input_is_refused_in_one_line_nothing_written(tmp_path, capsys, which):
    linear_cfg = KLIPPER_DIR / "example-delta.cfg"
    if which.startswith("rotary cfg"):
        assert main(["import", str(linear_cfg), "-o", str(tmp_path / "lin")]) == 0
        save_geometry(load_robot(tmp_path / "lin" / "printer.toml").geometry(), tmp_path / "cal.toml")
    else:
        _, truth = _truth(tmp_path)
        save_geometry(truth, tmp_path / "cal.toml")
    args = {"no --config": [],
            "linear cfg, rotary calibration": ["--config", str(linear_cfg)],
            "rotary cfg, linear calibration": ["--config", str(EXAMPLE)],
            "--keep-rotation-distance": ["--config", str(EXAMPLE), "--keep-rotation-distance"]}[which]
    capsys.readouterr()
    assert main(["export", str(tmp_path / "cal.toml"), "--controller", "klipper", "-o",
                 str(tmp_path / "out.cfg"), *args]) != 0
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err
    assert not (tmp_path / "out.cfg").exists()
    expected = {"no --config": "give --config printer.cfg",
                "linear cfg, rotary calibration": f"--config {linear_cfg} is not Klipper's configuration "
                                                  "of a rotary Delta printer",
                "rotary cfg, linear calibration": f"{EXAMPLE}: section [printer], key kinematics: value "
                                                  "'rotary_delta'",
                "--keep-rotation-distance": "--keep-rotation-distance applies to a linear Delta printer's"}
    assert expected[which] in err

