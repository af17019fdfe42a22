"""Warnings and fatal errors of one export run.

Warnings go to stderr as `warning: ...` lines and into the manifest's "warnings" list,
each text once; USD's own diagnostics (printed by its C++ core straight to file
descriptor 2) are captured and turned into such warnings too. An ExportError is unusable
input and ends the run with exit code 2 and one `error: ...` line. The warnings about what
is not rendered, or rendered approximately, are also counted by kind (`counts`, the
manifest's "unrendered" record, for `cirrus info`).
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
        # "not_rendered" / "approximated" -> kind -> warnings of that kind.
        self.counts: dict[str, dict[str, int]] = {"not_rendered": {}, "approximated": {}}

    def warn(self, message: str) -> None:
        """Records a fallback or skipped input, printing it the first time only."""
        if message in self._seen:
            return
        self._seen.add(message)
        self.warnings.append(message)
        print(f"warning: {message}", file=self._stream, flush=True)

    def not_rendered(self, kind: str, message: str) -> None:
        """Warns about a prim left out of the render, counted under `kind` (its type)."""
        self._counted("not_rendered", kind, message)

    def approximated(self, kind: str, message: str) -> None:
        """Warns about a prim or attribute rendered, but not as authored, counted under `kind`."""
        self._counted("approximated", kind, message)

    def _counted(self, status: str, kind: str, message: str) -> None:
        if message not in self._seen:
            table = self.counts[status]
            table[kind] = table.get(kind, 0) + 1
        self.warn(message)

    @contextlib.contextmanager
    def usd_diagnostics(self) -> Iterator[None]:
        """Captures USD's C++ diagnostics on fd 2 and re-reports each as one warning."""
        with _fd2_captured() as captured:
            self._stream = os.fdopen(os.dup(captured.saved), "w")
            try:
                yield
            finally:
                self._stream.close()
                self._stream = sys.stderr
        for function, message in captured.diagnostics:
            if function not in ALREADY_REPORTED:
                self.warn(f"usd: {message}")

    @staticmethod
    @contextlib.contextmanager
    def usd_messages() -> Iterator[list[str]]:
        """USD's diagnostics printed inside the block, handed to the caller (filled in when
        the block ends) instead of warned: for callers that fold them into a warning of
        their own naming the prim."""
        messages: list[str] = []
        with _fd2_captured() as captured:
            yield messages
        messages.extend(message for _, message in captured.diagnostics)


class _Captured:
    """What a redirection of fd 2 caught: the original fd 2 (while it lasts) and, once it
    ends, the USD diagnostics as (function, message)."""

    def __init__(self, saved: int) -> None:
        self.saved = saved
        self.diagnostics: list[tuple[str, str]] = []


@contextlib.contextmanager
def _fd2_captured() -> Iterator[_Captured]:
    """Points fd 2 at a temporary file for the block; other captured text is passed through
    to the previous fd 2 afterwards. Nests: an inner capture restores the outer one."""
    sys.stderr.flush()
    saved = os.dup(2)
    result = _Captured(saved)
    with tempfile.TemporaryFile(mode="w+b") as file:
        os.dup2(file.fileno(), 2)
        try:
            yield result
        finally:
            os.dup2(saved, 2)
            os.close(saved)
            file.seek(0)
            for line in file.read().decode("utf-8", "replace").splitlines():
                match = USD_DIAGNOSTIC.match(line)
                if match is None:
                    print(line, file=sys.stderr)
                else:
                    result.diagnostics.append((match.group(1), match.group(2)))
