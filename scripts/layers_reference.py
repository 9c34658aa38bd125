"""Write docs/LAYERS.md, the map of the package's layers and modules, from the package itself:
each module's row is the first sentence of its docstring (read with ``ast``, nothing
imported), beside the paper's equations it implements.

    .venv/bin/python scripts/layers_reference.py        (tests/test_docs.py checks it)
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = ROOT / "shapegrowth"

# top to bottom: each layer imports only those below it (tests/test_architecture.py)
LAYERS = (
    ("commands", "the command line and its commands: exit statuses, run folders, console"),
    ("optim", "the reduced functional J(m), dJ/dm, the optimiser's driver and its "
              "callbacks (exact resume), the verification"),
    ("io", "what a run writes and reads back: summary.json and its records, fields, figures"),
    ("shape", "bodies as point clouds, targets, the smooth Hausdorff distance and its kernels"),
    ("physics", "geometry and meshes, material, growth, filters, the state and its solvers"),
    ("config", "the typed schema, validation (ConfigError), safe expressions"),
    ("", "the base: dolfinx-version differences, errors, logging, timing"),
)

# the paper's equations, by module (the rest implement none directly)
PAPER = {
    "physics/material.py": "(5.1), (2.5)",
    "physics/kinematics.py": "(5.1)",
    "physics/closed_forms.py": "(5.5), (5.9), (5.13)",
    "physics/growth.py": "(5.2)-(5.5)",
    "physics/eigenframes.py": "(5.3)-(5.4)",
    "physics/boundary.py": "(2.8)",
    "physics/state.py": "(2.8), (5.10)-(5.12)",
    "physics/filters.py": "(5.7)",
    "physics/builders.py": "Figs. 2, 6, 9",
    "shape/hausdorff.py": "(2.9)",
    "shape/kernels.py": "(2.9)",
    "shape/pairs.py": "(2.9)",
    "shape/divergence.py": "(2.9)",
    "shape/targets.py": "(5.14)-(5.16)",
    "optim/complexity.py": "(2.14)-(2.15), Sect. 2.4",
    "optim/objective.py": "(5.6)",
    "optim/adjoint.py": "(5.8)-(5.13)",
    "optim/problem.py": "(5.6)",
    "optim/driver.py": "Sect. 5.1.4",
}

INTRO = """\
# The package, layer by layer

Generated from the package by `scripts/layers_reference.py` (a test fails when this file and
the package differ): each module with the first sentence of its docstring. Each layer
imports only the layers below it (`tests/test_architecture.py` checks every import, and
that none is circular).

One way through, each arrow a module; the gradient reads the chain rule backwards:

```
config --> physics/geometry --> physics/growth --> physics/state --> shape/clouds
 (YAML)      (gmsh mesh)          C_g (5.2)          R(u) = 0         Phi(X_q), J w_q
                                    ^ physics/filters (5.7)               |
                                    |                                     v
optim/driver <-- optim/problem <-- optim/objective J (5.6) <-- shape/hausdorff rho_H (2.9)
 (NLopt)          m -> filter -> solve -> J;  dJ/dm <- filter^T <- optim/adjoint (5.12)
 callbacks: optim/checkpoint, retry from rest, progress
```
"""


def summary_line(path: Path) -> str:
    """The first sentence of a module's docstring, on one line."""
    doc = ast.get_docstring(ast.parse(path.read_text())) or ""
    text = " ".join(doc.split()).replace("``", "`")
    match = re.match(r"(.+?(?<!Sect)(?<!Fig)(?<!e\.g)(?<!i\.e)\.)(\s|$)", text)
    return (match.group(1) if match else text).replace("|", "\\|")


def layers_markdown() -> str:
    lines = [INTRO]
    for layer, holds in LAYERS:
        folder = PACKAGE / layer if layer else PACKAGE
        paths = sorted(p for p in folder.glob("*.py") if p.name != "__init__.py")
        title = f"`{layer}/`" if layer else "`shapegrowth/` itself"
        lines += [f"## {title}: {holds}", "", "| module | holds | paper |", "|---|---|---|"]
        for path in paths:
            name = str(path.relative_to(PACKAGE))
            lines.append(f"| `{name}` | {summary_line(path)} | {PAPER.get(name, '-')} |")
        lines.append("")
    return "\n".join(lines).rstrip() + "\n"


if __name__ == "__main__":
    target = ROOT / "docs" / "LAYERS.md"
    target.write_text(layers_markdown())
    print(f"wrote {target}")
