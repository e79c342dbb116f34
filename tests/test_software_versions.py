"""Versions recorded in every JSON document (core.result.software_versions)."""
from importlib.metadata import version

import pytest

from hullprod_wb.core.result import dist_version


@pytest.mark.parametrize("name", ["numpy", "scipy", "trimesh", "pytest"])
def test_dist_version_matches_package_metadata(name):
    assert dist_version(name) == version(name)


def test_dist_version_of_an_absent_distribution_is_none():
    assert dist_version("no_such_distribution_hullprod") is None
