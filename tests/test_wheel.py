"""The wheel carries what the quickstart needs: built from a copy of the files the build reads (not
the checkout, which it would write build/ into), it holds the population index, the example agent
and the quickstart's base population, byte for byte what the index names; installed in a fresh venv
outside the checkout, the package finds that population in itself and checks it. The whole flow a
user runs (quickstart, pull, export snippet) is ``benchmarks/installed_package.py``."""

from __future__ import annotations

import json
import shutil
import site
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

from arena_league.league.population_index import load_index, population_folder_address

REPO = Path(__file__).resolve().parents[1]
GAME, NAME = "Crossroads-2T2P-v1", "base-v1"
PACKAGED = "arena_league/league/packaged/"


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    pytest.importorskip("setuptools", minversion="68")
    source = tmp_path_factory.mktemp("source")
    for name in ("pyproject.toml", "setup.py", "MANIFEST.in", "README.md"):
        shutil.copy2(REPO / name, source / name)
    shutil.copytree(REPO / "arena_league", source / "arena_league",
                    ignore=shutil.ignore_patterns("__pycache__", "packaged"))
    shutil.copytree(REPO / "checkpoints" / GAME / NAME, source / "checkpoints" / GAME / NAME)
    (source / "submissions").mkdir()
    shutil.copy2(REPO / "submissions" / "crossroads-2t2p-mlp.onnx", source / "submissions")
    out = tmp_path_factory.mktemp("wheel")
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q", "-w", str(out),
                    str(source)], check=True, capture_output=True)
    return next(out.glob("arena_league-*.whl"))


@pytest.mark.slow
def test_the_wheel_carries_the_index_the_example_and_the_quickstart_population(wheel, tmp_path):
    with zipfile.ZipFile(wheel) as archive:
        names = set(archive.namelist())
        archive.extractall(tmp_path / "unpacked", [n for n in names if n.startswith(PACKAGED)])
        index = json.loads(archive.read("arena_league/league/population_index.json"))
        metadata = archive.read(next(n for n in names if n.endswith(".dist-info/METADATA"))).decode()
    assert index == {k: v for k, v in load_index().items() if k not in ("by_key", "member_names")}
    assert PACKAGED + "crossroads-2t2p-mlp.onnx" in names
    folder = tmp_path / "unpacked" / PACKAGED / "populations" / GAME / NAME
    entry = next(p for p in index["populations"] if (p["game_id"], p["name"]) == (GAME, NAME))
    assert population_folder_address(folder) == entry["address"]
    assert not [n for n in names if n.startswith(PACKAGED + "populations/") and f"/{GAME}/{NAME}/" not in n]
    assert "Requires-Dist: onnxscript>=0.5" in metadata.splitlines()  # not an extra: docs/submitting.md's export needs it
    assert wheel.stat().st_size < 8_000_000


@pytest.mark.slow
def test_the_installed_package_finds_the_quickstart_population_in_itself(wheel, tmp_path):
    venv = tmp_path / "venv"
    subprocess.run([sys._base_executable, "-m", "venv", "--without-pip", str(venv)], check=True)
    packages = venv / "lib" / f"python{sys.version_info.major}.{sys.version_info.minor}" / "site-packages"
    with zipfile.ZipFile(wheel) as archive:  # what `pip install --no-deps` puts there, without pip in the venv
        archive.extractall(packages)
    (packages / "dependencies.pth").write_text(site.getsitepackages()[0] + "\n")
    probe = ("import arena_league; from arena_league.league.population_index import verified_population, shipped_rows;"
             f"found = verified_population('{GAME}', '{NAME}');"
             "print(arena_league.__file__); print(found.source, found.folder);"
             "print(sorted({r['where'] for r in shipped_rows()}))")
    done = subprocess.run([str(venv / "bin" / "python"), "-c", probe], cwd=tmp_path, capture_output=True, text=True,
                          env={"PATH": "/usr/bin:/bin", "HOME": str(tmp_path),
                               "ARENA_LEAGUE_POPULATIONS": str(tmp_path / "cache")}, check=False)
    assert done.returncode == 0, done.stderr
    module, found, wheres = done.stdout.splitlines()
    assert Path(module).is_relative_to(packages)
    assert found == f"package {packages / PACKAGED / 'populations' / GAME / NAME}"
    assert wheres == "['not downloaded', 'package']"  # every other population is one pull away
