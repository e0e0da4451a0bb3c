"""servoc as users install it: the wheel `pip` builds from this tree, in a fresh virtual
environment, runs every command (not the checkout: the tests run from elsewhere)."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import sysconfig
import tomllib
import venv
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


def test_every_package_of_the_tree_is_in_the_wheel_list():
    listed = set(tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"])
    found = {"servoc" + ("." + ".".join(p.parent.relative_to(ROOT / "servoc").parts) if p.parent != ROOT / "servoc"
                         else "") for p in (ROOT / "servoc").rglob("__init__.py")}
    assert found - listed == set(), f"packages missing from pyproject.toml: {sorted(found - listed)}"


@pytest.fixture(scope="module")
def installed(tmp_path_factory) -> Path:
    """A fresh venv with the wheel of this tree (its dependencies from the test run's own
    environment, read through a path entry: no network, no editable install)."""
    tmp = tmp_path_factory.mktemp("wheel")
    build = tmp / "build"
    shutil.copytree(ROOT, build, ignore=shutil.ignore_patterns(".venv", ".git", "*.egg-info", "build", "__pycache__",
                                                                ".hypothesis", ".pytest_cache"))
    dist = tmp / "dist"
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q", "-w", str(dist),
                    str(build)], check=True, cwd=tmp, stdin=subprocess.DEVNULL)
    (wheel,) = dist.glob("servoc-*.whl")
    env_dir = tmp / "env"
    venv.EnvBuilder(with_pip=False).create(env_dir)
    py = env_dir / "bin" / "python"
    site = subprocess.run([str(py), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                          check=True, capture_output=True, text=True).stdout.strip()
    subprocess.run([sys.executable, "-m", "pip", "install", "--no-deps", "-q", "--target", site, str(wheel)],
                   check=True, stdin=subprocess.DEVNULL)
    # the dependencies (lark, jinja2, intelhex, ...) from this environment, after the wheel's servoc
    Path(site, "zz_deps.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    return env_dir


def servoc(env_dir: Path, cwd: Path, *args: str) -> subprocess.CompletedProcess:
    py = env_dir / "bin" / "python"
    return subprocess.run([str(py), "-m", "servoc", *args], cwd=cwd, capture_output=True, text=True,
                          stdin=subprocess.DEVNULL, env={**os.environ, "PYTHONPATH": "", "NO_COLOR": "1"})


@pytest.mark.toolchain
def test_the_wheel_runs_every_command(installed, tmp_path):
    py = installed / "bin" / "python"
    origin = subprocess.run([str(py), "-c", "import servoc, servoc.imports; print(servoc.__file__)"],
                            cwd=tmp_path, capture_output=True, text=True, check=True).stdout
    assert str(ROOT) not in origin and str(installed) in origin, origin
    for name in ("biped.servo", "serial_arm.servo", "ssc32_arm.servo", "hexapod.servo"):
        shutil.copy(ROOT / "examples" / name, tmp_path / name)
    for name in ("serial_arm.events", "ssc32_arm.events"):
        shutil.copy(ROOT / "examples" / "events" / name, tmp_path / name)
    shutil.copy(ROOT / "examples" / "import" / "wave.xml", tmp_path / "wave.xml")
    runs = [("lint", "biped.servo"), ("plan", "biped.servo"), ("compile", "biped.servo", "-o", "b.hex"),
            ("verify", "biped.servo", "--frames", "60"),
            ("verify", "serial_arm.servo", "--events", "serial_arm.events"),
            ("verify", "ssc32_arm.servo", "--events", "ssc32_arm.events"),
            ("import", "wave.xml", "-o", "wave.servo"), ("init", "fresh"), ("--help",),
            ("sim", "serial_arm.servo", "--seconds", "0.5", "--view")]
    said = {}
    for args in runs:
        done = servoc(installed, tmp_path, *args)
        assert done.returncode == 0 and "Traceback" not in done.stderr + done.stdout, (args, done.stdout, done.stderr)
        said[args[0]] = done.stdout
    assert (tmp_path / "b.hex").read_text().startswith(":") and (tmp_path / "wave.servo").exists()
    assert "serial: /dev/pts/" in said["sim"] and "0.50 s simulated" in said["sim"] and "view:" in said["sim"]
    # three ports, each rising its fitted span after the one before
    hexapod = servoc(installed, tmp_path, "plan", "hexapod.servo")
    assert hexapod.returncode == 0 and "ports: P0 rises at 0 ms (its lines reach N 149)" in hexapod.stdout, hexapod.stdout
    # the ports at once (frame_merged.asm.j2, irq_merged.asm.j2 in the wheel): the hexapod on an
    # STC89C52RC at 22.1184 MHz, compiled and verified from the wheel
    text = (ROOT / "examples" / "hexapod.servo").read_text(encoding="utf-8")
    body = "\n".join(line for line in text.splitlines() if not line.startswith(("target ", "frame ")))
    (tmp_path / "fast.servo").write_text("target stc89c52rc clock 22.1184MHz\n" + body + "\n")
    fast = servoc(installed, tmp_path, "verify", "fast.servo", "--frames", "60")
    assert fast.returncode == 0 and "fast.servo: OK" in fast.stdout and "max error 0 cycles" in fast.stdout, (fast.stdout, fast.stderr)
    fast = servoc(installed, tmp_path, "compile", "fast.servo", "-o", "fast.hex")
    assert fast.returncode == 0 and "all at once" in fast.stdout, (fast.stdout, fast.stderr)
