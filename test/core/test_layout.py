"""The core's domain folders: each package's face imports lazily, and the old flat module paths still work."""

import importlib
import warnings

import pytest

import srs_ros.core
from srs_ros.core import MOVED_MODULES


@pytest.mark.parametrize("package", ["srs_ros.core.gait", "srs_ros.core.actuation", "srs_ros.core.vision"])
def test_every_public_name_of_a_domain_package_resolves(package):
    module = importlib.import_module(package)
    assert module.__doc__ and module.__all__
    for name in module.__all__:
        assert getattr(module, name) is not None
    with pytest.raises(AttributeError, match="has no attribute 'nothing_here'"):
        module.nothing_here  # noqa: B018


@pytest.mark.parametrize("old", sorted(set(MOVED_MODULES) - {"actuation"}))
def test_an_old_module_path_imports_the_new_module_with_a_deprecation_warning(old):
    import sys

    sys.modules.pop(f"srs_ros.core.{old}", None)
    with pytest.warns(DeprecationWarning, match=f"srs_ros.core.{old} moved to {MOVED_MODULES[old]}"):
        module = importlib.import_module(f"srs_ros.core.{old}")
    assert module is importlib.import_module(MOVED_MODULES[old])


def test_the_old_actuation_module_names_are_the_actuation_package_face():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        from srs_ros.core.actuation import clamp_pressures_bar, pressures_to_command_v  # noqa: F401
    assert srs_ros.core.actuation.clamp_pressures_bar([9.0] * 9).max() == 4.0
