"""The stability suite of issue #6 (bench/stability/), one test per case.

The same cases print as a table with `make stability`. A case with a known cause outside this
suite's reach is xfail(strict=True): its reason names the fix, and fixing it makes the test
fail until the mark is removed.
"""

import pytest

from mcpt.bench import stability


@pytest.fixture(scope="module")
def env(tmp_path_factory, gl):
    e = stability.Env(tmp_path_factory.mktemp("stability"))
    e.__dict__["gl"] = gl  # the session's context (cached_property slot)
    return e


def test_the_suite_has_at_least_25_cases_in_every_group():
    groups = {c.group for c in stability.CASES}
    assert len(stability.CASES) >= 25
    assert {"furnace", "scale", "offset", "watertight", "lights", "geometry", "limits",
            "non-finite", "determinism"} <= groups
    assert len({c.name for c in stability.CASES}) == len(stability.CASES)


@pytest.mark.parametrize("case", stability.CASES, ids=lambda c: c.name)
def test_case(case, env, request):
    known = case.known_issue(env)
    if known:
        request.applymarker(pytest.mark.xfail(strict=True, reason=known))
    row = stability.run_case(case, env)
    o = row.outcome
    assert o.passed, f"{case.name}: expected {o.expected}; measured {o.measured}"
