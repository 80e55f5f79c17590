"""Golden traces: a run's frames compared with a recorded file, times within a tolerance.

A trace is any file ``blinkcan`` reads and writes (candump ``.log``, ``.asc``, ``.pcap``...).
Times are compared relative to the first frame of each side, so a trace recorded from a rig
that started at another virtual time still matches.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Sequence
from pathlib import Path

from blinkcan.formats.logs import FrameWriter, read_frames
from blinkcan.protocol.frame import Frame


def record_trace(frames: Iterable[tuple[float, Frame]], path: str | os.PathLike[str],
                 replace: bool = False) -> int:
    """Write ``frames`` (``rig.frames``) to ``path``; returns how many. An existing file is
    kept unless ``replace``."""
    with FrameWriter(path, replace=replace) as writer:
        for time, frame in frames:
            writer.write(time, frame)
    return writer.count


def assert_matches_trace(frames: Sequence[tuple[float, Frame]],
                         path: str | os.PathLike[str], tolerance: float = 0.001) -> None:
    """AssertionError naming the first difference between ``frames`` and the trace at
    ``path``: a frame that differs, one more or fewer, or a time off by more than
    ``tolerance`` seconds."""
    if tolerance < 0:
        raise ValueError(f"tolerance must be >= 0 seconds, got {tolerance}")
    expected = list(read_frames(Path(path)))
    got = list(frames)
    base_expected = expected[0][0] if expected else 0.0
    base_got = got[0][0] if got else 0.0
    for i, (want, have) in enumerate(zip(expected, got, strict=False)):
        want_time, want_frame = want[0] - base_expected, want[1]
        have_time, have_frame = have[0] - base_got, have[1]
        if want_frame != have_frame:
            raise AssertionError(f"frame {i}: expected {want_frame} at {want_time:.6f} s, "
                                 f"got {have_frame} at {have_time:.6f} s"
                                 + _reordered(expected[i:], base_expected, got[i:], base_got,
                                              tolerance))
        if abs(want_time - have_time) > tolerance:
            raise AssertionError(f"frame {i} ({have_frame}): at {have_time:.6f} s, expected "
                                 f"{want_time:.6f} s +- {tolerance} s")
    if len(expected) != len(got):
        extra = got[len(expected)] if len(got) > len(expected) else expected[len(got)]
        raise AssertionError(f"{len(got)} frames, the trace has {len(expected)}; first "
                             f"{'extra' if len(got) > len(expected) else 'missing'}: "
                             f"{extra[1]} at {extra[0]:.6f} s")


def _reordered(expected: Sequence[tuple[float, Frame]], base_expected: float,
               got: Sequence[tuple[float, Frame]], base_got: float, tolerance: float) -> str:
    """A hint when the frames at the first difference's instant are the same ones in another
    order: the rig now lets frames already sent arrive before an input or fault call at the
    same instant (``Rig.catch_up``), which reorders traces recorded before it."""
    start = expected[0][0] - base_expected

    def instant(frames: Sequence[tuple[float, Frame]], base: float) -> list[Frame]:
        return [frame for time, frame in frames if abs(time - base - start) <= tolerance]

    mine, theirs = instant(got, base_got), instant(expected, base_expected)
    if sorted(mine) != sorted(theirs):
        return ""
    return ("; the same frames at this instant in another order (a rig input or fault call "
            "now lets the frames already sent arrive first; a trace recorded before it did may "
            "differ so: if the new order is right, record it again, pytest --blinkcan-record)")
