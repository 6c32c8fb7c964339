"""The style rules a reader meets on every page: lines of at most 120 characters in the project's Python."""

import pytest

from tests._paths import REPO

MAX_LINE = 120
FOLDERS = ("src", "tests", "benchmarks")


@pytest.mark.parametrize("folder", FOLDERS)
def test_no_python_line_is_over_120_characters(folder):
    long_lines = [f"{path.relative_to(REPO)}:{number} ({len(line)} characters)"
                  for path in sorted((REPO / folder).rglob("*.py"))
                  for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1)
                  if len(line) > MAX_LINE]
    assert not long_lines, f"lines over {MAX_LINE} characters: " + ", ".join(long_lines)
