"""Reading and repairing a scan of 10^6 triangles (not a test: it prints what it measures).

    .venv/bin/python benchmarks/surface_repair.py [--triangles 1000000] [--out DIR]

Writes an open wavy sheet of about ``--triangles`` triangles as a binary STL in millimetres
(its vertices repeated at every triangle, as an STL gives them), with defects a scan
carries: a tenth of the triangles turned inside out, 100 triangles given twice, 100 without
area, 50 stray pieces and one flap on an inner edge (a non-manifold edge); then times
reading it (trimesh) and the repair (shape/surface_repair.py), each in a fresh process,
and prints the seconds and the peak memory (resident set) of each, against the file's size.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

STEP = """
import json, resource, sys, time
from pathlib import Path
from shapegrowth.shape.surface_formats import read_triangles
from shapegrowth.shape.surface_repair import repaired
path, repair = Path(sys.argv[1]), sys.argv[2] == "repair"
base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
t0 = time.perf_counter()
points, triangles = read_triangles(path)
t1 = time.perf_counter()
line = ""
if repair:
    surface, done = repaired(points, triangles)
    line = done.line()
t2 = time.perf_counter()
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(json.dumps({"read_s": t1 - t0, "repair_s": t2 - t1, "rss_mb": peak / 1024,
                  "rss_before_mb": base / 1024, "line": line}))
"""


def sheet(n_target: int) -> tuple[np.ndarray, np.ndarray]:
    """A wavy sheet of about n_target triangles, with the defects of the module's text."""
    from shapegrowth.shape.surface_formats import TriangleSurface

    k = int(np.sqrt(n_target / 2))
    x, y = np.meshgrid(np.linspace(0, 300, k + 1), np.linspace(0, 300, k + 1), indexing="ij")
    z = 10 * np.sin(x.ravel() / 30) * np.cos(y.ravel() / 40)
    p = np.column_stack([x.ravel(), y.ravel(), z])
    c = ((k + 1) * np.arange(k)[:, None] + np.arange(k)[None]).ravel()
    t = np.concatenate([np.column_stack([c, c + k + 1, c + k + 2]),
                        np.column_stack([c, c + k + 2, c + 1])])
    rng = np.random.default_rng(0)
    turn = rng.random(len(t)) < 0.1
    t = np.where(turn[:, None], t[:, ::-1], t)
    extra = [t[rng.integers(0, len(t), 100)][:, ::-1]]  # given twice
    a = t[rng.integers(0, len(t), 100)]
    extra.append(np.column_stack([a[:, 0], a[:, 1], a[:, 0]]))  # without area
    stray = [p]
    for s in range(50):  # small pieces far off
        base = len(np.vstack(stray))
        x0 = 400.0 + 3 * s
        stray.append(np.array([[x0, 0, 0], [x0 + 1, 0, 0], [x0, 1, 0]]))
        extra.append(np.array([[base, base + 1, base + 2]]))
    p = np.vstack(stray)
    inner = t[len(t) // 3]
    p = np.vstack([p, p[inner[:2]].mean(axis=0) + [0, 0, 5.0]])
    extra.append(np.array([[inner[0], inner[1], len(p) - 1]]))  # a flap: non-manifold edge
    return TriangleSurface(p, np.vstack([t, *extra])).points, np.vstack([t, *extra])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--triangles", type=int, default=1_000_000)
    parser.add_argument("--out", type=Path, default=None)
    args = parser.parse_args()
    from shapegrowth.shape.surface_formats import write_stl

    with tempfile.TemporaryDirectory() as tmp:
        path = (args.out or Path(tmp)) / "scan_mm.stl"
        points, triangles = sheet(args.triangles)
        write_stl(path, points, triangles)
        runs = {}
        for step in ("read", "repair"):
            done = subprocess.run([sys.executable, "-c", STEP, str(path), step],
                                  capture_output=True, text=True, check=True)
            runs[step] = json.loads(done.stdout.strip().splitlines()[-1])
        size = path.stat().st_size / 2**20
    print(f"{len(triangles)} triangles, binary STL {size:.0f} MiB")
    print(f"read (trimesh):  {runs['read']['read_s']:.2f} s, peak RSS "
          f"{runs['read']['rss_mb']:.0f} MB")
    both = runs["repair"]
    print(f"read + repair:   {both['read_s'] + both['repair_s']:.2f} s "
          f"(repair {both['repair_s']:.2f} s), peak RSS {both['rss_mb']:.0f} MB "
          f"(the interpreter with numpy and trimesh {runs['repair']['rss_before_mb']:.0f} MB)")
    print(f"the repair's line: {runs['repair']['line']}")


if __name__ == "__main__":
    main()
