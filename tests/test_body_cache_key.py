"""The cache key of a reduced body follows what the code does, not how it is documented."""

from __future__ import annotations

from exudyn_study.bodies.spec import _code_without_docs


def test_docstrings_comments_and_wrapping_do_not_change_the_key():
    a = 'def f(x):\n    """Doc."""\n    return x + 1  # note\n'
    b = 'def f(x):\n    """Another doc,\n    on two lines."""\n    return (x +\n            1)\n'
    assert _code_without_docs(a) == _code_without_docs(b)


def test_a_change_of_what_the_code_does_changes_the_key():
    a = 'def f(x):\n    """Doc."""\n    return x + 1\n'
    c = 'def f(x):\n    """Doc."""\n    return x + 2\n'
    assert _code_without_docs(a) != _code_without_docs(c)


def test_a_function_that_is_only_a_docstring_keeps_a_body():
    assert "Pass" in _code_without_docs('def f():\n    """Only a docstring."""\n')
