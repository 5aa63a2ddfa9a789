"""riskscore/_riskscore.pyi (what editors and mypy see) against the extension module it
describes: the same functions, methods and parameter names, and classes that cannot be
subclassed at runtime marked @final (what `python -m mypy.stubtest riskscore._riskscore`
checks; mypy is not among the test tools, so this reads the stub with ast)."""
import ast
import inspect
import pathlib

import pytest

import riskscore
from riskscore import _riskscore

STUB = ast.parse((pathlib.Path(riskscore.__file__).parent / "_riskscore.pyi").read_text())


def stub_params(node):
    names = [a.arg for a in node.args.posonlyargs + node.args.args + node.args.kwonlyargs]
    return [n for n in names if n != "self"]


def runtime_params(obj):
    return [n for n in inspect.signature(obj).parameters if n != "self"]


def defs(body):
    return {n.name: n for n in body if isinstance(n, ast.FunctionDef)}


def test_module_functions_match():
    stubbed = defs(STUB.body)
    runtime = {n for n, o in vars(_riskscore).items()
               if callable(o) and not isinstance(o, type) and not n.startswith("__")}
    assert set(stubbed) == runtime
    for name in runtime:
        assert stub_params(stubbed[name]) == runtime_params(getattr(_riskscore, name)), name


def stub_classes():
    return {n.name: n for n in STUB.body if isinstance(n, ast.ClassDef)}


def test_classes_and_their_methods_match():
    classes = stub_classes()
    assert set(classes) == {n for n, o in vars(_riskscore).items() if isinstance(o, type)}
    for name, node in classes.items():
        cls = getattr(_riskscore, name)
        stubbed = defs(node.body)
        runtime = {n for n in vars(cls) if not n.startswith("__")}
        assert set(stubbed) == runtime, name
        for method, fn in stubbed.items():
            if callable(getattr(cls, method)):
                assert stub_params(fn) == runtime_params(getattr(cls, method)), f"{name}.{method}"


@pytest.mark.parametrize("name", sorted(stub_classes()))
def test_a_class_that_cannot_be_subclassed_is_final_in_the_stub(name):
    try:
        type("Sub", (getattr(_riskscore, name),), {})
        subclassable = True
    except TypeError:
        subclassable = False
    decorators = {d.id if isinstance(d, ast.Name) else getattr(d, "attr", None)
                  for d in stub_classes()[name].decorator_list}
    assert ("final" in decorators) == (not subclassable)
