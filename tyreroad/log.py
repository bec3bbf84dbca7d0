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
