"""Architecture rules: engine/ stays free of the app and of GL/window libraries."""
import ast

from tests.conftest import ROOT

FORBIDDEN = {"app", "glfw", "moderngl", "imgui_bundle", "OpenGL", "imgui"}


def test_engine_never_imports_app_or_gl():
    for path in (ROOT / "engine").rglob("*.py"):
        tree = ast.parse(path.read_text())
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                mods = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0:
                mods = [node.module or ""]
            else:
                continue
            for m in mods:
                assert m.split(".")[0] not in FORBIDDEN, f"{path.name} imports {m}"


def test_rig_data_is_consistent(rig):
    s = rig.skeleton
    assert s.num_joints == 27 and rig.animated_joints == 26
    assert all(s.parents[i] < i for i in range(1, s.num_joints))
    assert s.names[rig.bat_joint] == "Bat" and s.names[s.parents[rig.bat_joint]] == "LeftHand"
    assert (rig.limits[..., 0] <= rig.limits[..., 1]).all()
    left = [s.names[j] for j in rig.chains["left_arm"].joints]
    assert left[0] == "Spine" and left[-1] == "LeftHand" and "Hips" not in left
    assert rig.dof_mask(0)[rig.wrist].sum() == 0 and rig.dof_mask(2)[rig.wrist].sum() == 2
    assert abs(rig.ball_radius - 3.6) < 1e-9
