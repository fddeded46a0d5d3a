"""Progress for pipes and batch logs (stdlib only): where stderr is not a terminal, a tqdm bar's
carriage returns and cursor codes garble the log (``jamflow ensemble ... | tail``), so progress
is written as plain, infrequent lines instead (``PlainProgress``); on a terminal the commands
keep their tqdm bars (``is_terminal`` tells which)."""

from __future__ import annotations

import sys
import time

PLAIN_EVERY = 10.0  # seconds: at most one plain line this often ...
PLAIN_TENTHS = 10  # ... or one per tenth of a known total


def is_terminal(stream=None) -> bool:
    """Whether ``stream`` (default: the current ``sys.stderr``) is a terminal."""
    stream = sys.stderr if stream is None else stream
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):  # no isatty, or a closed stream
        return False


class PlainProgress:
    """The part of tqdm's interface jamflow uses (``update``, ``set_postfix_str``,
    ``set_description_str``, ``n``, ``total``, ``disable``, iteration, ``with``), written as
    plain lines ``desc: 40% 4/10 unit, 12.0 s, postfix``: at most one every ``every`` seconds
    or per tenth of a known total, and a final line on close if anything was counted and the
    last line did not already show it. Nothing is written before the first update (a run
    refused before work prints its error line only). ``status=True``: a line of text only
    (tqdm's ``bar_format="{desc}"``), written when it changes, at most every ``every`` seconds."""

    def __init__(self, iterable=None, total=None, desc="", unit="it", disable=False, file=None,
                 every=PLAIN_EVERY, status=False, **ignored):
        if total is None and iterable is not None and hasattr(iterable, "__len__"):
            total = len(iterable)
        self.iterable, self.total, self.desc, self.unit = iterable, total, desc or "", unit
        self.disable, self.file, self.every, self.status = disable, file, every, status
        self.n, self.postfix = 0, ""
        self._start = self._last_t = time.monotonic()
        self._tenth = 0  # the highest tenth of the total a line has shown
        self._shown = None  # (n, total) of the last line
        self._closed = False

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __iter__(self):
        try:
            for item in self.iterable:
                yield item
                self.update(1)
        finally:
            self.close()

    def __len__(self):
        return len(self.iterable) if self.iterable is not None else (self.total or 0)

    def set_postfix_str(self, s="", refresh=True):
        self.postfix = str(s)

    def set_description_str(self, desc=None, refresh=True):
        changed = (desc or "") != self.desc
        self.desc = desc or ""
        now = time.monotonic()
        if self.status and changed and self.desc and not self.disable and now - self._last_t >= self.every:
            self._write(self.desc, now)

    def update(self, k=1):
        self.n += k
        if self.disable or self.status:
            return
        now = time.monotonic()
        tenth = self._tenths()
        if tenth > self._tenth or now - self._last_t >= self.every:
            self._tenth = max(self._tenth, tenth)
            self._line(now)

    def close(self):
        if self._closed:
            return
        self._closed = True
        if not self.disable and not self.status and self.n > 0 and self._shown != (self.n, self.total):
            self._line(time.monotonic())

    def _tenths(self) -> int:
        if not self.total or self.total <= 0:
            return 0
        return min(PLAIN_TENTHS, int(PLAIN_TENTHS * self.n / self.total))

    def _line(self, now):
        count = f"{self.n}/{self.total}" if self.total else f"{self.n}"
        percent = f"{100 * self.n / self.total:.0f}% " if self.total else ""
        elapsed = now - self._start
        parts = [f"{self.desc}: {percent}{count} {self.unit}", f"{elapsed:.1f} s"]
        if self.n and elapsed > 0:  # rate and time left, as the terminal bar shows them
            rate = self.n / elapsed
            parts.append(f"{rate:.3g} {self.unit}/s")
            if self.total and self.total > self.n:
                parts.append(f"ETA {(self.total - self.n) / rate:.0f} s")
        self._shown = (self.n, self.total)
        self._write(", ".join(parts + ([self.postfix] if self.postfix else [])), now)

    def _write(self, text, now):
        self._last_t = now
        stream = sys.stderr if self.file is None else self.file
        print(text, file=stream, flush=True)
