"""The README's Python example runs as written (from the repository root), and the API reference's
table of main objects matches the package."""

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


def test_the_api_tables_match_the_public_names():
    """Every name of ``deltacal.__all__`` (exceptions aside) is in the API reference's table of main
    objects (docs/api/index.md), and every name there imports from the module its row gives."""
    import importlib

    import deltacal
    import deltacal.exceptions

    text = (ROOT / "docs" / "api" / "index.md").read_text(encoding="utf-8")
    section = text[text.index("## Main objects"):text.index("## Reference pages")]
    named: set[str] = set()
    for line in section.splitlines():
        if not line.startswith("| `"):
            continue
        cells = [c.strip() for c in line.strip("|").split("|")]
        modules = re.findall(r"`([\w.]+)`", cells[1])
        for name in re.findall(r"`([A-Za-z_][\w.]*)`", cells[0]):
            named.add(name)
            found = False
            for module in modules:
                obj = importlib.import_module(f"deltacal.{module}")
                try:
                    for part in name.split("."):
                        obj = getattr(obj, part)
                    found = True
                except AttributeError:
                    continue
            assert found, f"docs/api/index.md names {name} in {modules}, which do not hold it"
    exceptions = {n for n in dir(deltacal.exceptions) if n[0].isupper()} | {"__version__"}
    missing = sorted(set(deltacal.__all__) - named - exceptions)
    assert not missing, f"exported but not in the API reference's table: {missing}"
