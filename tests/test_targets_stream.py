"""Streaming targets and joints files (issue 13): chunks, the fast path, lines named across chunks."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import MODELS
from numpy.testing import assert_allclose

from deltacal import InputError
from deltacal.cli import main
from deltacal.io import TargetFile, joint_rows, load_nominal, read_target_table, save_geometry
from deltacal.io import targets as targets_module

NOMINAL = MODELS / "bai2015.toml"
#: Characters the fast path lets through: a field built of them may still be no number.
ALPHABET = list("0123456789+-.eE ")


def random_field(rng: np.random.Generator) -> str:
    """A plain number most of the time, otherwise a random string of the fast path's alphabet."""
    if rng.random() < 0.7:
        return repr(float(rng.normal(0.0, 300.0)))
    return "".join(rng.choice(ALPHABET, size=int(rng.integers(0, 6))))


def outcome(read):
    try:
        return read()
    except InputError as exc:
        return str(exc)


@pytest.mark.parametrize("seed", range(40))
def test_chunked_reading_agrees_with_the_whole_file_checks(tmp_path, seed):
    """Values, lines and errors of the chunked reader are those of read_csv_table, row by row."""
    rng = np.random.default_rng(seed)
    rows = []
    for _ in range(int(rng.integers(1, 40))):
        roll = rng.random()
        if roll < 0.05:
            rows.append("")  # a blank line: skipped, counted
        elif roll < 0.08:
            rows.append("  \r")
        else:
            rows.append(",".join(random_field(rng) if rng.random() < 0.05 else repr(float(rng.normal(0, 300)))
                                 for _ in range(3)))
    newline = "\r\n" if rng.random() < 0.3 else "\n"
    path = tmp_path / "t.csv"
    path.write_bytes(("x_mm,y_mm,z_mm" + newline + newline.join(rows) + newline).encode())

    def whole():
        table = read_target_table(path)
        return np.column_stack([table.numbers[c] for c in ("x_mm", "y_mm", "z_mm")]), table.lines

    def chunked():
        reader = TargetFile(path, chunk_bytes=int(rng.integers(8, 200)))
        chunks = list(reader.chunks())
        rows_seen = [c.first_row for c in chunks]
        assert rows_seen == list(np.cumsum([1] + [len(c) for c in chunks[:-1]]))
        return np.concatenate([c.targets for c in chunks]), np.concatenate([c.lines for c in chunks])

    expected, got = outcome(whole), outcome(chunked)
    if isinstance(expected, str):
        assert got == expected
    else:
        assert not isinstance(got, str), got
        assert_allclose(got[0], expected[0], rtol=0, atol=0)
        assert got[1].tolist() == expected[1].tolist()


def test_the_fast_path_refuses_what_the_field_checks_refuse(tmp_path):
    """Fields float() takes but a CSV number is not (and overflow) fail with the line named."""
    for value, message in (("1e999", "is not a finite number"), ("1.2.3", "is not a number"),
                           ("", "empty value in a required column")):
        path = tmp_path / "t.csv"
        path.write_text("x_mm,y_mm,z_mm\n1,2,3\n4,5,6\n" + f"7,{value},9\n")
        with pytest.raises(InputError, match=message) as info:
            list(TargetFile(path, chunk_bytes=6).chunks())
        assert "line 4 (data row 3), column y_mm" in str(info.value)


def test_joint_rows_write_the_targets_as_given_and_the_readings_to_twelve_decimals():
    rng = np.random.default_rng(3)
    q = np.concatenate([rng.uniform(-180.0, 180.0, (50, 3)),
                        [[0.0, -0.0, 1e-13], [-4e-13, 6e-13, 99.9999999999996], [-1.0, 100.0, -0.5]]])
    text = np.array([f"{k},x,{k / 7!r}".encode() for k in range(q.shape[0])])
    out = joint_rows(text, q).decode()
    lines = out.splitlines()
    assert len(lines) == q.shape[0] and out.endswith("\n")
    assert [s.rsplit(",", 3)[0] for s in lines] == [t.decode() for t in text]
    back = np.array([[float(v) for v in s.split(",")[3:]] for s in lines])
    assert_allclose(back, q, rtol=0, atol=0.5e-12)
    assert lines[-3].split(",")[3:] == ["0.000000000000", "0.000000000000", "0.000000000000"]
    # no "-0": a reading that rounds to zero is written unsigned; rounding carries into the units
    assert lines[-2].split(",")[3:] == ["0.000000000000", "0.000000000001", "100.000000000000"]
    assert lines[-1].split(",")[3:] == ["-1.000000000000", "100.000000000000", "-0.500000000000"]


def test_a_bad_or_unreachable_row_in_a_later_chunk_is_named_and_an_earlier_output_kept(
        tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(targets_module, "CHUNK_BYTES", 64)
    geometry = tmp_path / "g.toml"
    save_geometry(load_nominal(NOMINAL).geometry(), geometry)
    good = [f"{x},{-x},-900" for x in range(0, 100, 5)]
    targets, out = tmp_path / "t.csv", tmp_path / "j.csv"
    out.write_text("earlier joints\n")
    targets.write_text("x_mm,y_mm,z_mm\n" + "\n".join(good + ["0,0,-200", "0,0,-900"]) + "\n")
    assert main(["compensate", str(geometry), str(targets), "-o", str(out)]) == 1
    err = capsys.readouterr().err
    assert f"{targets}: line 22 (data row 21), columns x_mm..z_mm: target [0.0, 0.0, -200.0] mm is out of " \
           "reach" in err
    assert out.read_text() == "earlier joints\n"
    targets.write_text("x_mm,y_mm,z_mm\n" + "\n".join(good + ["0,0,-9x0"]) + "\n")
    assert main(["compensate", str(geometry), str(targets), "-o", str(out)]) == 1
    assert "line 22 (data row 21), column z_mm: value '-9x0' is not a number" in capsys.readouterr().err
    assert out.read_text() == "earlier joints\n"
    # and the good rows alone, across many chunks, give every row once, in order
    targets.write_text("x_mm,y_mm,z_mm\n" + "\n".join(good) + "\n")
    assert main(["compensate", str(geometry), str(targets), "-o", str(out)]) == 0
    written = out.read_text().splitlines()
    assert written[0] == "x_mm,y_mm,z_mm,q1_deg,q2_deg,q3_deg"
    assert [s.rsplit(",", 3)[0] for s in written[1:]] == good


def test_an_unreachable_last_row_is_refused_by_the_reading_pass(tmp_path, capsys, monkeypatch):
    """Issue 13: the reading pass's screen names the line before anything is compensated or written."""
    from deltacal.wings import compensate_job as command

    monkeypatch.setattr(targets_module, "CHUNK_BYTES", 64)

    class NoWriting:
        def __init__(self, path):
            raise AssertionError("the joints file was opened: the refusal came after the reading pass")

    monkeypatch.setattr(command, "JointsWriter", NoWriting)
    geometry = tmp_path / "g.toml"
    save_geometry(load_nominal(NOMINAL).geometry(), geometry)
    rng = np.random.default_rng(13)
    good = [f"{x:.3f},{y:.3f},-900" for x, y in rng.uniform(-100.0, 100.0, (40, 2))]
    targets, out = tmp_path / "t.csv", tmp_path / "j.csv"
    out.write_text("earlier joints\n")
    targets.write_text("x_mm,y_mm,z_mm\n" + "\n".join(good + ["0,0,-200"]) + "\n")
    assert main(["compensate", str(geometry), str(targets), "-o", str(out)]) == 1
    err = capsys.readouterr().err
    assert err.strip().endswith(f"{targets}: line 42 (data row 41), columns x_mm..z_mm: "
                                "target [0.0, 0.0, -200.0] mm is out of reach of the robot")
    assert out.read_text() == "earlier joints\n"
    # a bad value in a later chunk is still named first, though the unreachable row comes before it
    targets.write_text("x_mm,y_mm,z_mm\n" + "\n".join(["0,0,-200"] + good + ["0,0,-9x0"]) + "\n")
    assert main(["compensate", str(geometry), str(targets), "-o", str(out)]) == 1
    assert "line 43 (data row 42), column z_mm: value '-9x0' is not a number" in capsys.readouterr().err
    assert out.read_text() == "earlier joints\n"


def test_worker_processes_write_what_one_process_writes(tmp_path, capsys, monkeypatch):
    """A large file is solved by a pool of forked workers (``wings.workers``): the same bytes, in order,
    and a refusal in a worker named by its line."""
    from deltacal import Controller, Tolerances
    from deltacal.io import save_controller
    from deltacal.wings import workers

    monkeypatch.setattr(targets_module, "CHUNK_BYTES", 256)
    nominal = load_nominal(NOMINAL)
    geometry = tmp_path / "g.toml"
    save_geometry(nominal.geometry().perturbed(Tolerances.bai2015(), np.random.default_rng(3)), geometry)
    rng = np.random.default_rng(4)
    points = np.column_stack([rng.uniform(-200, 200, (120, 2)), rng.uniform(-950, -800, 120)])
    rows = [f"{x:.3f},{y:.3f},{z:.3f}" for x, y, z in points]
    targets = tmp_path / "t.csv"
    targets.write_text("x_mm,y_mm,z_mm\n" + "\n".join(rows) + "\n")
    for extra in ([], ["--controller", str(NOMINAL)]):
        outputs = []
        for pool_rows in (10**9, 0):  # one process, then the pool
            monkeypatch.setattr(workers, "POOL_ROWS", pool_rows)
            out = tmp_path / f"o{pool_rows}.csv"
            assert main(["compensate", str(geometry), str(targets), "-o", str(out), *extra]) == 0
            outputs.append(out.read_bytes())
        assert workers._workers(120) > 1 or len(workers.os.sched_getaffinity(0)) == 1
        assert outputs[0] == outputs[1] and len(outputs[0].splitlines()) == 121
    # a controller whose arms cannot reach: refused in a worker, named by its line, nothing written
    short = tmp_path / "short.toml"
    save_controller(short, Controller.from_geometry(nominal).replace(rod_length=np.full(3, 400.0)))
    out = tmp_path / "refused.csv"
    capsys.readouterr()
    assert main(["compensate", str(geometry), str(targets), "-o", str(out), "--controller", str(short)]) == 1
    err = capsys.readouterr().err
    assert "line 2 (data row 1)" in err and len(err.strip().splitlines()) == 1
    assert not out.exists()
