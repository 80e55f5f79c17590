"""Helpers for tests that run blinkcan in child processes on a udp_multicast bus (hop limit 0:
the datagrams never leave this machine)."""

from __future__ import annotations

import subprocess

import can
import pytest


def multicast_bus(channel: str, port: int) -> can.BusABC:
    """This process's bus on the group ``channel``; the test skips, saying how to fix it,
    where the machine cannot join a multicast group."""
    try:
        return can.Bus(interface="udp_multicast", channel=channel, port=port, hop_limit=0,
                       receive_own_messages=False)
    except (OSError, ImportError, can.CanError) as error:
        pytest.skip(f"udp_multicast unavailable here ({error}); on a machine without a default "
                    "route run: ip route add 224.0.0.0/4 dev lo")


def stop(child: subprocess.Popen[bytes] | subprocess.Popen[str]) -> None:
    """End a child process: SIGTERM, then SIGKILL if it has not ended within 5 s."""
    child.terminate()
    try:
        child.wait(timeout=5)
    except subprocess.TimeoutExpired:
        child.kill()
        child.wait(timeout=5)
