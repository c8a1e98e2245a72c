"""The engine's house rules, read from its source (issue 13 item 5), where they hold so
far: in the solvers' modules (engine/step_nb.py, ccd.py, dls.py) no function over 80
lines and no compiled kernel over 16 parameters, and the kernels repacked around them
(adapt's chain solve, the clean-up's leg solve) within 16 too; forward kinematics
written once in numpy (engine/skeleton.py) and once compiled (engine/fk_nb.py)."""
import ast

from tests.conftest import ROOT

MAX_LINES = 80
MAX_KERNEL_PARAMS = 16
CLEAN_MODULES = ("step_nb.py", "ccd.py", "dls.py")
REPACKED = {("adapt.py", "_solve_chain"), ("cleanup.py", "_leg_frames")}
FK_HOMES = {("skeleton.py", "forward_kinematics"), ("fk_nb.py", "tree_fk"), ("fk_nb.py", "chain_fk")}


def _functions(folders=("engine",)):
    for folder in folders:
        for path in sorted((ROOT / folder).rglob("*.py")):
            for node in ast.walk(ast.parse(path.read_text())):
                if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                    yield path, node


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


def test_solver_modules_exist():
    found = {p.name for p, _ in _functions()}
    assert set(CLEAN_MODULES) <= found
    assert REPACKED <= {(p.name, fn.name) for p, fn in _functions()}


def test_no_solver_function_over_80_lines():
    long = [f"{p.name}:{fn.name} {fn.end_lineno - fn.lineno + 1}" for p, fn in _functions()
            if p.name in CLEAN_MODULES and fn.end_lineno - fn.lineno + 1 > MAX_LINES]
    assert not long, long


def test_no_solver_kernel_over_16_parameters():
    kernels = [(p.name, fn) for p, fn in _functions() if _is_kernel(fn)
               and (p.name in CLEAN_MODULES or (p.name, fn.name) in REPACKED)]
    assert len(kernels) >= 8                  # the check does see the kernels
    wide = [f"{name}:{fn.name} {_params(fn)}" for name, fn in kernels if _params(fn) > MAX_KERNEL_PARAMS]
    assert not wide, wide


def test_forward_kinematics_written_once_numpy_and_once_compiled():
    found = {(p.name, fn.name) for p, fn in _functions(("engine", "app", "tools")) if _composes_transforms(fn)}
    assert found - FK_HOMES == set(), sorted(found - FK_HOMES)
    assert ("skeleton.py", "forward_kinematics") in found      # the detector does see FK
    chain = [p.name for p, fn in _functions(("engine", "app", "tools")) if fn.name == "chain_fk"]
    assert chain == ["fk_nb.py"], chain
