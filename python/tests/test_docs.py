"""The examples in the docstrings run and print what they say; the type stubs name every public function."""
import ast
import doctest
from pathlib import Path

import numpy as np

import gregvox


def test_the_docstring_examples_hold():
    result = doctest.testmod(gregvox, extraglobs={"gregvox": gregvox, "np": np}, optionflags=doctest.ELLIPSIS)
    assert result.attempted >= 8
    assert result.failed == 0


def test_the_stubs_cover_the_public_api():
    stub = Path(gregvox.__file__).with_name("__init__.pyi")
    assert (stub.parent / "py.typed").exists()
    names = {
        n.name
        for n in ast.parse(stub.read_text()).body
        if isinstance(n, (ast.FunctionDef, ast.ClassDef))
    }
    assert set(gregvox.__all__) <= names
