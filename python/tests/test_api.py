"""The module's surface: every public name documented and in the stub; a light import."""

import ast
import inspect
import pathlib
import subprocess
import sys

import autonomsim

STUB = pathlib.Path(autonomsim.__file__).with_name("__init__.pyi")


def stub_names() -> dict:
    """Top-level names of the stub, and each class's members."""
    tree = ast.parse(STUB.read_text())
    names = {}
    for node in tree.body:
        if isinstance(node, ast.ClassDef):
            members = set()
            for item in node.body:
                if isinstance(item, ast.FunctionDef):
                    members.add(item.name)
                elif isinstance(item, ast.AnnAssign):
                    members.add(item.target.id)
            names[node.name] = members
        elif isinstance(node, ast.FunctionDef):
            names[node.name] = set()
    return names


def public_members(cls) -> set:
    return {n for n in vars(cls) if not n.startswith("_")} | {
        n for n in getattr(cls, "__slots__", ()) if not n.startswith("_")}


def test_every_public_name_has_a_docstring_and_a_stub():
    stub = stub_names()
    for name in autonomsim.__all__:
        obj = getattr(autonomsim, name)
        assert inspect.getdoc(obj), name
        assert name in stub, name
        if inspect.isclass(obj) and obj is not autonomsim.ScenarioError:
            for member in public_members(obj):
                assert member in stub[name], f"{name}.{member}"
                attr = getattr(obj, member, None)
                if callable(attr) and not isinstance(attr, type):
                    assert inspect.getdoc(attr), f"{name}.{member}"


def test_importing_leaves_pandas_and_matplotlib_unloaded():
    code = "import autonomsim, sys; print(sorted({'pandas', 'matplotlib'} & set(sys.modules)))"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert done.stdout.strip() == "[]"
