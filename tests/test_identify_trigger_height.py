"""``identify`` of an imported FLSUN Q5 or QQ-S Pro: probe heights judged against their trigger height.

Their probes trigger with the nozzle 22 to 24 mm above the bed (``[probe] z_offset``, the
``trigger_height_mm`` of the imported probe.csv): the commanded z at the trigger is that far above
the bed the firmware knows, not an error of 20 mm (issue 40, item 12). A height beyond the bound
from the trigger height is still refused.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from deltacal.cli import main
from deltacal.io import load_calibration

REAL = Path(__file__).resolve().parent / "data" / "klipper" / "real"


@pytest.mark.parametrize(("name", "trigger", "misread"), [
    # the Q5's saved distances hold one 0.52 mm (26 σ) off what the other 18 measurements give: named
    # (issue 47), then identified without it
    pytest.param("flsun-q5-razorcopter.cfg", "24.374", 10, marks=pytest.mark.long),
    ("flsun-qqs-pro-susisstrolch.cfg", "22.0", None)])
def test_an_imported_flsun_with_a_tall_probe_is_identified(tmp_path, capsys, name, trigger, misread):
    folder = tmp_path / "imported"
    assert main(["import", str(REAL / name), "-o", str(folder)]) == 0
    assert f",{trigger}\n" in (folder / "probe.csv").read_text()  # each row's trigger_height_mm
    files = [str(folder / name) for name in ("probe.csv", "distances.csv") if (folder / name).exists()]
    command = ["identify", str(folder / "printer.toml"), *files, "--controller", str(REAL / name),
               "-o", str(tmp_path / "cal.toml")]
    capsys.readouterr()
    if misread is not None:
        assert main(command) == 1
        err = capsys.readouterr().err
        assert f"distances.csv: line {misread + 1} (data row {misread}), column distance_mm" in err, err
        assert "does not fit the other measurements" in err and not (tmp_path / "cal.toml").exists()
        rows = (folder / "distances.csv").read_text().splitlines(keepends=True)
        (folder / "distances.csv").write_text("".join(rows[:misread] + rows[misread + 1:]))
    assert main(command) == 0, capsys.readouterr().err
    assert load_calibration(tmp_path / "cal.toml").residuals_after.height_rms < 0.05


def test_a_height_far_from_its_trigger_height_is_still_refused(tmp_path, capsys):
    name = "flsun-qqs-pro-susisstrolch.cfg"
    folder = tmp_path / "imported"
    assert main(["import", str(REAL / name), "-o", str(folder)]) == 0
    probe = folder / "probe.csv"
    rows = probe.read_text().splitlines()
    x, y, z, trigger = rows[3].split(",")
    rows[3] = ",".join((x, y, str(float(z) + 25.0), trigger))  # 47 mm: 25 mm above where the probe triggers
    probe.write_text("\n".join(rows) + "\n")
    capsys.readouterr()
    assert main(["identify", str(folder / "printer.toml"), str(probe), "--controller", str(REAL / name),
                 "-o", str(tmp_path / "cal.toml")]) == 1
    err = capsys.readouterr().err
    assert "probe.csv: line 4 (data row 3), column z_mm: the probe triggered at z_mm = 46.8" in err
    assert "from the bed the firmware knows (its trigger height 22 mm, trigger_height_mm, taken off)" in err
    assert "1 of 7 rows" in err and len(err.strip().splitlines()) == 2  # the includes' warning, the error
