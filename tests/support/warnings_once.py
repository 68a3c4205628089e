"""A pytest plugin: each distinct data warning once in the warnings summary.

aquaspec warns (:class:`aquaspec.medium.water.WaterDataWarning`) every time a
water whose published table has gaps is loaded. pytest records warnings per
test and groups them by message *and* call site, so the suite's summary
listed the same few sentences about 60 times. Python's ``once`` filter
cannot help: its registry is the calling module's, cleared whenever the
filters change, which pytest does around every test. This keeps the first
report of each distinct warning (category and text) and drops the repeats
before the summary is written (and counted).
"""

from __future__ import annotations

import re

import pytest

#: Categories whose repeats are dropped (pytest shows other warnings as usual).
ONCE_CATEGORIES = ("WaterDataWarning",)
#: "path:lineno: Category: text" (the first line of a report's message).
_REPORT = re.compile(r"^.*?:\d+: (\w+): (.*)$")


def first_reports(reports) -> list:
    """``reports`` without repeats of a :data:`ONCE_CATEGORIES` warning."""
    seen, kept = set(), []
    for report in reports:
        m = _REPORT.match(report.message.splitlines()[0] if report.message else "")
        if m and m.group(1) in ONCE_CATEGORIES:
            if m.groups() in seen:
                continue
            seen.add(m.groups())
        kept.append(report)
    return kept


@pytest.hookimpl(hookwrapper=True, tryfirst=True)
def pytest_terminal_summary(terminalreporter):
    stats = terminalreporter.stats
    if stats.get("warnings"):
        stats["warnings"] = first_reports(stats["warnings"])
    yield
