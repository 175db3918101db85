"""Issue 48: a rotary Delta printer from Klipper's own saved ``DELTA_CALIBRATE`` data.

``deltacal import rotary.cfg`` writes the SAVE_CONFIG block's ``[delta_calibrate]`` measurements as
``probe.csv`` and ``distances.csv`` (commanded positions in Klipper's frame through the configuration's own
values), and ``identify --controller rotary.cfg`` of them starts from Klipper's values calibrated from the
very same data (wide priors on what Klipper's rotary calibration fitted).
"""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from deltacal.cli import main
from deltacal.printer.files.measurements import read_printed_distances, read_probe_heights
from deltacal.printer.firmware.klipper.config import read_klipper_config
from deltacal.printer.firmware.klipper.rotary_config import rotary_from_config
from deltacal.printer.firmware.klipper.rotary_model import KlipperRotaryDelta
from tests.test_klipper_rotary import EXAMPLE
from tests.test_klipper_rotary_compensate import MEASURED

#: The keys Klipper's rotary calibration saves (``RotaryDeltaCalibration.save_state``): SAVE_CONFIG
#: comments out their copies in the rest of the file.
SAVED_KEYS = ("shoulder_radius:", "shoulder_height:", "angle:", "position_endstop:")


def stable(steps: np.ndarray) -> str:
    """A stable position as Klipper saves it (``%.3f`` steps)."""
    return ",".join(f"{v:.3f}" for v in steps)


def saved_rotary_config(values: KlipperRotaryDelta, steps: np.ndarray, heights: np.ndarray,
                        pair_steps: np.ndarray | None = None, distances: np.ndarray | None = None) -> str:
    """The example ``printer.cfg`` after ``SAVE_CONFIG`` of Klipper's rotary calibration: the values it saves
    (``%.6f``, as ``save_state``) and its measurements (``DeltaCalibrate.save_state``)."""
    lines = ["#*# <---------------------- SAVE_CONFIG ---------------------->",
             "#*# DO NOT EDIT THIS BLOCK OR BELOW. The contents are auto-generated.", "#*#",
             "#*# [printer]", f"#*# shoulder_radius = {values.shoulder_radius:.6f}",
             f"#*# shoulder_height = {values.shoulder_height:.6f}", "#*#"]
    for i, arm in enumerate("abc"):
        lines += [f"#*# [stepper_{arm}]", f"#*# angle = {np.degrees(values.angle[i]):.6f}",
                  f"#*# position_endstop = {values.position_endstop[i]:.6f}", "#*#"]
    lines.append("#*# [delta_calibrate]")
    for i, (s, h) in enumerate(zip(steps, heights, strict=True)):
        lines += [f"#*# height{i} = {h!r}", f"#*# height{i}_pos = {stable(s)}"]
    pairs = np.zeros((0, 2, 3)) if pair_steps is None else pair_steps
    for i, (p, d) in enumerate(zip(pairs, np.zeros(0) if distances is None else distances, strict=True)):
        lines += [f"#*# distance{i} = {d!r}", f"#*# distance{i}_pos1 = {stable(p[0])}",
                  f"#*# distance{i}_pos2 = {stable(p[1])}"]
    rest = "\n".join("#" + line if line.startswith(SAVED_KEYS) else line
                     for line in EXAMPLE.read_text().split("\n"))
    return rest.rstrip() + "\n\n" + "\n".join(lines) + "\n"


def _example() -> KlipperRotaryDelta:
    return rotary_from_config(read_klipper_config(EXAMPLE))


#: Commanded positions worked out for the example's values: the centre 5 mm up, two points of the probe's
#: ring on the bed [mm].
POINTS = np.array([[0.0, 0.0, 5.0], [0.0, 50.0, 0.0], [-43.30127, -25.0, 0.0]])


def test_import_writes_the_saved_heights_and_distances_through_the_configurations_values(tmp_path, capsys):
    """Stable positions of known commanded positions through the example's values (steps from the
    endstops, saved to 0.001 step: 1.3e-4 mm at most) read back through the same saved values: the
    positions to 1e-3 mm, each height's trigger height the saved heightN, each distance the saved one."""
    k = _example()
    steps = k.steps(POINTS)
    assert np.all(np.abs(steps) > 1000.0)  # steps, not angles
    cfg = tmp_path / "printer.cfg"
    cfg.write_text(saved_rotary_config(k, steps, [1.5, 1.25, 1.0], steps[[0, 1]][None], [50.25]))
    assert main(["import", str(cfg), "-o", str(tmp_path / "imp"), *MEASURED]) == 0
    said = capsys.readouterr().out
    assert "3 rows" in said and "1 rows" in said, said
    probe = read_probe_heights(tmp_path / "imp" / "probe.csv")
    assert_allclose(probe.commanded, POINTS, rtol=0, atol=1e-3)
    assert_allclose(probe.heights, [1.5, 1.25, 1.0], rtol=0, atol=0)
    distances = read_printed_distances(tmp_path / "imp" / "distances.csv")
    assert_allclose(distances.pairs, [np.concatenate(POINTS[:2])], rtol=0, atol=1e-3)
    assert_allclose(distances.distance, [50.25], rtol=0, atol=0)


def test_the_saved_steps_are_commanded_through_the_saved_values_not_the_probings(tmp_path):
    """Klipper's stable positions mean steps: after a calibration (the saved shoulder height 1 mm up, arm
    B's endstop 0.5 mm down) the same steps are other commanded positions, those of the new values
    (``get_position_from_stable``), not those probed with (the centre's height moved by 0.6 mm or more)."""
    k = _example()
    steps = k.steps(POINTS)
    new = KlipperRotaryDelta(k.shoulder_radius, k.shoulder_height + 1.0, k.angle, k.upper_arm, k.lower_arm,
                             k.position_endstop + [0.0, -0.5, 0.0], k.step_distance)
    cfg = tmp_path / "printer.cfg"
    cfg.write_text(saved_rotary_config(new, steps, [0.0, 0.0, 0.0]))
    assert main(["import", str(cfg), "-o", str(tmp_path / "imp"), *MEASURED]) == 0
    probe = read_probe_heights(tmp_path / "imp" / "probe.csv")
    expected = new.step_positions(np.array([[float(v) for v in stable(s).split(",")] for s in steps]))
    assert_allclose(probe.commanded, expected, rtol=0, atol=1e-9)
    assert abs(probe.commanded[0, 2] - POINTS[0, 2]) > 0.6
    assert not (tmp_path / "imp" / "distances.csv").exists()


def test_saved_steps_out_of_the_arms_reach_are_refused_in_one_line(tmp_path, capsys):
    """Steps no arm reaches through the values (another printer's): one line naming the file, the section
    and the steps; nothing written."""
    k = _example()
    steps = k.steps(POINTS)
    steps[1, :2] = [20000.0, 40000.0]  # arms A and B turned 90 and 180 deg up: their rods cannot meet
    cfg = tmp_path / "printer.cfg"
    cfg.write_text(saved_rotary_config(k, steps, [0.0, 0.0, 0.0]))
    assert main(["import", str(cfg), "-o", str(tmp_path / "imp"), *MEASURED]) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert "printer.cfg" in err and "[delta_calibrate]" in err and "[20000.0, 40000.0," in err, err
    assert not (tmp_path / "imp").exists()


@pytest.mark.parametrize("key", ["height1_pos", "distance0_pos2"])
def test_a_saved_position_that_is_not_three_step_counts_is_named(tmp_path, capsys, key):
    """One line naming the file, section and key."""
    k = _example()
    steps = k.steps(POINTS)
    text = saved_rotary_config(k, steps, [0.0, 0.0, 0.0], steps[[0, 1]][None], [50.25])
    text = text.replace(f"#*# {key} = ", f"#*# {key} = 12,", 1)
    (tmp_path / "printer.cfg").write_text(text)
    assert main(["import", str(tmp_path / "printer.cfg"), "-o", str(tmp_path / "imp"), *MEASURED]) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and key in err and "stable position" in err, err
