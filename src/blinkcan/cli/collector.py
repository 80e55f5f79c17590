"""Python's garbage collector at start-up and while logs are decoded (issue 23: CPU per frame).

Importing a command's modules (pyarrow, the decoder's tables) allocates objects by the hundred
thousand, none of them garbage: the collector walked them some 90 times at every start-up
(~0.03 s of CPU). A decoding run keeps a row group's lists and tuples alive until the group
is written, and the youngest generation, collected every 700 allocations, walked them again
each time (~3 % of a run's CPU, and a full collection over every module's objects once a file
is long enough). Both are switched off where they find nothing, and restored afterwards.
"""

from __future__ import annotations

import gc
from collections.abc import Iterator
from contextlib import contextmanager

#: allocations between two collections of the youngest generation while logs are decoded
#: (Python's default: 700); a cycle of garbage waits at most this many allocations
DECODING_THRESHOLD = 100_000


@contextmanager
def collector_paused() -> Iterator[None]:
    """No collection while modules are imported (their objects are no garbage)."""
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()


@contextmanager
def collector_for_decoding() -> Iterator[None]:
    """The objects alive now frozen (``gc.freeze``: the modules' objects, walked by no
    collection of the run and shared with ``-j``'s forked workers, which inherit these
    settings), the youngest generation collected every :data:`DECODING_THRESHOLD`
    allocations (pyarrow's and the fleet's modules are imported under it, in a collection
    or two rather than dozens); both as they were afterwards."""
    thresholds = gc.get_threshold()
    frozen_before = gc.get_freeze_count()
    gc.freeze()
    gc.set_threshold(DECODING_THRESHOLD, *thresholds[1:])
    try:
        yield
    finally:
        gc.set_threshold(*thresholds)
        if not frozen_before:  # (objects someone else froze stay frozen)
            # the run's objects moved, not walked, into the oldest generation with the
            # others: a collection of the youngest would walk every one of them now
            gc.freeze()
            gc.unfreeze()
