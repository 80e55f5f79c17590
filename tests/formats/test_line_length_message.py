"""The message for a first line over MAX_LINE names the format with its article as spoken."""

from __future__ import annotations

from pathlib import Path

import pytest

from blinkcan.formats.log_source import MAX_LINE
from blinkcan.formats.logs import LogError, read_messages


@pytest.mark.parametrize(("suffix", "named"), [
    (".log", "a candump log"), (".asc", "an ASC log"), (".trc", "a TRC log"),
    (".csv", "a CSV log")])
def test_a_first_line_too_long_says_which_format_it_is_not(tmp_path: Path, suffix: str,
                                                             named: str) -> None:
    path = tmp_path / f"junk{suffix}"
    path.write_text("x" * (MAX_LINE + 10) + "\n")
    with pytest.raises(LogError, match=f"line 1 is over {MAX_LINE} bytes: not {named}$"):
        list(read_messages(path))
