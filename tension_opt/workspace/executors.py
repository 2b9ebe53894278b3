"""Run independent chunks of work in-process, in a local process pool, or on Dask.

Workspace checks, parameter studies and the benchmark matrix split their work into
chunks (of poses, of sweep points, of benchmark cells) that do not depend on each
other. An :class:`Executor` maps a function over those chunks and returns the
results *in the order of the chunks*, whichever machine computed them, so a run
on a cluster gives the same table as a run in this process.

Three executors are provided:

``"inprocess"`` (default)
    Chunks run one after the other in this process. Needs nothing.
``"processes"`` or ``"processes:N"``
    A :class:`concurrent.futures.ProcessPoolExecutor` with ``N`` workers (default:
    the number of CPUs).
``"dask"`` or ``"dask:ADDRESS"``
    A :class:`dask.distributed.Client` connected to the scheduler at ``ADDRESS``
    (``tcp://host:8786``); without an address, the ``DASK_SCHEDULER_ADDRESS``
    environment variable. Needs the optional extra ``pip install "tension-opt[dask]"``.

The functions given to :meth:`Executor.map` must be picklable (defined at module
level) for the process pool; Dask also sends closures. Every worker must be able to
import this package.
"""

from __future__ import annotations

import functools
import os
from abc import ABC, abstractmethod
from collections.abc import Callable, Iterator, Sequence
from typing import Any, TypeVar

import numpy as np

from tension_opt.errors import BackendNotAvailableError, InvalidInputError

__all__ = [
    "DASK_ADDRESS_VARIABLE",
    "DaskExecutor",
    "Executor",
    "InProcessExecutor",
    "ProcessPoolExecutor",
    "get_executor",
    "merge_chunks",
    "run_chunks",
]

T = TypeVar("T")
R = TypeVar("R")

DASK_ADDRESS_VARIABLE = "DASK_SCHEDULER_ADDRESS"
"""Environment variable read for the scheduler address when ``"dask"`` names none."""


class Executor(ABC):
    """Maps a function over chunks of work and yields the results in chunk order.

    Use as a context manager, or call :meth:`close`, to release workers and
    connections that the executor opened itself.
    """

    name: str = "executor"

    @property
    @abstractmethod
    def workers(self) -> int:
        """Number of chunks that can run at the same time."""

    @abstractmethod
    def map(self, fn: Callable[[T], R], chunks: Sequence[T]) -> Iterator[R]:
        """Apply ``fn`` to every chunk; yield the results in the order of ``chunks``.

        An exception raised by ``fn`` on a chunk is raised here when that chunk's
        result is reached; iterating further gives the following chunks' results.
        """

    def close(self) -> None:
        """Release what this executor opened (no-op by default)."""
        return None

    def __enter__(self) -> Executor:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"{type(self).__name__}(workers={self.workers})"


class _Ordered(Iterator[R]):
    """Results in chunk order, each fetched when reached.

    Unlike a generator it goes on after a chunk raised: the next item is the next
    chunk's result, so a caller can record a failure and carry on.
    """

    def __init__(self, fetchers: Sequence[Callable[[], R]]) -> None:
        self._fetchers = fetchers
        self._next = 0

    def __iter__(self) -> _Ordered[R]:
        return self

    def __next__(self) -> R:
        if self._next >= len(self._fetchers):
            raise StopIteration
        fetch = self._fetchers[self._next]
        self._next += 1
        return fetch()


class InProcessExecutor(Executor):
    """Runs the chunks one after the other in this process."""

    name = "inprocess"

    @property
    def workers(self) -> int:
        return 1

    def map(self, fn: Callable[[T], R], chunks: Sequence[T]) -> Iterator[R]:
        return _Ordered([functools.partial(fn, chunk) for chunk in chunks])


class ProcessPoolExecutor(Executor):
    """A local pool of worker processes (:class:`concurrent.futures.ProcessPoolExecutor`).

    Parameters
    ----------
    workers : int, optional
        Number of processes (default: ``os.cpu_count()``).
    """

    name = "processes"

    def __init__(self, workers: int | None = None) -> None:
        from concurrent.futures import ProcessPoolExecutor as _Pool

        count = workers if workers is not None else (os.cpu_count() or 1)
        if count < 1:
            raise InvalidInputError(f"a process pool needs at least 1 worker; got {workers}")
        self._workers = int(count)
        self._pool = _Pool(max_workers=self._workers)

    @property
    def workers(self) -> int:
        return self._workers

    def map(self, fn: Callable[[T], R], chunks: Sequence[T]) -> Iterator[R]:
        futures = [self._pool.submit(fn, chunk) for chunk in chunks]
        return _Ordered([f.result for f in futures])

    def close(self) -> None:
        self._pool.shutdown(wait=True, cancel_futures=True)


class DaskExecutor(Executor):
    """Chunks run as tasks on a Dask distributed cluster.

    Parameters
    ----------
    client : dask.distributed.Client or str, optional
        A connected client, or a scheduler address (``"tcp://host:8786"``). Default:
        the address in the ``DASK_SCHEDULER_ADDRESS`` environment variable.

    Raises
    ------
    BackendNotAvailableError
        If ``dask.distributed`` is not installed.
    InvalidInputError
        If no client or address is given and the environment names none.
    """

    name = "dask"

    def __init__(self, client: Any = None) -> None:
        try:
            from dask.distributed import Client
        except ImportError as exc:
            raise BackendNotAvailableError(
                'the Dask executor needs dask.distributed: pip install "tension-opt[dask]"'
            ) from exc
        self._own = not isinstance(client, Client)
        if isinstance(client, Client):
            self.client = client
        else:
            address = client or os.environ.get(DASK_ADDRESS_VARIABLE)
            if not address:
                raise InvalidInputError(
                    "the Dask executor needs a scheduler address: 'dask:tcp://host:8786' or "
                    f"the {DASK_ADDRESS_VARIABLE} environment variable"
                )
            self.client = Client(address)

    @property
    def workers(self) -> int:
        info = self.client.scheduler_info()
        return max(1, sum(int(w.get("nthreads", 1)) for w in info["workers"].values()))

    def map(self, fn: Callable[[T], R], chunks: Sequence[T]) -> Iterator[R]:
        # Chunks go to the workers as data, not inside the task graph (large chunks of
        # poses would bloat it); pure=False: identical chunks must each run.
        if not len(chunks):
            return iter(())
        data = self.client.scatter(list(chunks))
        futures = self.client.map(fn, data, pure=False)
        return _Ordered([f.result for f in futures])

    def close(self) -> None:
        if self._own:
            self.client.close()


def get_executor(spec: str | Executor | Any | None = None) -> Executor:
    """An executor from a name, a Dask client, or an executor (returned as is).

    Parameters
    ----------
    spec : str, Executor or dask.distributed.Client, optional
        ``None`` or ``"inprocess"``; ``"processes"`` or ``"processes:N"``; ``"dask"``
        (address from ``DASK_SCHEDULER_ADDRESS``) or ``"dask:tcp://host:port"``; a bare
        ``"tcp://host:port"`` also means Dask.

    Raises
    ------
    InvalidInputError
        For an unknown name or a bad worker count.
    """
    if spec is None:
        return InProcessExecutor()
    if isinstance(spec, Executor):
        return spec
    if not isinstance(spec, str):
        if _is_dask_client(spec):
            return DaskExecutor(spec)
        raise InvalidInputError(
            "executor must be None, a name ('inprocess', 'processes[:N]', 'dask[:ADDRESS]'), "
            f"an Executor or a dask.distributed.Client; got {type(spec).__name__}"
        )
    kind, _, arg = spec.partition(":")
    if kind in ("inprocess", "serial") and not arg:
        return InProcessExecutor()
    if kind == "processes":
        if arg and not arg.isdigit():
            raise InvalidInputError(f"'processes:N' needs a whole number of workers; got {spec!r}")
        return ProcessPoolExecutor(int(arg) if arg else None)
    if kind == "dask":
        return DaskExecutor(arg or None)
    if kind in ("tcp", "tls", "inproc", "ucx"):
        return DaskExecutor(spec)
    raise InvalidInputError(
        f"unknown executor {spec!r}; use 'inprocess', 'processes[:N]' or 'dask[:ADDRESS]'"
    )


def _is_dask_client(obj: object) -> bool:
    try:
        from dask.distributed import Client
    except ImportError:
        return False
    return isinstance(obj, Client)


def run_chunks(
    fn: Callable[[T], R],
    chunks: Sequence[T],
    executor: str | Executor | Any | None = None,
    progress: bool = False,
    description: str | None = None,
) -> list[R]:
    """Apply ``fn`` to every chunk through an executor; the results in chunk order.

    Parameters
    ----------
    fn : callable
        Picklable function of one chunk.
    chunks : sequence
        The chunks of work.
    executor : str, Executor or dask.distributed.Client, optional
        See :func:`get_executor`. An executor made here from a name is closed here;
        one passed in is left open.
    progress : bool
        Show a tqdm progress bar over the chunks.
    description : str, optional
        Label of the progress bar.

    Returns
    -------
    list
        ``[fn(c) for c in chunks]``, computed by the executor.
    """
    owned = not isinstance(executor, Executor) and (executor is None or isinstance(executor, str))
    runner = get_executor(executor)
    try:
        results = runner.map(fn, chunks)
        if progress:
            from tqdm import tqdm

            results = tqdm(results, total=len(chunks), desc=description, unit="chunk",
                           dynamic_ncols=True)
        return list(results)
    finally:
        if owned:
            runner.close()


def merge_chunks(parts: Sequence[dict[str, Any]], keys: Sequence[str]) -> dict[str, np.ndarray]:
    """Per-chunk arrays joined in chunk order, the inverse of cutting by
    :func:`~tension_opt.distribution.chunks.chunk_slices`.

    Parameters
    ----------
    parts : sequence of dict
        Results of :func:`run_chunks`, one per chunk, each holding arrays whose first
        axis runs over the chunk's items.
    keys : sequence of str
        The fields to join.

    Returns
    -------
    dict
        ``{key: numpy.concatenate([part[key] for part in parts])}``.
    """
    return {k: np.concatenate([p[k] for p in parts]) for k in keys}
