"""Build step only (pyproject.toml holds the metadata): the wheel carries what the quickstart needs.

The quickstart's base population (``checkpoints/Crossroads-2T2P-v1/base-v1``) and the example
submission (``submissions/crossroads-2t2p-mlp.onnx``) live once in the repository; ``build_py``
copies them into ``arena_league/league/packaged/`` of the built tree, where an installed package
finds them. MANIFEST.in puts them in an sdist, so a wheel built from the sdist carries them too.
"""

import shutil
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

HERE = Path(__file__).resolve().parent
#: Repository paths copied into ``arena_league/league/packaged/`` of a built wheel.
PACKAGED = {"checkpoints/Crossroads-2T2P-v1/base-v1": "populations/Crossroads-2T2P-v1/base-v1",
            "submissions/crossroads-2t2p-mlp.onnx": "crossroads-2t2p-mlp.onnx"}


class BuildWithPackagedData(build_py):
    def run(self):
        super().run()
        if getattr(self, "editable_mode", False):  # an editable install reads them from the checkout
            return
        target = Path(self.build_lib) / "arena_league" / "league" / "packaged"
        for source, dest in PACKAGED.items():
            src, out = HERE / source, target / dest
            if not src.exists():
                raise SystemExit(f"{src} is missing: the wheel must carry it (build from a checkout or an sdist)")
            out.parent.mkdir(parents=True, exist_ok=True)
            if src.is_dir():
                shutil.copytree(src, out, dirs_exist_ok=True)
            else:
                shutil.copy2(src, out)


setup(cmdclass={"build_py": BuildWithPackagedData})
