"""The type stub `_native.pyi` against the compiled module: the same
functions, classes, methods and properties, with the same parameter names
(pyo3 exposes each native signature as `__text_signature__`)."""

from __future__ import annotations

import ast
import inspect
import os

import hairshade
from hairshade import _native

STUB = os.path.join(os.path.dirname(hairshade.__file__), "_native.pyi")


def _stub() -> tuple[dict[str, list[str]], dict[str, dict[str, list[str] | None]], set[str]]:
    """(functions -> parameter names, classes -> {member -> parameter names
    or None for properties}, module-level names assigned in the stub)."""
    tree = ast.parse(open(STUB).read())
    funcs: dict[str, list[str]] = {}
    classes: dict[str, dict[str, list[str] | None]] = {}
    names: set[str] = set()

    def params(f: ast.FunctionDef) -> list[str]:
        return [a.arg for a in f.args.posonlyargs + f.args.args + f.args.kwonlyargs if a.arg != "self"]

    for node in tree.body:
        if isinstance(node, ast.FunctionDef):
            funcs[node.name] = params(node)
        elif isinstance(node, ast.ClassDef):
            members: dict[str, list[str] | None] = {}
            for m in node.body:
                if isinstance(m, ast.FunctionDef):
                    prop = any(isinstance(d, ast.Name) and d.id == "property" for d in m.decorator_list)
                    members[m.name] = None if prop else params(m)
            classes[node.name] = members
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            names.add(node.target.id)
    return funcs, classes, names


def _native_params(f: object) -> list[str]:
    return [p for p in inspect.signature(f).parameters if p != "self"]  # type: ignore[arg-type]


def test_01_every_native_name_is_in_the_stub_and_back():
    funcs, classes, names = _stub()
    public = {n for n in dir(_native) if not n.startswith("_")} | {"__version__"}
    stub_names = set(funcs) | set(classes) | names
    assert public - stub_names == set(), "in the module, missing from the stub"
    assert stub_names - public == set(), "in the stub, missing from the module"


def test_02_functions_have_the_stub_parameters():
    funcs, _, _ = _stub()
    for name, params in funcs.items():
        assert _native_params(getattr(_native, name)) == params, name


def test_03_classes_have_the_stub_members():
    _, classes, _ = _stub()
    for cname, members in classes.items():
        cls = getattr(_native, cname)
        native = {m for m in vars(cls) if not m.startswith("_")}
        assert native == {m for m in members if not m.startswith("_")}, cname
        for m, params in members.items():
            attr = inspect.getattr_static(cls, m)
            if params is None:
                assert not callable(attr), f"{cname}.{m} should be a property"
            elif m == "__init__":
                assert [p for p in inspect.signature(cls).parameters] == params, f"{cname}.__init__"
            else:
                assert _native_params(attr) == params, f"{cname}.{m}"
