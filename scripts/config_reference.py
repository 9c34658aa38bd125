"""Write docs/CONFIG.md, the config reference, from the schema in shapegrowth/config/
(sections.py and numerics.py).

    .venv/bin/python scripts/config_reference.py        (tests/test_config.py checks it)
"""

from __future__ import annotations

from pathlib import Path

from shapegrowth.config import reference_text

if __name__ == "__main__":
    path = Path(__file__).resolve().parent.parent / "docs" / "CONFIG.md"
    path.parent.mkdir(exist_ok=True)
    path.write_text(reference_text())
    print(f"wrote {path}")
