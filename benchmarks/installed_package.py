"""The package as a user installs it: a wheel built from this checkout, installed in a fresh virtual
environment outside the checkout, used from an empty folder with a fresh league and an empty
population cache::

    python benchmarks/installed_package.py [--work DIR] [--keep]

Steps, each printed with its command, exit code, time and the end of its output:

1. ``pip wheel --no-deps --no-build-isolation`` of the checkout (the wheel's size is reported);
2. a venv whose site-packages sees this interpreter's (for the dependencies, through a plain path
   line in a ``.pth`` file, which does not run an editable install's finder), the wheel installed
   into it with ``--no-deps``; ``arena_league`` must import from the venv;
3. ``arena-league quickstart``: the example placed against the 100-agent base population the
   wheel carries;
4. ``arena-league population pull Snake-2T2P-v1 --mirror URL`` from an ``http.server`` serving the
   checkout's ``checkpoints/`` on 127.0.0.1;
5. the torch export snippet of ``docs/submitting.md`` (read from there) on a small GoBang MLP, then
   ``arena-league submit model.onnx``.

Prints a JSON summary on stdout; exits 1 when a step fails. About a minute on 2 cores (the
quickstart is most of it); the tests check the wheel's contents and the pull on a tiny population.
"""

from __future__ import annotations

import argparse
import functools
import http.server
import json
import os
import re
import shutil
import site
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def step(name: str, argv: list[str], *, cwd: Path, env: dict[str, str] | None = None) -> dict:
    print(f"$ {' '.join(argv)}", file=sys.stderr)
    started = time.perf_counter()
    done = subprocess.run(argv, cwd=cwd, env=env, capture_output=True, text=True, check=False)
    seconds = round(time.perf_counter() - started, 1)
    output = (done.stderr + done.stdout).strip()  # a command's log lines (stderr) come before its table
    print(f"  exit {done.returncode} in {seconds} s\n  " + "\n  ".join(output.splitlines()[-12:]), file=sys.stderr)
    return {"step": name, "returncode": done.returncode, "seconds": seconds, "output": output}


class QuietHandler(http.server.SimpleHTTPRequestHandler):
    def log_message(self, format, *args):  # the pull's own line says what was fetched
        pass


def documented_export_snippet() -> str:
    """The ``torch.onnx.export(...)`` call of ``docs/submitting.md``, as it stands there."""
    text = (REPO / "docs" / "submitting.md").read_text()
    found = re.search(r"^ {4}(torch\.onnx\.export\(.*?\)\))\s*$", text, flags=re.MULTILINE | re.DOTALL)
    if found is None:
        raise SystemExit("docs/submitting.md has no `torch.onnx.export(...)` snippet")
    return "\n".join(line.removeprefix("    ") for line in found.group(1).splitlines())


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--work", default=None, help="the working folder (default: a new temporary one)")
    parser.add_argument("--keep", action="store_true", help="keep the working folder")
    args = parser.parse_args()
    work = Path(args.work) if args.work else Path(tempfile.mkdtemp(prefix="arena-league-installed-"))
    if work.resolve().is_relative_to(REPO):
        raise SystemExit(f"{work} lies inside the checkout; the point is a folder outside it")
    steps = []
    try:
        wheels, venv, cwd = work / "wheel", work / "venv", work / "cwd"
        cwd.mkdir(parents=True, exist_ok=True)
        steps.append(step("build the wheel", [sys.executable, "-m", "pip", "wheel", "--no-deps",
                                              "--no-build-isolation", "-q", "-w", str(wheels), str(REPO)], cwd=cwd))
        wheel = next(wheels.glob("arena_league-*.whl"))
        subprocess.run([sys._base_executable, "-m", "venv", str(venv)], check=True)
        packages = venv / "lib" / f"python{sys.version_info.major}.{sys.version_info.minor}" / "site-packages"
        (packages / "dependencies.pth").write_text(site.getsitepackages()[0] + "\n")
        python, command = venv / "bin" / "python", str(venv / "bin" / "arena-league")
        steps.append(step("install the wheel", [str(python), "-m", "pip", "install", "-q", "--no-deps", str(wheel)],
                          cwd=cwd))
        steps.append(step("import", [str(python), "-c", "import arena_league; print(arena_league.__file__)"], cwd=cwd))
        installed = Path(steps[-1]["output"].splitlines()[-1])
        if not installed.is_relative_to(venv):
            raise SystemExit(f"arena_league imports from {installed}, not from the new venv {venv}")
        env = {**os.environ, "ARENA_LEAGUE_HOME": str(work / "home"), "ARENA_LEAGUE_POPULATIONS": str(work / "cache")}
        for key in ("ARENA_LEAGUE_DB", "ARENA_LEAGUE_POPULATION_MIRROR", "PYTHONPATH"):
            env.pop(key, None)
        steps.append(step("quickstart", [command, "quickstart"], cwd=cwd, env=env))
        handler = functools.partial(QuietHandler, directory=str(REPO / "checkpoints"))
        server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
        threading.Thread(target=server.serve_forever, daemon=True).start()
        try:
            mirror = f"http://127.0.0.1:{server.server_address[1]}/"
            steps.append(step("pull", [command, "population", "pull", "Snake-2T2P-v1", "--mirror", mirror], cwd=cwd,
                              env=env))
        finally:
            server.shutdown()
            server.server_close()
        script = ("import torch\nfrom arena_league.envs import make_rules\n"
                  "obs_dim = make_rules('GoBang-2T1P-v1').obs_dim\n"
                  "model = torch.nn.Sequential(torch.nn.Linear(obs_dim, 32), torch.nn.Tanh(),\n"
                  "                            torch.nn.Linear(32, 225))  # GoBang's 225 cells\n"
                  + documented_export_snippet() + "\n")
        (cwd / "export.py").write_text(script)
        steps.append(step("documented export snippet", [str(python), "export.py"], cwd=cwd, env=env))
        steps.append(step("submit the export", [command, "submit", "model.onnx", "--game", "GoBang-2T1P-v1", "--name",
                                                "alice-v1"], cwd=cwd, env=env))
        summary = {"work": str(work), "wheel": wheel.name, "wheel_bytes": wheel.stat().st_size,
                   "installed_at": str(installed), "outside_checkout": not installed.is_relative_to(REPO),
                   "steps": [{k: v for k, v in s.items() if k != "output"} for s in steps],
                   "quickstart": steps[3]["output"].splitlines()[:6], "pull": steps[4]["output"].splitlines()[-1:]}
        print(json.dumps(summary, indent=2))
        return 0 if all(s["returncode"] == 0 for s in steps) and summary["outside_checkout"] else 1
    finally:
        if not args.keep:
            shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
