"""Logging set-up for workflow jobs.

Library modules log through ``logging.getLogger(__name__)``; a Snakemake adapter script calls
:func:`configure` once so that the records reach the rule's ``log:`` file (and stderr).
"""

from __future__ import annotations

import logging
import sys
from pathlib import Path

_FORMAT = "%(asctime)s %(levelname)-7s %(name)s: %(message)s"


def configure(log_path: str | Path | None = None, level: int = logging.INFO) -> logging.Logger:
    """Send tyreroad's log records to ``log_path`` (overwritten) and to stderr.

    Parameters
    ----------
    log_path : path-like, optional
        The rule's log file. Parent directories are created.
    level : int
        Logging level for the ``tyreroad`` logger.

    Returns
    -------
    logging.Logger
        The ``tyreroad`` package logger.
    """
    logger = logging.getLogger("tyreroad")
    logger.setLevel(level)
    for handler in list(logger.handlers):
        logger.removeHandler(handler)
        handler.close()
    formatter = logging.Formatter(_FORMAT)
    handlers: list[logging.Handler] = [logging.StreamHandler(sys.stderr)]
    if log_path is not None:
        Path(log_path).parent.mkdir(parents=True, exist_ok=True)
        handlers.append(logging.FileHandler(log_path, mode="w"))
    for handler in handlers:
        handler.setFormatter(formatter)
        logger.addHandler(handler)
    logger.propagate = False
    logging.captureWarnings(True)

    def _log_uncaught(exc_type, exc, tb):
        # a failing job must say why in its log file, not only on the terminal
        logger.error("job failed: %s: %s", exc_type.__name__, exc, exc_info=(exc_type, exc, tb))

    sys.excepthook = _log_uncaught
    return logger


def format_duration(seconds: float) -> str:
    """A duration for a progress line: '8 s', '4 min 05 s', '1 h 12 min'.

    Parameters
    ----------
    seconds : float
        Duration [s], >= 0.
    """
    s = max(0, int(round(seconds)))
    if s < 60:
        return f"{s} s"
    if s < 3600:
        return f"{s // 60} min {s % 60:02d} s"
    return f"{s // 3600} h {(s % 3600) // 60:02d} min"


class Progress:
    """Elapsed time and an estimate of the time left for a loop of ``total`` equal-ish items.

    The estimate is the simple rate one: time left = elapsed / done x (total - done), with done
    the items finished so far. It says nothing before the first item is done.

    Parameters
    ----------
    total : int
        Number of items (e.g. time steps) of the loop.
    interval : float
        :meth:`due` is true once this long [s] has passed since the last line, so that a long run
        prints a line at least this often whatever its step count.
    clock : callable
        Monotonic clock in seconds (``time.monotonic``; tests pass a fake one).
    """

    def __init__(self, total: int, interval: float = 60.0, clock=None) -> None:
        import time

        self.total = int(total)
        self.interval = float(interval)
        self._clock = clock if clock is not None else time.monotonic
        self._start = self._clock()
        self._last = self._start

    def due(self) -> bool:
        """True when ``interval`` has passed since the last :meth:`status` (or the start)."""
        return self._clock() - self._last >= self.interval

    def status(self, done: int) -> str:
        """'elapsed 2 min 10 s, about 6 min 30 s left' after ``done`` of ``total`` items."""
        now = self._clock()
        self._last = now
        elapsed = now - self._start
        text = f"elapsed {format_duration(elapsed)}"
        if 0 < done < self.total and elapsed > 0:
            left = elapsed / done * (self.total - done)
            text += f", about {format_duration(left)} left"
        return text
