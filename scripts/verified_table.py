"""Tabulate the runs of scripts/verified_sweeps.sh (or any run folders) as Markdown rows:
the verified shape error first (a reduced model's lifted 3D error, then its own refined
one), then the run's own, their ratio, DOFs, iterations and time.

    .venv/bin/python scripts/verified_table.py results/verified_sweeps
"""

from __future__ import annotations

import json
import sys
from pathlib import Path


def row(folder: Path) -> str | None:
    path = folder / "summary.json"
    if not path.is_file():
        return None
    s = json.loads(path.read_text())
    own = s["hausdorff_final"] / s["target_size"]
    v = s.get("verified") or {}
    verified = v.get("relative")
    ratio = f"{verified / own:.2f}" if verified is not None and own > 0 else "-"
    shown = f"{100 * verified:.2f}" if verified is not None else v.get("status", "-")
    lifted = v.get("lifted") or {}
    if lifted.get("relative") is not None:
        head = f"**{100 * lifted['relative']:.2f}** (3D, {lifted['dofs']} DOFs)"
    else:
        head = lifted.get("status", "-")
    if not lifted:
        shown, head = f"**{shown}**" if verified is not None else shown, "-"
    levels = s["config"]["optimizer"]["levels"]
    checked = v.get("wall_s", 0.0) + lifted.get("wall_s", 0.0)
    return (f"| {folder.name} | {head} | {shown} | {100 * own:.2f} | {ratio} | "
            f"{s['dofs']['state']} | {v.get('dofs', '-')} | {s['iterations']} | "
            f"{list(levels)} | {s['wall_time_s'] - checked:.0f} | {checked:.0f} | "
            f"{s['status']} |")


def main() -> None:
    root = Path(sys.argv[1] if len(sys.argv) > 1 else "results/verified_sweeps")
    print("| run | lifted % | verified % | self % | verified / self | state DOFs (finest level) "
          "| verified on DOFs | iterations | levels | optimisation s | verification s | "
          "status |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---|---:|---:|---|")
    for folder in sorted(p for p in root.iterdir() if p.is_dir()):
        line = row(folder)
        if line:
            print(line)


if __name__ == "__main__":
    main()
