"""Messages on a terminal (issue 21): a warning never glued to the progress line."""

from __future__ import annotations

import io
import sys

from deltacal.cli.common import warn
from deltacal.cli.progress import Progress


class Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_a_warning_clears_the_progress_line_first(monkeypatch):
    terminal = Terminal()
    monkeypatch.setattr(sys, "stderr", terminal)
    with Progress("compensate", delay=0.0) as progress:
        progress.update(0.1, "reading")
        warn(["the column extra_mm is ignored"])
        progress.update(0.5, "computing")
    text = terminal.getvalue()
    before, _, after = text.partition("warning: ")
    assert before.endswith("\r\x1b[K"), repr(text)  # the progress line cleared, then the warning
    assert after.startswith("the column extra_mm is ignored\n")
    assert "compensate:  50% computing" in after  # drawn again below the warning
    assert text.endswith("\r\x1b[K")


def test_cr_only_line_endings_are_named(tmp_path, capsys):
    from conftest import MODELS

    from deltacal.cli import main

    targets = tmp_path / "t.csv"
    targets.write_bytes(b"x_mm,y_mm,z_mm\r0,0,-850\r10,0,-850\r")
    robot = tmp_path / "g.toml"
    from deltacal.io import load_nominal, save_geometry

    save_geometry(load_nominal(MODELS / "bai2015.toml").geometry(), robot)
    assert main(["compensate", str(robot), str(targets), "-o", str(tmp_path / "j.csv")]) == 1
    err = capsys.readouterr().err
    assert "t.csv: line 1: the lines end in CR alone" in err and "LF or CRLF" in err
    assert "universal-newline" not in err and len(err.strip().splitlines()) == 1


def test_negative_values_are_read_as_users_type_them(tmp_path, capsys):
    from conftest import MODELS

    from deltacal.cli import main
    from deltacal.io import load_nominal, save_geometry

    robot = tmp_path / "g.toml"
    save_geometry(load_nominal(MODELS / "bai2015.toml").geometry(), robot)
    assert main(["export", str(robot), "--mjcf", str(tmp_path / "m.xml"), "--home", "-5,-5,-5"]) == 0
    assert main(["export", str(robot), "--mjcf", str(tmp_path / "n.xml"), "--home", "1e300,0,0"]) == 2
    err = capsys.readouterr().err
    assert "within ±180 deg" in err and not (tmp_path / "n.xml").exists()


def test_a_plan_that_cannot_identify_its_model_is_refused(tmp_path, capsys):
    from conftest import MODELS

    from deltacal.cli import main

    robot, out = str(MODELS / "bai2015.toml"), str(tmp_path / "p.csv")
    for options, needed in ((["--count", "7"], "of the 42"), (["--count", "1"], "of the 42"),
                            (["--model", "classical", "--count", "2"], "of the 24")):
        assert main(["plan", robot, "--strategy", "doptimal", *options, "-o", out]) == 1
        err = capsys.readouterr().err
        assert needed in err and "use --count" in err and len(err.strip().splitlines()) == 1
    assert main(["plan", robot, "--strategy", "doptimal", "--points", ",", "-o", out]) == 1
    assert "no point named" in capsys.readouterr().err
    assert main(["plan", robot, "--count", "7", "-o", out]) == 2
    assert "--count applies to --strategy doptimal" in capsys.readouterr().err
    from pathlib import Path

    assert not Path(out).exists()
    assert main(["plan", robot, "--strategy", "doptimal", "--count", "20", "-o", out]) == 0


def test_station_names_that_look_like_slips_are_warned(tmp_path):
    """Issue 21, item 15: "East" beside "east", empty station cells, stations of too few poses."""
    from deltacal.io import read_measurement_file

    rows = ["q1_deg,q2_deg,q3_deg,x_mm,y_mm,z_mm,station"]
    for k in range(9):
        station = ("East", "east", "")[k % 3]
        rows.append(f"{k},{2 * k},{3 * k},1,2,{-800 - k},{station}")
    rows.append("40,10,10,1,2,-800,lonely")
    path = tmp_path / "m.csv"
    path.write_text("\n".join(rows) + "\n")
    warnings = " | ".join(read_measurement_file(path).warnings)
    assert "3 row(s) have an empty station" in warnings
    assert "'East', 'east' differ only in case" in warnings
    assert "'lonely' hold fewer than 3 poses" in warnings
    clean = tmp_path / "c.csv"
    clean.write_text("\n".join(r.rsplit(",", 1)[0] + (",a" if i else ",station")
                               for i, r in enumerate(rows[:-1])) + "\n")
    assert read_measurement_file(clean).warnings == []


def test_a_station_name_with_a_comma_reads_back(tmp_path):
    """Issue 21, item 6: simulate wrote `a,b` unquoted and identify failed on its own file."""
    from conftest import MODELS

    from deltacal.cli import main
    from deltacal.io import read_measurements

    robot = str(MODELS / "bai2015.toml")
    poses, meas, cal = (str(tmp_path / n) for n in ("p.csv", "m.csv", "c.toml"))
    assert main(["plan", robot, "--strategy", "doptimal", "--count", "30", "-o", poses]) == 0
    assert main(["simulate", robot, poses, "--perturb", "2", "--no-orientation",
                 "--station", 'a,b "north":0,0,20:1500,300,100', "-o", meas]) == 0
    assert read_measurements(meas)[0].stations == ['a,b "north"']
    assert main(["identify", robot, meas, "--frame", "free", "-o", cal]) == 0
