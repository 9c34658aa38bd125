"""The second and third platforms' legs (`make test-debian13`, `make test-dolfinx011`) say why
where they cannot run, and the compat module is the only place that asks for dolfinx's
version."""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = ROOT / "scripts" / "debian13.sh"


def _run(command: list[str], env: dict[str, str]) -> subprocess.CompletedProcess:
    return subprocess.run(command, env=env, capture_output=True, text=True, timeout=60)


def _without_debootstrap(script: Path, tmp_path: Path) -> subprocess.CompletedProcess:
    """``script`` run with a PATH of the shell's tools but neither debootstrap nor apt-get,
    and no cached Debian 13 root."""
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    for tool in ("bash", "id", "dirname", "chroot"):
        found = shutil.which(tool)
        assert found, tool
        (bin_dir / tool).symlink_to(found)
    env = {"PATH": str(bin_dir), "HOME": str(tmp_path),
           "SHAPEGROWTH_DEBIAN13_ROOT": str(tmp_path / "no-root-here")}
    return _run([str(bin_dir / "bash"), str(script)], env)


@pytest.mark.skipif(os.geteuid() != 0 or shutil.which("setpriv") is None,
                    reason="needs root and setpriv to run the script as another user")
def test_the_debian13_leg_skips_with_one_line_when_not_root():
    # a copy readable by the other user (a checkout may sit in a private folder)
    import tempfile

    place = Path(tempfile.mkdtemp())
    try:
        place.chmod(0o755)
        (place / "scripts").mkdir(mode=0o755)
        script = place / "scripts" / "debian13.sh"
        shutil.copyfile(SCRIPT, script)
        script.chmod(0o755)
        result = _run(["setpriv", "--reuid=65534", "--regid=65534", "--clear-groups", "bash",
                       str(script)], {"PATH": os.environ["PATH"], "HOME": "/nonexistent"})
    finally:
        shutil.rmtree(place)
    assert result.returncode == 0
    assert result.stdout.strip() == ("test-debian13: skipped: needs root (debootstrap, chroot "
                                     "and mount); run it as root")


@pytest.mark.skipif(os.geteuid() != 0, reason="the check after the root check")
def test_the_debian13_leg_skips_with_one_line_without_debootstrap(tmp_path):
    """A PATH with the shell's tools but neither debootstrap nor apt-get, and no cached root."""
    result = _without_debootstrap(SCRIPT, tmp_path)
    assert result.returncode == 0
    assert result.stdout.strip() == ("test-debian13: skipped: no debootstrap, and no apt-get "
                                     "to install it")
    assert not (tmp_path / "no-root-here").exists()


def test_only_compat_asks_for_the_dolfinx_version():
    """Every version difference lives in compat.py: no other module reads the version."""
    readers = [p.relative_to(ROOT).as_posix() for p in (ROOT / "shapegrowth").rglob("*.py")
               if p.name != "compat.py"
               and any(word in p.read_text() for word in ("dolfinx.__version__", "AT_LEAST_"))]
    assert readers == []


@pytest.mark.skipif(os.geteuid() != 0, reason="the check after the root check")
def test_the_dolfinx011_leg_skips_with_one_line_without_a_debian13_root(tmp_path):
    """The third platform's leg lives in the second's root: where that cannot be built (no
    debootstrap here), the leg says so after the second's own line, and succeeds."""
    result = _without_debootstrap(ROOT / "scripts" / "dolfinx011.sh", tmp_path)
    assert result.returncode == 0
    assert result.stdout.strip().splitlines()[-1] == (
        "test-dolfinx011: skipped: no Debian 13 root (make test-debian13 says why)")
    assert not (tmp_path / "no-root-here").exists()
