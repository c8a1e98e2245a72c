"""The engine's house rules, read from its source (issue 13 item 5): in the whole engine/
package no function over 80 lines and no compiled kernel over 16 parameters; forward
kinematics written once in numpy (engine/skeleton.py) and once compiled (engine/fk_nb.py);
one Levenberg-Marquardt accept/undo loop (engine/step_nb.py: lm_loop)."""
import ast

from tests.conftest import ROOT

MAX_LINES = 80
MAX_KERNEL_PARAMS = 16
SOLVER_MODULES = ("step_nb.py", "ccd.py", "dls.py", "end_nb.py", "arms_nb.py", "frames_nb.py", "adapt.py", "cleanup.py", "cleanup_nb.py")
LM_HOME = {("step_nb.py", "lm_loop")}
FK_HOMES = {("skeleton.py", "forward_kinematics"), ("fk_nb.py", "tree_fk"), ("fk_nb.py", "chain_fk")}


def _functions(folders=("engine",)):
    """(file name, function node) of every function in the folders' Python files."""
    for folder in folders:
        for path in sorted((ROOT / folder).rglob("*.py")):
            yield from _parsed(path.name, path.read_text())


def _parsed(name, source):
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            yield name, node


def _lines(fn) -> int:
    return fn.end_lineno - fn.lineno + 1


def _long(functions) -> list[str]:
    return [f"{name}:{fn.name} {_lines(fn)} lines" for name, fn in functions if _lines(fn) > MAX_LINES]


def _wide(functions) -> list[str]:
    return [f"{name}:{fn.name} {_params(fn)} parameters" for name, fn in functions
            if _is_kernel(fn) and _params(fn) > MAX_KERNEL_PARAMS]


def _is_kernel(fn) -> bool:
    for d in fn.decorator_list:
        target = d.func if isinstance(d, ast.Call) else d
        if (target.attr if isinstance(target, ast.Attribute) else getattr(target, "id", "")) in ("njit", "jit"):
            return True
    return False


def _params(fn) -> int:
    a = fn.args
    return len(a.posonlyargs) + len(a.args) + len(a.kwonlyargs) + (a.vararg is not None) + (a.kwarg is not None)


def _composes_transforms(fn) -> bool:
    """A loop over joints (no loop inside it) that multiplies each joint's rotation onto
    its parent's (looked up in a parents array) and rotates its offset by the parent's:
    forward kinematics. (Loops over frames that call FK hold loops of their own.)"""
    for loop in ast.walk(fn):
        if not isinstance(loop, (ast.For, ast.While)):
            continue
        if any(isinstance(n, (ast.For, ast.While)) for n in ast.walk(loop) if n is not loop):
            continue
        calls = {n.func.attr if isinstance(n.func, ast.Attribute) else getattr(n.func, "id", "")
                 for n in ast.walk(loop) if isinstance(n, ast.Call)}
        names = {n.id if isinstance(n, ast.Name) else n.attr for n in ast.walk(loop)
                 if isinstance(n, (ast.Name, ast.Attribute))}
        if calls & {"mul", "qmul"} and calls & {"rotate", "qrot"} and any("parents" in n for n in names):
            return True
    return False


def _scaled_by(node, factor) -> set[str]:
    """Names the statements under ``node`` multiply by the constant ``factor``
    (``x *= f``, ``x * f``, ``f * x``)."""
    out = set()
    for n in ast.walk(node):
        if isinstance(n, ast.AugAssign) and isinstance(n.op, ast.Mult) and isinstance(n.target, ast.Name):
            if isinstance(n.value, ast.Constant) and n.value.value == factor:
                out.add(n.target.id)
        elif isinstance(n, ast.BinOp) and isinstance(n.op, ast.Mult):
            for a, b in ((n.left, n.right), (n.right, n.left)):
                if isinstance(a, ast.Name) and isinstance(b, ast.Constant) and b.value == factor:
                    out.add(a.id)
    return out


def _damps_like_lm(fn) -> bool:
    """A loop that multiplies a name by 4 (a step undone: damp harder) and the same name by
    0.5 (a step kept: damp less): a Levenberg-Marquardt accept/undo loop."""
    return any(_scaled_by(loop, 4) & _scaled_by(loop, 0.5) for loop in ast.walk(fn)
               if isinstance(loop, (ast.For, ast.While)))


def test_the_checks_see_what_they_check():
    # a made-up module: a kernel of 17 parameters and a function of 81 lines are caught,
    # one of 16 and one of 80 are not
    params = ", ".join(f"a{i}" for i in range(17))
    body = "\n".join(f"    x{i} = {i}" for i in range(79))
    source = (f"from numba import njit\n@njit(cache=True)\ndef wide({params}):\n    pass\n"
              f"@njit\ndef narrow({params[:params.rindex(',')]}):\n    pass\n"
              f"def long():\n{body}\n    return 0\n"
              f"def short():\n{body[:body.rindex(chr(10))]}\n    return 0\n")
    made_up = list(_parsed("made_up.py", source))
    assert _wide(made_up) == ["made_up.py:wide 17 parameters"]
    assert _long(made_up) == ["made_up.py:long 81 lines"]
    lm = ("def lm(mu, err):\n    for _ in range(9):\n        if err > 1:\n            mu = mu * 4\n"
          "            continue\n        mu = max(0.05, 0.5 * mu)\n")
    assert [fn.name for _, fn in _parsed("lm.py", lm) if _damps_like_lm(fn)] == ["lm"]
    assert not any(_damps_like_lm(fn) for _, fn in _parsed("lm.py", lm.replace("0.5 * mu", "0.5 * err")))
    found = list(_functions())
    assert set(SOLVER_MODULES) <= {name for name, _ in found}
    assert sum(_is_kernel(fn) for _, fn in found) >= 60        # the scan does see the engine's kernels


def test_no_engine_function_over_80_lines():
    long = _long(_functions())
    assert not long, long


def test_no_engine_kernel_over_16_parameters():
    wide = _wide(_functions())
    assert not wide, wide


def test_forward_kinematics_written_once_numpy_and_once_compiled():
    found = {(p, fn.name) for p, fn in _functions(("engine", "app", "tools")) if _composes_transforms(fn)}
    assert found - FK_HOMES == set(), sorted(found - FK_HOMES)
    assert ("skeleton.py", "forward_kinematics") in found      # the detector does see FK
    chain = [p for p, fn in _functions(("engine", "app", "tools")) if fn.name == "chain_fk"]
    assert chain == ["fk_nb.py"], chain


def test_one_levenberg_marquardt_loop():
    found = {(p, fn.name) for p, fn in _functions() if _damps_like_lm(fn)}
    assert found == LM_HOME, sorted(found)
