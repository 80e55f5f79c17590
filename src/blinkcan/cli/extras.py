"""The command that installs one of blinkcan's optional extras where blinkcan itself is
installed: the same Python (``python -m pip``), and the same checkout for an editable install
(PEP 610's ``direct_url.json``), so the command a user copies works as it is."""

from __future__ import annotations

import json
import shlex
import sys
from importlib import metadata
from urllib.parse import unquote, urlparse

from blinkcan.formats.compressed import MissingExtraError


def install_command(extra: str) -> str:
    """E.g. ``/repo/.venv/bin/python -m pip install -e '/repo[web]'`` for a checkout installed
    with ``pip install -e`` (as ``dev.py`` does), ``... -m pip install 'blinkcan[web]'``
    otherwise."""
    pip = f"{shlex.quote(sys.executable)} -m pip install"
    try:
        direct = metadata.distribution("blinkcan").read_text("direct_url.json")
        found = json.loads(direct) if direct else {}
    except (metadata.PackageNotFoundError, ValueError):
        found = {}
    url = str(found.get("url", ""))
    if url.startswith("file://") and found.get("dir_info", {}).get("editable"):
        return f"{pip} -e {shlex.quote(unquote(urlparse(url).path) + f'[{extra}]')}"
    return f"{pip} {shlex.quote(f'blinkcan[{extra}]')}"


def error_text(error: Exception) -> str:
    """An error's line; one that names a missing extra ends with the command installing it."""
    if isinstance(error, MissingExtraError):
        return f"{error}: {install_command(error.extra)}"
    return str(error)
