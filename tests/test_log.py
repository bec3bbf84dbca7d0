"""The progress helper of long loops (tyreroad.log.Progress), on a fake clock."""

from __future__ import annotations

import pytest

from tyreroad.log import Progress, format_duration


class FakeClock:
    def __init__(self) -> None:
        self.now = 1000.0

    def __call__(self) -> float:
        return self.now


@pytest.mark.parametrize("seconds, text", [(0, "0 s"), (8.4, "8 s"), (59.6, "1 min 00 s"), (245, "4 min 05 s"),
                                           (3600 + 12 * 60 + 7, "1 h 12 min")])
def test_format_duration(seconds, text):
    assert format_duration(seconds) == text


def test_time_left_is_the_rate_estimate():
    clock = FakeClock()
    progress = Progress(1000, clock=clock)
    assert progress.status(0) == "elapsed 0 s"  # nothing done: no estimate
    clock.now += 130.0  # 100 of 1000 steps in 130 s: 900 more take 1170 s
    assert progress.status(100) == "elapsed 2 min 10 s, about 19 min 30 s left"
    clock.now += 1170.0
    assert progress.status(1000) == "elapsed 21 min 40 s"  # finished: no estimate


def test_due_once_the_interval_has_passed_since_the_last_line():
    clock = FakeClock()
    progress = Progress(10, interval=60.0, clock=clock)
    clock.now += 59.0
    assert not progress.due()
    clock.now += 1.0
    assert progress.due()
    progress.status(3)
    assert not progress.due()  # a line was just printed
    clock.now += 60.0
    assert progress.due()
