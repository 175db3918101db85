"""The robot kinds as objects: one chain per kind, asked for what differs, never told apart by words."""

from __future__ import annotations

import ast
import copy
import pickle
from pathlib import Path

import numpy as np
import pytest
from conftest import MODELS

from deltacal.chains import CHAINS, JOINTS, PRISMATIC, REVOLUTE, ROBOT_KINDS, Chain, chain_of
from deltacal.geometry import error_names
from deltacal.robots import load_printer, load_robot

PACKAGE = Path(__file__).resolve().parents[1] / "deltacal"
#: The words of the kinds in files (a geometry file's ``joint``, a robot file's ``kind``).
WORDS = {"revolute", "prismatic", "rotary", "linear"}
#: The modules where those words are read and written: only they may compare them.
FILE_MODULES = {"chains.py", "io/robot.py", "io/geometry_file.py"}


def test_each_word_maps_to_its_chain():
    assert CHAINS == (REVOLUTE, PRISMATIC) and JOINTS == ("revolute", "prismatic")
    assert ROBOT_KINDS == ("rotary", "linear")
    for chain in CHAINS:
        assert chain_of(chain.name) is chain and chain_of(chain.robot_kind) is chain
        assert chain_of(chain) is chain
    with pytest.raises(ValueError, match="joint must be one of revolute, prismatic, got 'spherical'"):
        chain_of("spherical")


def test_a_chain_stays_itself_through_copies_and_pickles():
    for chain in CHAINS:
        assert copy.deepcopy(chain) is chain and pickle.loads(pickle.dumps(chain)) is chain
    g = load_printer(MODELS / "kossel.toml").geometry()
    back = pickle.loads(pickle.dumps(g))
    assert back.chain is PRISMATIC and back.joint == "prismatic" and back.allclose(g)


def test_geometries_hold_their_chain_and_its_word():
    rotary = load_robot(MODELS / "bai2015.toml").geometry()
    printer = load_printer(MODELS / "kossel.toml").geometry()
    assert (rotary.chain, rotary.joint) == (REVOLUTE, "revolute")
    assert (printer.chain, printer.joint) == (PRISMATIC, "prismatic")
    assert error_names(PRISMATIC) == error_names("prismatic") == error_names("linear")
    assert error_names() == error_names(REVOLUTE)


def test_the_words_users_read():
    shown = {chain: (chain.words.part, chain.words.plate, chain.words.tcp) for chain in CHAINS}
    assert shown == {REVOLUTE: ("arm", "plate", "TCP"), PRISMATIC: ("carriage", "effector", "nozzle")}


def test_chain_methods_agree_with_their_paths():
    """A carried point's path and slope, the joint values of a multibody model and back."""
    rng = np.random.default_rng(4)
    q = rng.uniform(-1.0, 1.0, (5, 3))
    scale = np.array([1.0, 1.0, 1.0])
    for chain in CHAINS:
        assert isinstance(chain, Chain)
        assert np.array_equal(chain.reading_of(chain.joint_value(q, scale), scale), q)
        theta = chain.coordinate(q, scale, np.zeros(3))
        assert np.array_equal(theta, q)
        assert chain.carrier_rotation(np.tile(np.eye(3), (3, 1, 1)), theta).shape == (5, 3, 3, 3)


def _kind_tests(path: Path) -> list[str]:
    """Comparisons with a kind's word, dicts keyed by them and identity tests of a chain, in a module."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Compare):
            parts = [node.left, *node.comparators]
            method = "method" in ast.unparse(node.left)  # "linear" as an identification method
            if not method and any(isinstance(x, ast.Constant) and x.value in WORDS for x in parts):
                found.append(f"{node.lineno}: {ast.unparse(node)}")
            if any(isinstance(x, ast.Name) and x.id in ("REVOLUTE", "PRISMATIC") for x in parts):
                found.append(f"{node.lineno}: {ast.unparse(node)}")
        keys = node.keys if isinstance(node, ast.Dict) else []
        if any(isinstance(k, ast.Constant) and k.value in WORDS for k in keys):
            found.append(f"{node.lineno}: a dict keyed by the kinds")
    return found


def test_only_the_file_modules_tell_the_kinds_apart():
    wrong = [f"{path.relative_to(PACKAGE)}:{line}" for path in sorted(PACKAGE.rglob("*.py"))
             if path.relative_to(PACKAGE).as_posix() not in FILE_MODULES for line in _kind_tests(path)]
    assert not wrong, "ask the chain instead:\n" + "\n".join(wrong)
