"""Progress of long calls (``lobe.fit``, ``lobe.render``): a tqdm bar when tqdm is
installed (``tqdm.auto``: the widget in a notebook with ipywidgets, the text bar in a
terminal or a notebook without), else plain lines on stderr."""

from __future__ import annotations

import sys
from typing import Optional


class Progress:
    """A bar counting ``unit``s up to ``total`` (``None``: unknown). ``update_to(n,
    note)`` moves it to ``n``; without tqdm it prints a line per ``note``, or, for
    updates without one, a line at each tenth of ``total`` on a terminal and only the
    last one elsewhere (a log or a pipe)."""

    def __init__(self, desc: str, total: Optional[int], unit: str, unit_scale: bool = False):
        self.desc, self.total, self.n = desc, total, 0
        self._tenths = 0
        self._interactive = hasattr(sys.stderr, "isatty") and sys.stderr.isatty()
        try:
            from tqdm.auto import tqdm
        except ImportError:
            self.bar = None
        else:
            self.bar = tqdm(total=total, desc=desc, unit=unit, unit_scale=unit_scale)

    def update_to(self, n: int, note: Optional[str] = None) -> None:
        step, self.n = n - self.n, n
        if self.bar is not None:
            if note is not None:
                self.bar.set_postfix_str(note, refresh=False)
            self.bar.update(step)
        elif note is not None:
            print(f"{self.desc}: {note}", file=sys.stderr)
        elif self.total:
            tenths = 10 * n // self.total
            if not self._interactive and n < self.total:
                return
            if tenths > self._tenths:
                self._tenths = tenths
                print(f"{self.desc}: {10 * tenths}% ({n} of {self.total})", file=sys.stderr)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()

    def __enter__(self) -> "Progress":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
