"""A fuzzed contract over the catenary solvers and the sag-aware inverse kinematics.

Every call of :func:`catenary.solve_forces` and :func:`catenary.solve_length` returns
(no hang; a watchdog besides hypothesis' deadline) and either raises
:class:`catenary.CatenaryError` naming the argument at fault, or reports per cable a
status whose word can be trusted: ``converged`` means finite forces whose catenary
(:func:`catenary.spans`) spans the chord to 1e-6 of its length and, for a prescribed
tension, meets it to 1e-6; ``slack`` a zero force; any other status NaN forces. No
RuntimeWarning leaks out. This must hold for ordinary data and for extreme but legal
data: tensions up to 1e300 N, spans and lengths from 1e-9 to 1e9 m (and beyond), any
positive finite weight per length and stiffness, and inextensible cables.

The few helpers this needs (:func:`watchdog`, :func:`keeps_contract`,
:func:`contract_settings`) are duplicated from ``tests/tension_opt/test_contract.py``
rather than shared: test modules do not import each other, and hypothesis settings are
applied when the module is imported, where a conftest fixture cannot provide them.

The examples are derandomised (the same on every run); ``TENSION_OPT_FUZZ=10`` runs ten
times as many, freshly drawn.
"""

from __future__ import annotations

import os
import signal
import threading
import warnings
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

import catenary
import tension_opt as to
from catenary.geometry import cable_data, cable_planes
from tension_opt.status import Status

# Kernels compile before the watchdog times any call (see tests/conftest.py).
pytestmark = pytest.mark.usefixtures("compiled_kernels")

#: Longest a single call may take (s) before the watchdog calls it a hang.
CALL_LIMIT = 2.0
PACKAGE_ERRORS = (to.TensionOptError, catenary.CatenaryError)
#: ``TENSION_OPT_FUZZ=10`` runs ten times the examples, freshly drawn.
DEPTH = float(os.environ.get("TENSION_OPT_FUZZ", "1"))
#: Shrinking retries a failing example many times: off for the extreme magnitudes.
NO_SHRINK = (Phase.explicit, Phase.generate)
STATUSES = {"converged", "slack", "infeasible", "indeterminate", "not_converged"}
CATENARY_NAMES = ("x", "z", "l0", "w", "ea", "tension", "end")


def contract_settings(examples: int) -> settings:
    """Deterministic settings (unless :data:`DEPTH` says otherwise) with a per-example
    deadline."""
    return settings(max_examples=int(examples * DEPTH), deadline=10_000,
                    derandomize=DEPTH == 1, database=None,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much,
                                           HealthCheck.data_too_large])


@contextmanager
def watchdog(seconds: float) -> Iterator[None]:
    """Raise TimeoutError in the main thread if the block runs longer than ``seconds``."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def expire(signum: int, frame: Any) -> None:
        raise TimeoutError(f"no return after {seconds} s")

    previous = signal.signal(signal.SIGALRM, expire)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def keeps_contract(call: Callable[[], Any], names: tuple[str, ...],
                   limit: float = CALL_LIMIT) -> Any:
    """``call()``, or None if it raised the package's error naming one of ``names``.

    Any other exception (a RuntimeWarning, a hang of more than ``limit`` s) propagates
    and fails the example.
    """
    try:
        with watchdog(limit), warnings.catch_warnings():
            warnings.simplefilter("error", RuntimeWarning)
            return call()
    except PACKAGE_ERRORS as error:
        text = str(error).lower()
        assert any(name.lower() in text for name in names), (
            f"{type(error).__name__} names none of {names}: {error}")
        return None


def test_the_watchdog_stops_a_call() -> None:
    import time

    with pytest.raises(TimeoutError), watchdog(0.2):
        time.sleep(1.0)


# ------------------------------------------------------------------- certificate
def _catenary_certified(result: Any, x: float, z: float, L0: Any, w: float, EA: float,
                        tension: float | None = None, end: str = "B") -> None:
    """The status is one of the documented ones and its word holds: where converged,
    finite forces whose catenary spans the chord (1e-6 of it) and, for a prescribed
    tension, meets it (1e-6 relative); where slack, no force; elsewhere NaN forces."""
    status = str(result.status)
    assert status in STATUSES, status
    H, V_A, V_B = float(result.H), float(result.V_A), float(result.V_B)
    if status == "slack":
        assert H == 0.0 and V_B == 0.0
        return
    if status != "converged":
        assert np.isnan(H) and np.isnan(V_B), f"{status} with forces {H}, {V_B}"
        return
    L0 = float(L0)
    assert np.isfinite([H, V_A, V_B, L0]).all(), f"converged with {H}, {V_A}, {V_B}, {L0}"
    assert H >= 0.0 and L0 > 0.0
    with np.errstate(all="ignore"):
        xs, zs = catenary.spans(H, V_B, L0, w, EA)
    chord = float(np.hypot(x, z))
    miss = float(np.hypot(xs - x, zs - z))
    assert miss <= 1e-6 * chord, f"converged spans miss the chord by {miss / chord:.3g} of it"
    if tension is not None:
        got = {"A": np.hypot(H, V_A), "B": np.hypot(H, V_B), "H": H}[end]
        assert abs(got - tension) <= 1e-6 * tension, f"end tension {got} != {tension}"


def _forces_case(x: float, z: float, L0: float, w: float, EA: float) -> None:
    result = keeps_contract(lambda: catenary.solve_forces(x, z, L0, w, EA), CATENARY_NAMES)
    if result is not None:
        _catenary_certified(result, x, z, L0, w, EA)


def _length_case(x: float, z: float, tension: float, w: float, EA: float, end: str) -> None:
    result = keeps_contract(lambda: catenary.solve_length(x, z, tension, w, EA, end),
                            CATENARY_NAMES)
    if result is not None:
        _catenary_certified(result, x, z, result.L0, w, EA, tension, end)


# --------------------------------------------------------------- ordinary magnitudes
ORDINARY = st.sampled_from([1e-3, 0.5, 1.0, 10.0, 1e3])
HEIGHTS = st.sampled_from([-10.0, -1.0, 0.0, 2.0, 1e3])
RATIOS = st.sampled_from([0.5, 0.999, 1.0, 1.001, 1.2, 3.0])


@contract_settings(300)
@given(x=ORDINARY, z=HEIGHTS, ratio=RATIOS, w=ORDINARY,
       EA=st.sampled_from([np.inf, 1e9, 1e6]))
def test_solve_forces_keeps_the_contract(x: float, z: float, ratio: float, w: float,
                                         EA: float) -> None:
    _forces_case(x, z, ratio * float(np.hypot(x, z)), w, EA)


@contract_settings(300)
@given(x=ORDINARY, z=HEIGHTS, tension=st.sampled_from([1e-3, 1.0, 1e3, 1e6, 1e12]),
       w=ORDINARY, EA=st.sampled_from([np.inf, 1e9, 1e6]),
       end=st.sampled_from(["A", "B", "H"]))
def test_solve_length_keeps_the_contract(x: float, z: float, tension: float, w: float,
                                         EA: float, end: str) -> None:
    _length_case(x, z, tension, w, EA, end)


# ---------------------------------------------------------------- extreme magnitudes
SPANS = st.sampled_from([0.0, 1e-9, 1e-3, 1.0, 1e3, 1e6, 1e9])
EXTREME_HEIGHTS = st.sampled_from([-1e9, -10.0, -1.0, 0.0, 2.0, 1e3, 1e9])
WEIGHTS = st.sampled_from([1e-300, 1e-9, 1e-3, 1.0, 1e3, 1e6, 1e9, 1e300])
STIFFNESSES = st.sampled_from([np.inf, 1e300, 1e9, 1e6, 1e3, 1.0, 1e-300])
EXTREME_RATIOS = st.sampled_from([1e-6, 0.5, 0.999, 1.0, 1.001, 1.2, 3.0, 1e3, 1e6])
TENSIONS = st.sampled_from([1e-300, 1e-6, 1.0, 1e6, 1e12, 1e100, 1e300])


@settings(contract_settings(400), phases=NO_SHRINK)
@given(x=SPANS, z=EXTREME_HEIGHTS, ratio=EXTREME_RATIOS, w=WEIGHTS, EA=STIFFNESSES)
def test_solve_forces_at_extreme_magnitudes(x: float, z: float, ratio: float, w: float,
                                            EA: float) -> None:
    chord = float(np.hypot(x, z))
    _forces_case(x, z, ratio * chord if chord > 0 else ratio, w, EA)


@settings(contract_settings(400), phases=NO_SHRINK)
@given(x=SPANS, z=EXTREME_HEIGHTS, tension=TENSIONS, w=WEIGHTS, EA=STIFFNESSES,
       end=st.sampled_from(["A", "B", "H"]))
def test_solve_length_at_extreme_magnitudes(x: float, z: float, tension: float, w: float,
                                            EA: float, end: str) -> None:
    _length_case(x, z, tension, w, EA, end)


def _power(low: float, high: float) -> st.SearchStrategy[float]:
    """``10**e`` with ``e`` uniform in ``[low, high]``."""
    return st.floats(low, high).map(lambda e: float(10.0**e))


SIGNED_HEIGHTS = st.one_of(st.just(0.0), _power(-9, 9), _power(-9, 9).map(lambda v: -v))


@settings(contract_settings(300), phases=NO_SHRINK)
@given(x=_power(-9, 9), z=SIGNED_HEIGHTS, L0=_power(-9, 9), w=_power(-300, 300),
       EA=st.one_of(st.just(np.inf), _power(-300, 300)))
def test_solve_forces_over_log_uniform_magnitudes(x: float, z: float, L0: float, w: float,
                                                  EA: float) -> None:
    _forces_case(x, z, L0, w, EA)


@settings(contract_settings(300), phases=NO_SHRINK)
@given(x=_power(-9, 9), z=SIGNED_HEIGHTS, tension=_power(-300, 300), w=_power(-300, 300),
       EA=st.one_of(st.just(np.inf), _power(-300, 300)), end=st.sampled_from(["A", "B", "H"]))
def test_solve_length_over_log_uniform_magnitudes(x: float, z: float, tension: float,
                                                  w: float, EA: float, end: str) -> None:
    _length_case(x, z, tension, w, EA, end)


#: Inputs on which the solvers once broke the contract, as (function, args), kept as
#: regressions (forces: x, z, L0, w, EA; length: x, z, tension, w, EA, end).
KNOWN_CATENARY = [
    # No return (the overflow in the fallback, then nested bracketed searches).
    ("length", (10.0, 2.0, 1e200, 20.0, 1e6, "B")),
    ("length", (10.0, 2.0, 1e100, 20.0, 1e6, "B")),
    # Status converged with vertical forces of -inf.
    ("forces", (10.0, 2.0, 1e300, 20.0, np.inf)),
    # Converged after 1181 iterations, 1.9e-5 m off a 10 m chord.
    ("forces", (1e-9, -10.0, 30.0, 1e9, 1.0)),
    # Converged with the end-A tension 3.6e-5 (relative) off the one prescribed.
    ("length", (1e-9, 1000.0, 1e-6, 1000.0, np.inf, "A")),
    # About 24 s to answer infeasible.
    ("length", (1000.0, -10.0, 1e-6, 1e9, 1000.0, "A")),
    # No return within 2 s.
    ("length", (1.0, 1000.0, 1.0, 1e9, 1000.0, "A")),
    ("forces", (1e6, 2.0, 3.0 * float(np.hypot(1e6, 2.0)), 1e9, 1000.0)),
    # Newton's fit, relative to the length, let a cable 2.5e16 chords long through
    # 7e-5 of the chord off; a heavily stretched one (L0 = 7e-4 chord) was refused.
    ("forces", (1e-9, 0.0, 25235325.723101225, 1e-3, 1.0)),
    ("forces", (1e9, 2.0, 683404.4285009323, 1e9, 1e6)),
    # Length fallback: a cable 1000 chords long given H (converged), and
    # near-vertical ones given a small end-A tension (infeasible).
    ("length", (332877886.8169483, -10.0, 1.0, 1e-3, 1000.0, "H")),
    ("length", (1e9, 2.0, 1e-6, 1e-9, 1e300, "H")),
    ("length", (230146.11585546803, -1.0, 1e-6, 1000.0, np.inf, "H")),
    # Weight or stiffness beyond the double range once scaled: not converged at once.
    ("length", (1000.0, -5.9243392731770985, 1.0, 1e300, 1e-300, "B")),
    ("forces", (1000.0, -29371.306368623496, 1e9, 1e300, np.inf)),
]


@pytest.mark.parametrize(("function", "args"), KNOWN_CATENARY)
def test_known_catenary_failures_keep_the_contract(function: str, args: tuple) -> None:
    if function == "forces":
        _forces_case(*args)
    else:
        _length_case(*args)


# ----------------------------------------------------------- sag inverse kinematics
IK_GARBAGE = ["abc", [[1.0, 2.0], [3.0]], None, [[np.nan, 1.0, 2.0]], np.zeros((2, 2, 2)),
              [np.inf], -1.0, [], object()]
IK_NAMES = ("pose", "model", "objective")


@st.composite
def ik_poses(draw: st.DrawFn, robot: to.CableRobot) -> Any:
    """Poses under the robot's drawing points (N from 0 to 4, some out of reach), or
    garbage one time in ten."""
    if draw(st.integers(0, 9)) == 0:
        return draw(st.sampled_from(IK_GARBAGE))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    N = draw(st.sampled_from([0, 1, 2, 3, 4]))
    low, high = robot.anchors.min(axis=0), robot.anchors.max(axis=0)
    spread = high - low
    poses = rng.uniform(low - 0.1 * spread, high + 0.1 * spread, (N, 3))
    poses[:, 2] = rng.uniform(low[2] - spread.max(), high[2], N)
    return poses[0] if N == 1 and draw(st.booleans()) else poses


@contract_settings(40)
@given(st.data())
def test_sag_inverse_kinematics_keeps_the_contract(data: st.DataObject) -> None:
    """A converged pose has every catenary certified; the coupled model is also in
    equilibrium, the thesis model need not be (it imposes straight-cable tensions)."""
    robot = to.presets.algae_harvester()
    poses = data.draw(ik_poses(robot))
    model = data.draw(st.sampled_from(["thesis", "coupled", "nope"]))
    objective = data.draw(st.sampled_from(["min_sum", "min_norm", "min_max"]))
    result = keeps_contract(lambda: catenary.inverse_kinematics(robot, poses, model,
                                                                objective), IK_NAMES,
                            limit=60.0)
    if result is None:
        return
    ok = result.status == Status.CONVERGED
    assert np.isfinite(result.lengths[ok]).all() and np.isfinite(result.tensions[ok]).all()
    if not ok.any():
        return
    planes = cable_planes(robot, robot.as_poses(poses)[ok])
    w, EA = cable_data(robot)
    H, L0 = result.horizontal_tensions[ok], result.lengths[ok]
    V_B = result.platform_forces[ok][..., 2] + w * L0
    xs, zs = catenary.spans(H, V_B, L0, w, EA)
    miss = np.hypot(xs - planes.x, zs - planes.z)
    assert (miss <= 1e-6 * planes.chord).all(), miss / planes.chord
    if model == "coupled":
        assert (result.equilibrium_residual[ok] <= 1e-6 * robot.weight).all()


def test_thesis_status_means_the_catenaries_converged(thesis: to.CableRobot,
                                                      snapshots: list[dict]) -> None:
    """Thesis model: the study's poses are converged with a force imbalance above 5 % of
    the load (by construction), each cable a certified catenary carrying the
    straight-line tension."""
    poses = np.array([s["pose"] for s in snapshots], dtype=float)
    result = catenary.inverse_kinematics(thesis, poses, model="thesis")
    straight = to.distribute(thesis, poses, "min_sum")
    assert (result.status == Status.CONVERGED).all()
    assert (result.equilibrium_residual > 0.05 * thesis.weight).all()
    np.testing.assert_allclose(result.tensions, straight.tensions, rtol=1e-9)
    planes = cable_planes(thesis, poses)
    w, EA = cable_data(thesis)
    V_B = result.platform_forces[..., 2] + w * result.lengths
    xs, zs = catenary.spans(result.horizontal_tensions, V_B, result.lengths, w, EA)
    np.testing.assert_allclose(xs, planes.x, rtol=0, atol=1e-9 * planes.chord.max())
    np.testing.assert_allclose(zs, planes.z, rtol=0, atol=1e-9 * planes.chord.max())
