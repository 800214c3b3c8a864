"""The packages whose names load on first use: every name resolves, and none shadows a submodule
(a name equal to a submodule's would turn into that module once anything imports the submodule)."""

from __future__ import annotations

import importlib
import pkgutil

import pytest


@pytest.mark.parametrize("package_name", ["arena_league.league", "arena_league.policies"])
def test_lazy_names_resolve_and_shadow_no_submodule(package_name):
    package = importlib.import_module(package_name)
    submodules = {info.name for info in pkgutil.iter_modules(package.__path__)}
    assert not set(package.__all__) & submodules
    for name in package.__all__:
        assert getattr(package, name) is not None
    for submodule in submodules:  # importing every submodule leaves the exported names intact
        importlib.import_module(f"{package_name}.{submodule}")
    for name in package.__all__:
        assert not isinstance(getattr(package, name), type(importlib)), name
