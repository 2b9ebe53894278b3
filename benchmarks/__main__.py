"""``python -m benchmarks``: the command line of :mod:`benchmarks.cli`."""

from __future__ import annotations

import sys

from benchmarks.cli import main

__all__ = ["main"]

if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
