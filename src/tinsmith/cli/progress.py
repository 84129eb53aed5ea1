"""Stage timing and a progress bar on standard error (only when it is a terminal)."""

from __future__ import annotations

import contextlib
import sys
import time

import click

__all__ = ["Pipeline"]


class Pipeline:
    """Runs named stages in order, times each, and draws one bar over all of them.

    Parameters
    ----------
    weights : dict of str -> float
        Expected share of the total time of each stage (any scale).
    show : bool
        Draw the bar; it is drawn only when standard error is a terminal.
    """

    _STEPS = 1000

    def __init__(self, weights: dict[str, float], show: bool = True):
        total = sum(weights.values()) or 1.0
        self._share = {k: v / total for k, v in weights.items()}
        self.timings: dict[str, float] = {}
        self._done = 0.0
        self._drawn = 0
        self._bar = None
        if show and sys.stderr.isatty():
            self._bar = click.progressbar(length=self._STEPS, label="tinsmith", file=sys.stderr, width=30)
            self._bar.__enter__()

    def _draw(self, fraction: float) -> None:
        if self._bar is None:
            return
        target = min(self._STEPS, int(fraction * self._STEPS))
        if target > self._drawn:
            self._bar.update(target - self._drawn)
            self._drawn = target

    @contextlib.contextmanager
    def stage(self, name: str):
        """Time the block as ``name``; yield a callback taking the fraction done within it."""
        share = self._share.get(name, 0.0)
        start_done = self._done
        if self._bar is not None:
            self._bar.label = name
            self._bar.render_progress()
        start = time.perf_counter()

        def report(fraction: float) -> None:
            self._draw(start_done + share * max(0.0, min(1.0, float(fraction))))

        try:
            yield report
        finally:
            self.timings[name] = time.perf_counter() - start
            self._done = start_done + share
            self._draw(self._done)

    def __enter__(self) -> Pipeline:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        if self._bar is not None:
            self._bar.__exit__(None, None, None)
            self._bar = None
