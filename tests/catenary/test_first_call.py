"""The size rule of plain sag kinematics (tension_opt.kernels.launch.COMPILED_MIN, counted
in cables: poses times cables): smaller calls of the thesis model take the numpy
reference and compile nothing, with the kernels' statuses and their values to rounding."""

from __future__ import annotations

import textwrap
from collections.abc import Callable

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import catenary
import tension_opt as to
from tension_opt.kernels import launch

DEFAULT_MIN = 16  # the value in tension_opt.kernels.launch (the conftest sets 1)


def test_the_readme_example_compiles_nothing_in_a_fresh_process(
    fresh_process: Callable[[str], str],
) -> None:
    """With an empty kernel cache: distribute and the thesis model on the study robot's
    three poses (12 cables) and on one pose, the coupled model and the forward
    kinematics back from its lengths on one pose start no compilation."""
    script = textwrap.dedent("""
        import numpy as np
        import tension_opt as to
        import catenary
        robot = to.presets.algae_harvester()
        poses = [[0, 0, 0], [-29.4, 10.2, 1.5], [35, 22, 5]]
        to.distribute(robot, poses, "min_sum")
        sag = catenary.inverse_kinematics(robot, poses, model="thesis")
        one = catenary.inverse_kinematics(robot, poses[1], model="thesis")
        coupled = catenary.inverse_kinematics(robot, poses[1], model="coupled")
        back = catenary.forward_kinematics(robot, coupled.lengths, model="catenary")
        print("statuses:", sag.status.tolist(), one.status.tolist())
        print("coupled:", coupled.status.tolist(), back.status.tolist(),
              abs(back.poses - np.asarray(poses[1])).max() < 1e-6)
        print("compiled:", compiled)
    """)
    out = fresh_process(script)
    assert "compiled: []" in out, out[-3000:]
    assert "statuses: ['converged', 'converged', 'converged'] ['converged']" in out
    assert "coupled: ['converged'] ['converged'] True" in out, out


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), count=st.integers(1, DEFAULT_MIN // 4 - 1),
       objective=st.sampled_from(["min_sum", "min_norm", "min_max"]),
       one_pose=st.booleans())
def test_small_thesis_calls_answer_as_the_kernels(seed: int, count: int, objective: str,
                                                  one_pose: bool) -> None:
    robot = to.presets.algae_harvester()
    rng = np.random.default_rng(seed)
    poses = np.column_stack([rng.uniform(-45, 45, count), rng.uniform(-30, 30, count),
                             rng.uniform(-1, 8, count)])  # some beyond the workspace
    if one_pose:
        poses = poses[0]
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(launch, "COMPILED_MIN", DEFAULT_MIN)
        small = catenary.inverse_kinematics(robot, poses, "thesis", objective)
    kernels = catenary.inverse_kinematics(robot, poses, "thesis", objective, compiled=True)
    assert list(small.status) == list(kernels.status)
    solved = np.isfinite(kernels.lengths)
    assert (np.isfinite(small.lengths) == solved).all()
    np.testing.assert_allclose(small.lengths[solved], kernels.lengths[solved],
                               rtol=1e-11, atol=0)
    np.testing.assert_allclose(small.tensions[solved], kernels.tensions[solved],
                               rtol=1e-9, atol=0)
