"""tests/conftest.py: with CI set, a skipped test fails the session in one line; without, a
skip is a skip. Each case runs pytest in a subprocess on made-up tests beside a copy of the
conftest."""

from __future__ import annotations

from pathlib import Path

import pytest

CONFTEST = Path(__file__).with_name("conftest.py")

TESTS = """
import pytest

def test_runs():
    pass

def test_skips():
    pytest.skip("no such extra")

@pytest.mark.xfail(strict=True, reason="known")
def test_fails_as_expected():
    assert False
"""


def run(pytester: pytest.Pytester, tests: str, *args: str) -> pytest.RunResult:
    pytester.makeconftest(CONFTEST.read_text())
    pytester.makepyfile(test_made_up=tests)
    return pytester.runpytest_subprocess("-p", "no:cacheprovider", *args)


def test_under_ci_a_skip_fails_the_session_with_one_line_naming_it(pytester, monkeypatch):
    monkeypatch.setenv("CI", "true")
    result = run(pytester, TESTS)
    result.assert_outcomes(passed=1, skipped=1, xfailed=1)
    assert result.ret == pytest.ExitCode.TESTS_FAILED
    lines = [line for line in result.outlines if line.startswith("CI is set")]
    assert lines == ["CI is set and 1 test(s) skipped: test_made_up.py::test_skips"]


def test_under_ci_a_skip_fails_the_session_on_every_core_too(pytester, monkeypatch):
    """`make test` runs pytest-xdist's workers, which report their skips to the session."""
    monkeypatch.setenv("CI", "true")
    pytester.makepyfile(test_also_made_up='import pytest\n\npytest.importorskip("no_such_one")\n')
    result = run(pytester, TESTS, "-n", "2", "--dist", "loadfile")
    result.assert_outcomes(passed=1, skipped=2, xfailed=1)
    assert result.ret == pytest.ExitCode.TESTS_FAILED
    result.stdout.fnmatch_lines(["CI is set and 2 test(s) skipped: *"])


def test_under_ci_a_module_skipped_at_import_fails_too(pytester, monkeypatch):
    monkeypatch.setenv("CI", "true")
    result = run(pytester, 'import pytest\n\npytest.importorskip("no_such_module_here")\n')
    assert result.ret == pytest.ExitCode.TESTS_FAILED
    result.stdout.fnmatch_lines(["CI is set and 1 test(s) skipped: test_made_up.py"])


def test_under_ci_no_skip_passes(pytester, monkeypatch):
    monkeypatch.setenv("CI", "true")
    result = run(pytester, TESTS.replace('pytest.skip("no such extra")', "pass"))
    result.assert_outcomes(passed=2, xfailed=1)
    assert result.ret == pytest.ExitCode.OK


@pytest.mark.parametrize("value", [None, ""])
def test_without_ci_a_skip_is_a_skip(pytester, monkeypatch, value):
    if value is None:
        monkeypatch.delenv("CI", raising=False)
    else:
        monkeypatch.setenv("CI", value)
    result = run(pytester, TESTS)
    result.assert_outcomes(passed=1, skipped=1, xfailed=1)
    assert result.ret == pytest.ExitCode.OK
    assert not [line for line in result.outlines if line.startswith("CI is set")]
