"""``deltacal import CONFIG -o DIR`` into a folder that already holds measurements: refused, nothing lost.

An earlier import (another printer's, or a configuration that held measurements then) leaves
``probe.csv`` and ``distances.csv``; an import that writes none must not leave them beside its new
``printer.toml`` (``identify`` would fit the wrong printer's data) nor delete them (a user's file):
it is refused in one line naming them, nothing written (issue 40, item 8).
"""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from deltacal.cli.main import main

DATA = Path(__file__).resolve().parent / "data"
#: Its SAVE_CONFIG block holds 7 heights and 12 distances.
Q5 = DATA / "klipper" / "real" / "flsun-q5-razorcopter.cfg"


def _configuration(tmp_path: Path, firmware: str) -> Path:
    """A real-shaped configuration of each firmware that holds no measurements."""
    if firmware == "rrf":
        for name in ("config.g", "config-override.g"):
            shutil.copy(DATA / "rrf" / name, tmp_path / name)
        return tmp_path / "config.g"
    if firmware == "marlin":
        return shutil.copy(DATA / "marlin_m503.txt", tmp_path / "m503.txt")
    return shutil.copy(DATA / "klipper" / "printer.cfg", tmp_path / "printer.cfg")


@pytest.mark.parametrize("firmware", ["klipper", "rrf", "marlin"])
def test_another_printers_measurements_in_the_folder_are_refused_and_kept(tmp_path, capsys, firmware):
    folder = tmp_path / "imported"
    assert main(["import", str(Q5), "-o", str(folder)]) == 0  # printer.toml, probe.csv, distances.csv
    before = {name: (folder / name).read_bytes() for name in ("printer.toml", "probe.csv", "distances.csv")}
    capsys.readouterr()
    assert main(["import", str(_configuration(tmp_path, firmware)), "-o", str(folder)]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1
    assert f"{folder}: holds probe.csv and distances.csv, which this import does not write" in err
    assert "move or delete them, or import into another folder" in err
    assert {name: (folder / name).read_bytes() for name in before} == before  # nothing written, nothing lost


def test_one_stale_file_is_named_alone_and_a_clean_folder_imports(tmp_path, capsys):
    folder = tmp_path / "imported"
    folder.mkdir()
    (folder / "distances.csv").write_text("x1_mm,y1_mm,z1_mm,x2_mm,y2_mm,z2_mm,distance_mm\n")
    config = _configuration(tmp_path, "marlin")
    assert main(["import", str(config), "-o", str(folder)]) == 2
    assert "holds distances.csv, which this import does not write" in capsys.readouterr().err
    assert not (folder / "printer.toml").exists()
    (folder / "distances.csv").unlink()
    assert main(["import", str(config), "-o", str(folder)]) == 0
    assert sorted(p.name for p in folder.iterdir()) == ["printer.toml"]


def test_the_same_printer_imported_again_rewrites_its_three_files(tmp_path):
    folder = tmp_path / "imported"
    assert main(["import", str(Q5), "-o", str(folder)]) == 0
    assert main(["import", str(Q5), "-o", str(folder)]) == 0
    assert sorted(p.name for p in folder.iterdir()) == ["distances.csv", "printer.toml", "probe.csv"]
