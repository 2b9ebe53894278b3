"""When a batch kernel runs in parallel, and one parallel launch at a time.

numba runs ``prange`` loops on a threading layer chosen once per process (tbb, OpenMP
or its own "workqueue"). The layers differ in what they survive:

- "workqueue" (numba's fallback when neither tbb nor OpenMP is installed) aborts the
  process when two Python threads launch parallel kernels at once;
- GNU OpenMP ("omp", the layer numba picks on most Linux machines without tbb)
  terminates a forked child that launches a parallel kernel after its parent did
  (process pools and isolated workers are forked children).

So :func:`run` launches the parallel variant of a kernel only for batches of at least
:data:`PARALLEL_MIN` poses, one launch at a time in the process (:data:`LOCK`: two
launches at once would only share the same cores), and never in a forked child of a
process whose OpenMP layer is running; otherwise it runs the serial variant, which is
safe from any thread and in any process. Both variants compute every pose alike, so
the answers do not depend on the choice.
"""

from __future__ import annotations

import os
import threading
from collections.abc import Callable
from typing import Any, Protocol, cast

__all__ = ["COMPILED_MIN", "DEFAULT_COMPILED_MIN", "LOCK", "PARALLEL_MIN", "compiled_for",
           "compiled_min_from_environment", "configured_threads", "entry_point",
           "parallel_allowed", "run"]

#: Poses (or problems) from which a plain batch call of ``distribute`` takes its compiled
#: kernels (geometry, closed form, scaling, certificate); smaller batches take their
#: numpy references, which compile nothing. numba compiles a kernel on its first call
#: (30 s for the closed form's and the certificate's on a 2-core machine, once per
#: installation); below 16 poses the numpy path costs 0.3-1.5 ms more per call, so a
#: first call on a few poses answers at once. The rule is by size alone, so which path
#: answers never depends on what happens to be in numba's cache; the two paths give the
#: same statuses and the same tensions to rounding (each kernel is tested against its
#: reference). The real-time classes (``Distributor``, ``ThesisIK``, ``CoupledIK``)
#: are compiled at any size; a loop of one-pose calls belongs there. The environment
#: variable ``TENSION_OPT_COMPILED_MIN`` sets another size when the package is imported
#: (1: the kernels at every size; the tests run so, and the processes they start).
DEFAULT_COMPILED_MIN = 16


def compiled_min_from_environment() -> int:
    """:data:`COMPILED_MIN` as ``TENSION_OPT_COMPILED_MIN`` sets it (default 16).

    Raises
    ------
    InvalidInputError
        If the variable is set to anything but a whole number >= 0.
    """
    text = os.environ.get("TENSION_OPT_COMPILED_MIN", "").strip()
    if not text:
        return DEFAULT_COMPILED_MIN
    try:
        value = int(text)
    except ValueError:
        value = -1
    if value < 0:
        from tension_opt.errors import InvalidInputError

        raise InvalidInputError(f"TENSION_OPT_COMPILED_MIN={text!r} is not a whole number "
                                ">= 0 (poses from which plain calls take the kernels); "
                                "unset it for the default 16")
    return value


#: Poses from which a plain batch call takes the compiled kernels (see above).
COMPILED_MIN = compiled_min_from_environment()

#: Poses from which a batch runs in parallel. Each launch waits for every worker thread
#: to be scheduled, which on a busy machine can take a scheduler quantum (milliseconds):
#: measured on a loaded 2-core machine, 10^4 poses in chunks of 4096 took 4 us/pose in
#: parallel against 0.6 us/pose serial. So only batches that carry several milliseconds
#: of work per launch go parallel; :func:`tension_opt.distribute`'s default chunks
#: (4096 poses) stay serial, and small batches from many Python threads never wait.
PARALLEL_MIN = 16384
#: Held while a parallel kernel runs.
LOCK = threading.Lock()
_state = {"forked": False, "parallel": None}


def _after_fork_in_child() -> None:
    _state["forked"], _state["parallel"] = True, None


os.register_at_fork(after_in_child=_after_fork_in_child)


class _NumbaConfig(Protocol):
    """``numba.config``, whose ``NUMBA_*`` settings numba sets from the environment when
    it is imported (attributes no type checker sees)."""

    NUMBA_NUM_THREADS: int


def configured_threads() -> int:
    """numba's configured thread count (``NUMBA_NUM_THREADS``, one per core by default),
    read without starting its threading layer (``numba.get_num_threads()`` would)."""
    import numba

    return cast(_NumbaConfig, numba.config).NUMBA_NUM_THREADS


def parallel_allowed() -> bool:
    """Whether this process may launch parallel kernels: numba has more than one
    thread, and the process is no forked child of a parent whose OpenMP layer runs."""
    allowed = _state["parallel"]
    if allowed is None:
        import numba

        # The configured count: asking numba.get_num_threads() would start the layer.
        allowed = configured_threads() > 1
        if allowed and _state["forked"]:
            try:
                layer = numba.threading_layer()  # the parent's, if it launched any
            except ValueError:  # none started yet: this process starts its own
                layer = None
            allowed = layer != "omp"
        _state["parallel"] = allowed
    return bool(allowed)


def compiled_for(count: int) -> bool:
    """Whether a plain batch call of ``count`` poses takes the compiled kernels
    (:data:`COMPILED_MIN`)."""
    return count >= COMPILED_MIN


def run(parallel: Callable[..., Any], serial: Callable[..., Any], count: int,
        *args: Any) -> Any:
    """``parallel(*args)`` for a batch of ``count >= PARALLEL_MIN`` poses where allowed
    (:func:`parallel_allowed`), holding :data:`LOCK`; ``serial(*args)`` otherwise."""
    if count >= PARALLEL_MIN and parallel_allowed():
        with LOCK:
            return parallel(*args)
    return serial(*args)


def entry_point(kernel: Any, *examples: Any) -> Callable[..., Any]:
    """The machine code of ``kernel`` (a numba dispatcher) for exactly the argument
    types of ``examples``, as a function called without numba's type dispatch.

    The dispatcher works out the numba type of every argument on every call; for a
    kernel of seven arguments that costs about 1.4 us, more than the arithmetic of one
    pose. The entry point skips it, and so checks nothing: an array of another dtype,
    dimension or layout (a strided view read as contiguous) gives wrong numbers. Call
    it only with arguments whose types the caller has established (a read-only array
    where the kernel only reads is fine: its numba type differs in that flag alone).
    The machine code comes from numba's disk cache where it is there.
    """
    import numba

    return kernel.compile(tuple(numba.typeof(a) for a in examples))
