"""Fixtures shared by the Python tests: `rig`, the real simulator and emulated robot (rig.py).

Under SCARATWIN_NO_SKIPS=1 (set by the ci preset, SCARATWIN_REQUIRE_ALL=ON) a skipped test is
a failed one: a module that is missing (pandas, matplotlib, nbformat, jupyter) must not let a
test pass unseen in CI, where scripts/install-deps.sh installs them all.
"""
import os

import pytest

from rig import rig  # noqa: F401  (a fixture, found by name)


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    outcome = yield
    report = outcome.get_result()
    if report.skipped and os.environ.get("SCARATWIN_NO_SKIPS") == "1":
        report.outcome = "failed"
        why = report.longrepr[2] if isinstance(report.longrepr, tuple) else report.longrepr
        report.longrepr = f"skipped, and SCARATWIN_NO_SKIPS=1 (CI) allows no skip: {why}"
