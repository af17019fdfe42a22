"""Warnings and fatal errors of one export run.

Warnings go to stderr as `warning: ...` lines and into the manifest's "warnings" list,
each text once; USD's own diagnostics (printed by its C++ core straight to file
descriptor 2) are captured and turned into such warnings too. An ExportError is unusable
input and ends the run with exit code 2 and one `error: ...` line.
"""

import contextlib
import os
import re
import sys
import tempfile
from collections.abc import Iterator
from typing import TextIO

# "Warning: in Func at line 12 of /src/file.cpp -- message"
USD_DIAGNOSTIC = re.compile(r"^(?:Warning|Runtime Error|Coding Error|Error): in (\S+) at line \d+ of \S+ -- (.*)$")
# Composition errors are reported by Report's caller, grouped per missing layer.
ALREADY_REPORTED = {"_ReportErrors"}


class ExportError(Exception):
    """Input the exporter cannot use at all (missing file, parse error, empty stage)."""


class Report:
    """Collects warnings once each, in the order they first happened."""

    def __init__(self) -> None:
        self.warnings: list[str] = []
        self._seen: set[str] = set()
        self._stream: TextIO = sys.stderr

    def warn(self, message: str) -> None:
        """Records a fallback or skipped input, printing it the first time only."""
        if message in self._seen:
            return
        self._seen.add(message)
        self.warnings.append(message)
        print(f"warning: {message}", file=self._stream, flush=True)

    @contextlib.contextmanager
    def usd_diagnostics(self) -> Iterator[None]:
        """Captures USD's C++ diagnostics on fd 2 and re-reports each as one warning."""
        sys.stderr.flush()
        saved = os.dup(2)
        with tempfile.TemporaryFile(mode="w+b") as captured:
            os.dup2(captured.fileno(), 2)
            self._stream = os.fdopen(os.dup(saved), "w")
            try:
                yield
            finally:
                self._stream.close()
                self._stream = sys.stderr
                os.dup2(saved, 2)
                os.close(saved)
                captured.seek(0)
                self._report_usd_lines(captured.read().decode("utf-8", "replace"))

    def _report_usd_lines(self, text: str) -> None:
        """Turns captured diagnostics into warnings; other captured text is passed through."""
        for line in text.splitlines():
            match = USD_DIAGNOSTIC.match(line)
            if match is None:
                print(line, file=sys.stderr)
            elif match.group(1) not in ALREADY_REPORTED:
                self.warn(f"usd: {match.group(2)}")
