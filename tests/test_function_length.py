"""No function in src/adaptid has a body of more than 80 lines of code (issue 13, point 9),
and no module more than 600 lines (issue 31, point 4).

A line of code is a physical line of the function's body that carries a
Python token other than a comment: blank lines, comment-only lines and the
lines of docstrings (the function's own and those of functions and classes
nested in it) do not count; each line of a statement that spans several
lines does. The decorators and the signature are not part of the body. A
nested function counts towards the function that contains it (a closure
is part of its body) and is checked on its own as well.

A module's length is its number of physical lines (``wc -l``): a module
past 600 lines is split by what its parts do (data go to data files).

The counter itself is checked against hand-counted sources
(``test_counter_on_hand_counted_source``), so that the limit cannot pass
because the counter counts nothing.
"""

import ast
import io
import tokenize
from pathlib import Path

import pytest

MAX_LINES = 80
ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src" / "adaptid"

#: Files exempt from the limit: none (issue 13 split the last long functions).
ALLOWED: set = set()

MAX_MODULE_LINES = 600
#: Modules exempt from the module limit: none.
LONG_MODULES: set = set()

_NOT_CODE = {tokenize.COMMENT, tokenize.NL, tokenize.NEWLINE, tokenize.INDENT,
             tokenize.DEDENT, tokenize.ENCODING, tokenize.ENDMARKER}
_DEFS = (ast.FunctionDef, ast.AsyncFunctionDef)


def _docstring_lines(tree):
    """Line numbers of every docstring (module, classes, functions) in the tree."""
    lines = set()
    for node in ast.walk(tree):
        if isinstance(node, (*_DEFS, ast.ClassDef, ast.Module)) and node.body:
            first = node.body[0]
            if (isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant)
                    and isinstance(first.value.value, str)):
                lines.update(range(first.lineno, first.end_lineno + 1))
    return lines


def function_lengths(source):
    """``(name, line, lines of code in the body)`` of every function in ``source``."""
    tree = ast.parse(source)
    code = set()
    for tok in tokenize.generate_tokens(io.StringIO(source).readline):
        if tok.type not in _NOT_CODE:
            code.update(range(tok.start[0], tok.end[0] + 1))
    code -= _docstring_lines(tree)
    out = []
    for node in ast.walk(tree):
        if isinstance(node, _DEFS):
            body = range(node.body[0].lineno, node.end_lineno + 1)
            out.append((node.name, node.lineno, sum(1 for k in body if k in code)))
    return sorted(out, key=lambda item: item[1])


def _sources():
    return sorted(SRC.rglob("*.py"))


def _long_functions():
    """``{relative path: [(name, line, length), ...]}`` of functions over the limit."""
    found = {}
    for path in _sources():
        rel = path.relative_to(ROOT).as_posix()
        long = [f for f in function_lengths(path.read_text(encoding="utf-8"))
                if f[2] > MAX_LINES]
        if long:
            found[rel] = long
    return found


# ------------------------------------------------------------- the counter

_HAND_COUNTED = '''\
import os


@decorator(
    option=1,
)
def outer(a,
          b):
    """Docstring: two lines,

    not code."""
    # a comment line

    x = (a +      # 1 (and a trailing comment)
         b)       # 2
    s = """a string
    that is code"""   # 3, 4

    def inner():  # 5
        """Inner docstring."""
        return x  # 6

    class K:      # 7
        """Class docstring."""
        y = 1     # 8
    return inner, K, s  # 9


async def coro():
    await os.sleep(0)


def one_liner(): return 1
'''


def test_counter_on_hand_counted_source():
    # expected counts: the numbered lines of _HAND_COUNTED, counted by hand
    got = {name: n for name, _, n in function_lengths(_HAND_COUNTED)}
    assert got == {"outer": 9, "inner": 1, "coro": 1, "one_liner": 1}


def test_counter_flags_a_long_function():
    body = "".join(f"    x{k} = {k}\n" for k in range(MAX_LINES + 1))
    src = f'def f():\n    """Doc."""\n    # comment\n\n{body}'
    assert function_lengths(src) == [("f", 1, MAX_LINES + 1)]


# ----------------------------------------------------------------- the rule

def test_sources_found():
    # guards against a wrong ROOT: the package has well over 50 modules
    assert len(_sources()) > 50
    assert (SRC / "__init__.py").exists()


def test_no_function_over_the_limit():
    offenders = {path: funcs for path, funcs in _long_functions().items()
                 if path not in ALLOWED}
    report = "\n".join(f"  {path}:{line} {name}: {n} lines of code"
                       for path, funcs in sorted(offenders.items())
                       for name, line, n in funcs)
    assert not offenders, (
        f"functions with more than {MAX_LINES} lines of code (split them into named "
        f"steps; blank, comment and docstring lines do not count):\n{report}")


def test_allow_list_is_empty():
    """Issue 13, point 9: every long function has been split; the list stays empty
    (a function over the limit is split, not allowed)."""
    assert ALLOWED == set()


def _module_lengths():
    """``{relative path: physical lines}`` of every module of src/adaptid."""
    return {path.relative_to(ROOT).as_posix(): len(path.read_text(encoding="utf-8").splitlines())
            for path in _sources()}


def test_no_module_over_the_limit():
    lengths = _module_lengths()
    offenders = {path: n for path, n in lengths.items()
                 if n > MAX_MODULE_LINES and path not in LONG_MODULES}
    report = "\n".join(f"  {path}: {n} lines" for path, n in sorted(offenders.items()))
    assert not offenders, (
        f"modules with more than {MAX_MODULE_LINES} lines (split them by what their parts "
        f"do, numbers into data files):\n{report}")


def test_long_module_exceptions_are_still_needed():
    # an exception whose module is gone or back under the limit is removed from the list
    lengths = _module_lengths()
    stale = sorted(p for p in LONG_MODULES if lengths.get(p, 0) <= MAX_MODULE_LINES)
    assert not stale, f"remove from LONG_MODULES (no longer over {MAX_MODULE_LINES} lines): {stale}"
