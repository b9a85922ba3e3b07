"""The examples run and write their pictures; the stubs and docstrings
cover every public name."""

import ast
import pathlib
import subprocess
import sys

import pytest

import hyperpbd as hp
from conftest import REPO

EXAMPLES = REPO / "python" / "examples"
PICTURES = {
    "cloth_on_plane.py": "cloth_on_plane.png",
    "damping_sweep.py": "damping_sweep.png",
    "energy_4d.py": "energy_4d.png",
    "expression_families.py": "expression_families.png",
    "moving_obstacles.py": None,
    "scene_from_dict.py": None,
}


@pytest.mark.parametrize("name", sorted(PICTURES))
def test_example_runs(name, tmp_path):
    pytest.importorskip("matplotlib", reason="the examples draw with matplotlib")
    done = subprocess.run(
        [sys.executable, str(EXAMPLES / name), str(tmp_path)],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=EXAMPLES,
    )
    assert done.returncode == 0, done.stderr
    picture = PICTURES[name]
    if picture is not None:
        png = (tmp_path / picture).read_bytes()
        assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 10_000


def stub_names():
    """{class or function: {member names}} declared in _native.pyi."""
    tree = ast.parse((pathlib.Path(hp.__file__).parent / "_native.pyi").read_text())
    names = {}
    for node in tree.body:
        if isinstance(node, ast.ClassDef):
            names[node.name] = {
                n.name for n in node.body if isinstance(n, (ast.FunctionDef, ast.AnnAssign)) and hasattr(n, "name")
            } | {n.target.id for n in node.body if isinstance(n, ast.AnnAssign)}
        elif isinstance(node, ast.FunctionDef):
            names[node.name] = set()
    return names


def test_stubs_declare_every_public_name():
    declared = stub_names()
    for name in hp.__all__:
        if name == "__version__":
            continue
        assert name in declared, f"{name} has no stub"
        obj = getattr(hp, name)
        assert obj.__doc__, f"{name} has no docstring"
        if isinstance(obj, type) and not issubclass(obj, Exception):
            for member in vars(obj):
                if member.startswith("_"):
                    continue
                assert member in declared[name], f"{name}.{member} has no stub"
                assert getattr(obj, member).__doc__, f"{name}.{member} has no docstring"
