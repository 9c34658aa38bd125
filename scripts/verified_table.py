"""Tabulate the runs of scripts/verified_sweeps.sh (or any run folders) as Markdown rows:
the verified shape error first (a reduced model's lifted 3D error, then its own refined
one), then the run's own, their ratio, DOFs, iterations and time.

    .venv/bin/python scripts/verified_table.py results/verified_sweeps
"""

from __future__ import annotations

import sys
from pathlib import Path

from shapegrowth.commands.launch import read_summary


def row(folder: Path) -> str | None:
    s = read_summary(folder)
    if s is None:
        return None
    own = s.relative_error or 0.0
    v = s.verified
    verified = v.relative if v is not None else None
    ratio = f"{verified / own:.2f}" if verified is not None and own > 0 else "-"
    shown = f"{100 * verified:.2f}" if verified is not None else (v.status if v else "-")
    lifted = v.lifted if v is not None else None
    if lifted is not None and lifted.relative is not None:
        head = f"**{100 * lifted.relative:.2f}** (3D, {lifted.dofs} DOFs)"
    else:
        head = lifted.status if lifted is not None else "-"
    if lifted is None:
        shown, head = f"**{shown}**" if verified is not None else shown, "-"
    levels = s.config["optimizer"]["levels"]
    checked = v.check_wall_s if v else 0.0
    return (f"| {folder.name} | {head} | {shown} | {100 * own:.2f} | {ratio} | "
            f"{s.dofs.state} | {v.dofs if v else '-'} | {s.iterations} | "
            f"{list(levels)} | {s.wall_time_s - checked:.0f} | {checked:.0f} | "
            f"{s.status} |")


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
