"""A time limit over a whole computation, checked between its steps."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

from tension_opt.checks import is_number
from tension_opt.errors import InvalidInputError

__all__ = ["Deadline", "OutOfTime"]


class OutOfTime(Exception):
    """The time limit of a computation passed before it ended."""


@dataclass(frozen=True)
class Deadline:
    """When a computation must stop (``time.perf_counter`` seconds; inf: never)."""

    end: float = math.inf

    @classmethod
    def after(cls, time_limit: object, start: float) -> Deadline:
        """``time_limit`` seconds (a positive number, or None for no limit) after
        ``start``; else the package's error naming ``time_limit``."""
        if time_limit is None:
            return cls()
        if not (is_number(time_limit) and float(time_limit) > 0):  # type: ignore[arg-type]
            raise InvalidInputError(
                f"time_limit must be a positive number of seconds (or None), got {time_limit!r}")
        return cls(start + float(time_limit))  # type: ignore[arg-type]

    @property
    def limited(self) -> bool:
        """Whether there is a limit."""
        return math.isfinite(self.end)

    def remaining(self) -> float:
        """Seconds left (inf without a limit, 0 once passed)."""
        return max(self.end - time.perf_counter(), 0.0)

    def check(self) -> None:
        """Raise :class:`OutOfTime` once the limit has passed."""
        if time.perf_counter() > self.end:
            raise OutOfTime
