"""A missing extra is named with the command that installs it where blinkcan is installed
(issue 20 item 15)."""

from __future__ import annotations

import json
import shlex
import sys
from importlib import metadata

import pytest
from click.testing import CliRunner

from blinkcan.cli.extras import install_command
from blinkcan.cli.main import cli


class _Installed:
    def __init__(self, direct_url: dict[str, object] | None) -> None:
        self.direct_url = direct_url

    def read_text(self, name: str) -> str | None:
        assert name == "direct_url.json"
        return json.dumps(self.direct_url) if self.direct_url is not None else None


@pytest.mark.parametrize(("direct_url", "expected"), [
    ({"url": "file:///home/ann/blink%20can", "dir_info": {"editable": True}},
     "-m pip install -e '/home/ann/blink can[web]'"),   # a checkout, as dev.py installs it
    ({"url": "file:///tmp/blinkcan-0.1.0-py3-none-any.whl", "archive_info": {}},
     "-m pip install 'blinkcan[web]'"),                  # a wheel file
    (None, "-m pip install 'blinkcan[web]'"),            # from the package index
])
def test_the_install_command_fits_where_blinkcan_is_installed(
        monkeypatch: pytest.MonkeyPatch, direct_url: dict[str, object] | None,
        expected: str) -> None:
    monkeypatch.setattr(metadata, "distribution", lambda name: _Installed(direct_url))
    assert install_command("web") == f"{shlex.quote(sys.executable)} {expected}"


def test_the_panel_without_the_web_extra_names_the_command(monkeypatch: pytest.MonkeyPatch
                                                           ) -> None:
    monkeypatch.setitem(sys.modules, "blinkcan.web.server", None)  # as if not installed
    result = CliRunner().invoke(cli, ["emulate", "keypad", "--web", "127.0.0.1:0", "-i",
                                      "virtual", "-c", "extras-test"])
    assert result.exit_code == 1
    assert result.output.strip().splitlines()[-1] == (
        f"Error: the front panel needs the web extra: {install_command('web')}")
