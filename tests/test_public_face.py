"""The top level is the job's face; what it held before still imports, with a warning naming its home."""

import importlib
import subprocess
import sys
import warnings

import pytest

import deltacal
from deltacal import _moved


def test_the_face_holds_at_most_45_names_and_each_imports():
    assert len(deltacal.__all__) <= 45
    for name in deltacal.__all__:
        assert getattr(deltacal, name) is not None


@pytest.mark.parametrize("name", sorted(deltacal._FORMER))
def test_a_former_top_level_name_warns_and_names_its_home(name):
    with pytest.warns(DeprecationWarning, match=rf"deltacal\.{name} is now deltacal\.[\w.]+\.{name}"):
        value = getattr(deltacal, name)
    home = importlib.import_module(f"deltacal.{deltacal._FORMER[name]}")
    assert value is getattr(home, name)
    assert name not in deltacal.__all__ and name not in dir(deltacal)


def test_every_old_module_path_is_the_new_module_with_a_warning():
    # a fresh interpreter: no old path may be in sys.modules yet
    code = """
import importlib, warnings, deltacal
from deltacal._moved import MOVED
for old, new in sorted(MOVED.items()):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        module = importlib.import_module(old)
    assert module is importlib.import_module(new), (old, module)
    said = [str(w.message) for w in caught if issubclass(w.category, DeprecationWarning)]
    assert any(new in text and old in text for text in said), (old, said)
print(len(MOVED))
"""
    done = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True)
    assert done.stdout.strip() == str(len(_moved.MOVED))


def test_an_unknown_name_is_an_attribute_error():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(AttributeError, match="no attribute 'no_such_name'"):
            deltacal.no_such_name  # noqa: B018


@pytest.mark.parametrize("name", ["load_robot", "load_controller", "load_printer"])
def test_io_readers_of_either_kind_moved_up_and_warn(name):
    import deltacal.io

    with pytest.warns(DeprecationWarning, match=rf"deltacal\.io\.{name} is now deltacal\.[\w.]+\.{name}"):
        value = getattr(deltacal.io, name)
    assert value.__name__ == name
