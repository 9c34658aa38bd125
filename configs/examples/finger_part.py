"""Writes finger.step: a pneumatic finger's body, the CAD part of configs/examples/finger.yaml.

    .venv/bin/python configs/examples/finger_part.py

A bar 4 long (X1 from 0), 1 wide (X2) and 1 high (X3), centred on the X1 axis, with a
chamber 3.5 long and 0.6 x 0.6 in section that opens at X1 = 0, where air comes in and the
finger is held. gmsh's OpenCASCADE kernel makes it and writes it as STEP, as a CAD program
would export it.
"""

from pathlib import Path

import gmsh

HERE = Path(__file__).resolve().parent


def main() -> None:
    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("finger")
        occ = gmsh.model.occ
        bar = occ.addBox(0.0, -0.5, -0.5, 4.0, 1.0, 1.0)
        chamber = occ.addBox(0.0, -0.3, -0.3, 3.5, 0.6, 0.6)
        occ.cut([(3, bar)], [(3, chamber)])
        occ.synchronize()
        gmsh.write(str(HERE / "finger.step"))
    finally:
        gmsh.finalize()


if __name__ == "__main__":
    main()
