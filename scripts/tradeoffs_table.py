"""Markdown tables of the sweeps made by scripts/tradeoff_sweeps.sh (for docs/MODELS.md).

    .venv/bin/python scripts/tradeoffs_table.py [results/tradeoffs]
"""

from __future__ import annotations

import csv
import sys
from pathlib import Path


def main(root: Path) -> None:
    for scene in sorted(p for p in root.iterdir() if p.is_dir()):
        print(f"\n### {scene.name}\n")
        for sweep in sorted(p for p in scene.iterdir() if (p / "study.csv").exists()):
            rows = list(csv.DictReader(open(sweep / "study.csv")))
            key = next(iter(rows[0]))
            print(f"`{key}` | DOFs | design | iterations | time s | self % | reference % | "
                  "peak MB | status")
            print("---|---:|---:|---:|---:|---:|---:|---:|---")
            for r in rows:
                size = float(r["target_size"])

                def pct(name: str) -> str:
                    return f"{100 * float(r[name]) / size:.2f}" if r[name] not in ("", "None") \
                        else "-"
                print(f"{r[key]} | {r['dofs_state']} | {r['dofs_design']} | {r['iterations']} | "
                      f"{float(r['wall_time_s']):.1f} | {pct('hausdorff_final')} | "
                      f"{pct('hausdorff_reference')} | {float(r['peak_memory_mb']):.0f} | "
                      f"{r['status']}")
            print()


if __name__ == "__main__":
    main(Path(sys.argv[1] if len(sys.argv) > 1 else "results/tradeoffs"))
