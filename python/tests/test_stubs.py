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


def accepts(hint, value):
    """Whether `value` matches the type `hint` as a type checker reads it (float takes int, not
    bool; a generic such as np.floating[Any] by its class). Enough for the threshold hints."""
    import typing

    origin = typing.get_origin(hint)
    if origin is typing.Union:
        return any(accepts(arg, value) for arg in typing.get_args(hint))
    if hint is None or hint is type(None):
        return value is None
    if origin is not None:
        hint = origin
    if hint is float:
        return isinstance(value, (float, int)) and not isinstance(value, bool)
    return isinstance(hint, type) and isinstance(value, hint)


def stub_annotation(function, parameter):
    """The stub's annotation of `parameter` of `function`, evaluated as a type checker reads it."""
    import typing

    import numpy as np
    import pyarrow as pa

    node = defs(STUB.body)[function]
    arg = next(a for a in node.args.args if a.arg == parameter)
    names = {**vars(typing), "np": np, "pa": pa}
    for statement in STUB.body:  # the stub's own aliases (_Threshold, ...)
        if isinstance(statement, ast.Assign) and isinstance(statement.targets[0], ast.Name):
            names[statement.targets[0].id] = eval(ast.unparse(statement.value), names)
    return eval(ast.unparse(arg.annotation), names)


def test_a_numpy_float32_threshold_is_a_threshold_to_type_checkers():
    """riskscore.evaluate(thresholds=np.float32(2.5)) works; its hints (and the stub's) said
    float, which np.float32 is not, so a type checker refused it. A bool stays refused."""
    import typing

    import numpy as np

    public = typing.get_type_hints(riskscore.evaluate)["thresholds"]
    threshold = typing.get_type_hints(riskscore._choice)["value"]
    stub_all = stub_annotation("evaluate", "threshold_all")
    stub_by_name = typing.get_args(stub_annotation("evaluate", "thresholds_by_name"))[1]
    for hint in (public, threshold, stub_all, stub_by_name):
        for value in (np.float32(2.5), np.float64(2.5), np.int64(2), 2.5, 2, "default"):
            assert accepts(hint, value), (hint, value)
        assert not accepts(hint, np.bool_(True)), hint
