"""Evidence a reviewer reads: one self-contained HTML report of runs judged against requirements (docs/reports.md).

The public face: `Test` (one run or log and what was judged on it), `Report` (the tests, the environment, the
traceability matrix), `write_report(report, path)`, and `envelope` (the page's min/max decimation)."""

from .decimate import envelope
from .model import Environment, FmuRecord, Report, Test, environment_of_system
from .page import write_report
from .tests_from_logs import test_of_log

__all__ = ["Environment", "FmuRecord", "Report", "Test", "envelope", "environment_of_system", "test_of_log", "write_report"]
