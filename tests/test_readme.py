"""The README's Python example runs as written (from the repository root)."""

import os
import re

from conftest import ROOT


def test_readme_python_example_runs(tmp_path, monkeypatch, capsys):
    text = (ROOT / "README.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, flags=re.S)
    assert blocks, "the README has a Python example"
    robot = ROOT / "deltacal" / "models" / "bai2015.toml"
    code = blocks[0].replace('"models/bai2015.toml"', repr(str(robot)))
    monkeypatch.chdir(tmp_path)
    exec(compile(code, "README.md", "exec"), {})
    out = capsys.readouterr().out
    assert "plate tilt [deg]" in out and "rank 42 of 51" in out
    assert os.path.exists(tmp_path / "calibration.toml")
    # the validation line of the exact compensation with the 200 mm tool: within 0.02 mm
    max_mm = float(re.search(r"max error ([0-9.]+) mm", out).group(1))
    assert max_mm < 0.02
