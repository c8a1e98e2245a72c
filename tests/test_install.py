"""The install is what the README says: CI runs the README's test command, every
third-party module the code imports is declared, and the lock pins them."""
import ast
import re
import sys
import tomllib
from importlib import metadata
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
BENCH_FILES = ("app/cli/bench.py",)     # `hitpoint bench` compares against ikpy (the bench extra)


def _files(*folders, exclude=()):
    return [p for f in folders for p in (ROOT / f).rglob("*.py")
            if str(p.relative_to(ROOT)) not in exclude]


def _readme_commands() -> list[str]:
    text = (ROOT / "README.md").read_text()
    return [m.strip() for m in re.findall(r"```bash\n(.*?)```", text, re.S)]


def _requirement_names(reqs: list[str]) -> set[str]:
    return {re.split(r"[<>=!~\[; ]", r, maxsplit=1)[0].lower().replace("_", "-") for r in reqs}


def _imported_distributions(files) -> set[str]:
    """Distributions (normalised names) providing the top-level modules imported
    anywhere in ``files``, the standard library and our own packages left out."""
    own = {"app", "engine", "tools", "tests"}
    modules = set()
    for path in files:
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                modules |= {a.name.split(".")[0] for a in node.names}
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                modules.add(node.module.split(".")[0])
    modules -= own | set(sys.stdlib_module_names)
    providers = metadata.packages_distributions()
    return {d.lower().replace("_", "-") for m in modules for d in providers.get(m, [m])}


def _pyproject() -> dict:
    return tomllib.loads((ROOT / "pyproject.toml").read_text())


def test_ci_runs_the_readme_test_command_verbatim():
    commands = _readme_commands()
    assert len(commands) == 2, "the README has exactly two set-up commands"
    test_cmd = next(c for c in commands if "pytest" in c)
    assert test_cmd in (ROOT / ".ci" / "run").read_text()


def test_readme_commands_install_from_the_lock():
    for cmd in _readme_commands():
        assert "-c constraints.txt" in cmd, cmd
    viewer = next(c for c in _readme_commands() if "pytest" not in c)
    assert "[" not in viewer, "the viewer command installs no extras: a plain install must run it"


def test_every_runtime_import_is_a_declared_dependency():
    project = _pyproject()["project"]
    declared = _requirement_names(project["dependencies"])
    missing = _imported_distributions(_files("app", "engine", exclude=BENCH_FILES)) - declared
    assert not missing, f"imported by app/ or engine/ but not in dependencies: {sorted(missing)}"
    extras = project["optional-dependencies"]
    missing = _imported_distributions(_files(*BENCH_FILES)) - declared - _requirement_names(extras["bench"])
    assert not missing, f"imported by the bench but not declared: {sorted(missing)}"
    missing = _imported_distributions(_files("tools")) - declared - _requirement_names(extras["assets"])
    assert not missing, f"imported by tools/ but not declared: {sorted(missing)}"


def test_every_dependency_has_bounds_and_a_pinned_version():
    project = _pyproject()["project"]
    reqs = project["dependencies"] + [r for extra in project["optional-dependencies"].values()
                                      for r in extra if not r.startswith("hitpoint")]
    lock = (ROOT / "constraints.txt").read_text().lower().replace("_", "-")
    pinned = dict(re.findall(r"^([a-z0-9.\-]+)==(\S+)$", lock, re.M))
    for req in reqs:
        assert ">=" in req and "<" in req, f"{req}: needs a lower and an upper bound"
        (name,) = _requirement_names([req])
        assert name in pinned, f"{name} is not pinned in constraints.txt"


def test_every_folder_of_code_and_data_is_installed():
    from setuptools import find_namespace_packages
    find = _pyproject()["tool"]["setuptools"]["packages"]["find"]
    installed = set(find_namespace_packages(str(ROOT), include=find["include"]))
    for folder in ("app", "engine", "tools"):
        for init in (ROOT / folder).rglob("__init__.py"):
            assert ".".join(init.parent.relative_to(ROOT).parts) in installed, init
    assert {"assets", "assets.shots", "shaders"} <= installed
    data = _pyproject()["tool"]["setuptools"]["package-data"]
    suffixes = {p.suffix for p in (ROOT / "shaders").iterdir()} | {p.suffix for p in (ROOT / "assets").rglob("*.*")}
    patterns = {pat[1:] for pats in data.values() for pat in pats}
    assert suffixes <= patterns, f"data files not installed: {suffixes - patterns}"


def test_app_folders_show_the_architecture():
    """app/ is folders by role; at most 6 loose modules beside them."""
    loose = [p.name for p in (ROOT / "app").glob("*.py") if p.name != "__init__.py"]
    assert len(loose) <= 6, loose
