"""The reports: the seed's claims checked (``results/report.md``) and the rolling study (``results/rolling.md``).

A package of three modules, because the claim registry has a second user besides the markdown:

* :mod:`~tyreroad.report.claims`: the thresholds (:data:`THRESHOLDS`), the measurements and the
  claim registry :data:`CLAIMS` -- the one place a verdict is decided, used by the report's table
  and by the sensitivity sweep (:mod:`tyreroad.sensitivity`);
* :mod:`~tyreroad.report.sections`: every report section, each a function of one
  :class:`ReportContext` (the study, its settings, the thresholds and the datasets), among them
  the sections on load-unload cycles and on rolling that used to live in ``hysteresis`` and
  ``rolling``;
* :mod:`~tyreroad.report.document`: the assembling, the one place that lists the sections of each
  report in order (:func:`build_report`, :func:`build_rolling_report`), and :func:`write_report`.

Every public name is re-exported here: ``from tyreroad.report import X`` works for each of them.
"""

from .claims import (
    CLAIMS,
    DIRECTION_OPPOSITE,
    FAILS,
    HOLDS,
    NOT_EVALUATED,
    THRESHOLDS,
    VERDICTS,
    ClaimContext,
    ClaimResult,
    count_growth_peak,
    evaluate_claims,
    evaluate_context,
    loss_direction_verdict,
    quasistatic_resampling_check,
    ripple,
    saturation_change,
)
from .document import REPORT_SECTIONS, ROLLING_REPORT_SECTIONS, build_report, build_rolling_report, write_report
from .sections import ReportContext, hysteresis_section, rolling_section

# private, re-exported because tests/test_stiffness.py imports it from tyreroad.report
from .sections import _stiffness_spectrum_section  # noqa: F401  (isort: skip)

__all__ = [
    "THRESHOLDS",
    "HOLDS",
    "DIRECTION_OPPOSITE",
    "FAILS",
    "NOT_EVALUATED",
    "VERDICTS",
    "ClaimResult",
    "ClaimContext",
    "CLAIMS",
    "evaluate_claims",
    "evaluate_context",
    "loss_direction_verdict",
    "saturation_change",
    "ripple",
    "count_growth_peak",
    "quasistatic_resampling_check",
    "ReportContext",
    "REPORT_SECTIONS",
    "ROLLING_REPORT_SECTIONS",
    "build_report",
    "build_rolling_report",
    "write_report",
    "hysteresis_section",
    "rolling_section",
]
