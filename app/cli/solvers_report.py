"""``hitpoint analyse --solvers``: ccd, dls, learnt and learnt+ccd side by side over a
grid of offsets (engine.solver_compare), as a table or JSON."""
from __future__ import annotations

import math

UNITS = {"bat_error_cm": "bat cm", "grip_error_cm": "grip cm", "limit_hits": "limit hits",
         "us_per_frame": "us/frame", "style_rmse": "style", "face_angle_deg": "face deg"}


def clean(value):
    """The report with every float rounded and a NaN (no face on this rig) as None."""
    if isinstance(value, dict):
        return {k: clean(v) for k, v in value.items()}
    if isinstance(value, list):
        return [clean(v) for v in value]
    if isinstance(value, float):
        return None if not math.isfinite(value) else round(value, 4)
    return value


def solvers_report(rig, shots, distances, falloff: float, wrist_dof: int, leave_out: bool) -> dict:
    from engine.adapt import AdaptSettings
    from engine.solver_compare import compare  # numba: when the command runs
    return clean(compare(rig, shots, distances, settings=AdaptSettings(falloff=falloff, wrist_dof=wrist_dof),
                         leave_out=leave_out))


def _cells(figures: dict, metrics) -> str:
    return "".join(f"{'-' if figures[m] is None else format(figures[m], '.3f' if m != 'limit_hits' else '.1f'):>12}"
                   for m in metrics)


def print_solvers(report: dict) -> None:
    metrics = report["metrics"]
    head = f"{'shot':<20}{'solver':<12}" + "".join(f"{UNITS[m]:>12}" for m in metrics)
    n = len(report["offsets_cm"])
    print(f"medians over {n} offsets (cm along +-x, +-y, +-z); learnt model "
          f"{'without the shot itself' if report['leave_out'] else 'trained on every shot'}")
    print(head)
    for row in report["shots"]:
        for s in report["solvers"]:
            print(f"{row['name']:<20}{s:<12}" + _cells(row["solvers"][s], metrics))
    print(f"{'median over shots':<20}")
    for s in report["solvers"]:
        print(f"{'':<20}{s:<12}" + _cells(report["overall"][s], metrics))
