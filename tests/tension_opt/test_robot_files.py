"""Robot description files: bit-for-bit round trips, the preset files, validation
messages (field path, line, fix) and the command line."""

from __future__ import annotations

import math
import re
import subprocess
import sys
import tracemalloc
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

import tension_opt as to
from tension_opt.cli import main
from tension_opt.kinds import KINDS
from tension_opt.robot import files as robot_files
from tension_opt.robot.formats import parse_text
from tension_opt.robot.presets import PUBLISHED, algae_harvester_from_parameters

ROOT = Path(__file__).resolve().parents[2]
PRESETS = {"algae_harvester": to.presets.algae_harvester, **PUBLISHED}
ARRAYS = ("anchors", "attachments", "com", "t_min", "t_max", "inertia", "home")
SCALARS = ("mass", "g", "kind", "name", "cable")


def assert_same_robot(a: to.CableRobot, b: to.CableRobot) -> None:
    """Every array equal bit for bit (same dtype, shape and bytes), every scalar == and
    every float the same bit for bit (-0.0 is not 0.0)."""
    for field in ARRAYS:
        x, y = getattr(a, field), getattr(b, field)
        assert (x is None) == (y is None), field
        if x is not None:
            assert np.array_equal(x, y), field
            assert x.dtype == y.dtype and x.shape == y.shape and x.tobytes() == y.tobytes(), field
    for field in SCALARS:
        x, y = getattr(a, field), getattr(b, field)
        assert x == y and repr(x) == repr(y), field
    if a.cable is not None:
        for field in ("diameter", "linear_mass", "EA"):
            x, y = getattr(a.cable, field), getattr(b.cable, field)
            assert repr(float(x)) == repr(float(y)), f"cable.{field}"


# ------------------------------------------------------------------ round trips
@pytest.mark.parametrize("suffix", [".yaml", ".yml", ".json"])
@pytest.mark.parametrize("name", sorted(PRESETS))
def test_every_preset_round_trips_bit_for_bit(name: str, suffix: str, tmp_path: Path) -> None:
    robot = PRESETS[name]()
    path = tmp_path / f"{name}{suffix}"
    robot.to_file(path)
    assert_same_robot(to.CableRobot.from_file(path), robot)
    # and a second trip writes the same text
    again = tmp_path / f"again{suffix}"
    to.CableRobot.from_file(path).to_file(again)
    assert again.read_text() == path.read_text()


_TINY_HUGE = [5e-324, 2.2250738585072014e-308, 1e-300, 1e300, 1.7976931348623157e308]
# within the reach of a robot's points (1e6 m); includes -0.0, 5e-324, 0.1 + 0.2...
_coordinate = st.one_of(st.floats(-1e6, 1e6, allow_nan=False), st.sampled_from(
    [-0.0, 5e-324, -5e-324, 2.2250738585072014e-308, 1e6, -1e6, 0.1 + 0.2]))


def _positive(low: float, high: float) -> st.SearchStrategy[float]:
    return st.one_of(st.floats(low, high), st.sampled_from(_TINY_HUGE))


def _non_negative(high: float) -> st.SearchStrategy[float]:
    return st.one_of(st.floats(0.0, high), st.sampled_from([-0.0, 0.0, *_TINY_HUGE]))


# Names a YAML or JSON writer could get wrong: YAML 1.1 and 1.2 words and numbers,
# quotes, indicators, spaces at either end, line breaks, control and unicode characters.
NAMES = [
    "", " ", "   ", "yes", "no", "on", "off", "y", "n", "Yes", "NO", "true", "False",
    "null", "Null", "~", "1e3", "1E3", ".5", "5.", "010", "0o10", "0x10", "0b10", "1_000",
    "1:30", "-0.0", "+1", "2001-12-14", ".inf", "-.inf", ".nan", "inf", "nan", "  leading",
    "trailing  ", " both ", "'single'", '"double"', "it's", 'say "hi"', "#comment",
    "a # b", "a: b", "a:b", "- item", "-", "[1, 2]", "{a: 1}", "&anchor", "*alias", "!tag",
    "!!str x", "%directive", "@at", "`tick", "|", ">", "?", ",", "<<", "=", "---", "...",
    "tab\there", "\t", "line\nbreak", "two\n\nbreaks", "trailing\n", "\nleading",
    "\r\n", "cr\r", "nul\x00", "bell\x07", "del\x7f", "nel\x85", "ls\u2028ps\u2029",
    "bom\ufeff", "\ufffe\uffff", "nbsp\xa0", "é中文🙂", "\U0010ffff", "word " * 30,
    "x" * 200, "a  b  " * 20, "a \n b", "back\\slash",
]


@st.composite
def robots(draw: st.DrawFn) -> to.CableRobot:
    kind = draw(st.sampled_from(sorted(KINDS)))
    m = draw(st.integers(1, 9))
    points = st.lists(st.lists(_coordinate, min_size=3, max_size=3), min_size=m, max_size=m)
    t_min = draw(st.one_of(_non_negative(1e4), st.lists(_non_negative(1e4), min_size=m,
                                                        max_size=m)))
    slack = draw(st.one_of(st.just(math.inf), st.floats(0, 1e4), st.just(1e308)))
    cable = draw(st.one_of(st.none(), st.builds(
        to.CableProperties, _positive(1e-6, 1.0), _non_negative(100.0),
        st.one_of(st.just(math.inf), _positive(1e-3, 1e12)))))
    inertia = draw(st.one_of(st.none(), st.lists(_non_negative(1e3), min_size=3,
                                                 max_size=3).map(np.diag)))
    pattern = KINDS[kind]
    home = draw(st.one_of(st.none(), st.lists(_coordinate, min_size=pattern.pose_size,
                                              max_size=pattern.pose_size)))
    with np.errstate(over="ignore"):  # a t_max beyond the float range is inf
        t_max = np.asarray(t_min) + slack
    try:
        return to.CableRobot(
            anchors=np.array(draw(points)), attachments=np.array(draw(points)),
            mass=draw(_positive(1e-6, 1e6)), kind=kind, com=draw(st.lists(
                _coordinate, min_size=3, max_size=3)), g=draw(_non_negative(100.0)),
            t_min=t_min, t_max=t_max, cable=cable, home=home,
            name=draw(st.one_of(st.sampled_from(NAMES), st.text(max_size=20))),
            inertia=inertia)
    except to.InvalidInputError:  # coinciding anchors, an empty name, a weight overflowing
        assume(False)
        raise


@settings(max_examples=150, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(robot=robots(), suffix=st.sampled_from([".yaml", ".json"]))
def test_any_robot_round_trips_bit_for_bit(robot: to.CableRobot, suffix: str,
                                           tmp_path: Path) -> None:
    path = tmp_path / f"robot{suffix}"
    robot.to_file(path)
    assert_same_robot(to.CableRobot.from_file(path), robot)


@pytest.mark.parametrize("suffix", [".yaml", ".json"])
@pytest.mark.parametrize("name", NAMES)
def test_every_name_a_robot_takes_round_trips(name: str, suffix: str, tmp_path: Path) -> None:
    """A robot named "" was written by to_file and refused by from_file."""
    anchors = [[0.0, 0.0, 3.0], [2.0, 0.0, 3.0], [0.0, 2.0, 3.0]]
    if name == "":
        with pytest.raises(to.InvalidInputError, match=r"^name must be non-empty text"):
            _point_robot(anchors, name=name)
        return
    robot = _point_robot(anchors, name=name)
    path = tmp_path / f"robot{suffix}"
    robot.to_file(path)
    back = to.CableRobot.from_file(path)
    assert type(back.name) is str and back.name == name
    assert_same_robot(back, robot)


def test_huge_finite_numbers_round_trip_or_are_refused(tmp_path: Path) -> None:
    """An inertia entry near the float range's end was stored as inf (its symmetrised
    sum overflowed), and so was a box inertia beyond the range: to_file wrote .inf,
    which from_file refuses."""
    anchors = [[0.0, 0.0, 3.0], [2.0, 0.0, 3.0]]
    huge = 1.7976931348623157e308
    robot = _point_robot(anchors, inertia=np.diag([huge, 5e-324, -0.0]), mass=huge, g=0.0,
                         t_min=huge, cable=to.CableProperties(5e-324, huge, huge))
    assert robot.inertia.diagonal().tolist() == [huge, 5e-324, -0.0]
    for suffix in (".yaml", ".json"):
        path = tmp_path / f"huge{suffix}"
        robot.to_file(path)
        assert_same_robot(to.CableRobot.from_file(path), robot)
    with pytest.raises(to.InvalidInputError, match=r"box_inertia .*give the inertia"):
        _point_robot(anchors, attachments=[[0.0, 0.0, 0.0], [1e6, 1e6, 0.0]], mass=1e300)


def test_a_document_sharing_a_list_is_written_out(tmp_path: Path) -> None:
    """One list object used twice was written as a YAML alias, which the reader refuses."""
    document = robot_files.robot_document(to.presets.point_xz_4cable())
    point = [0.0, 0.0, 0.0]
    document["attachments"] = [point] * len(document["anchors"])
    path = tmp_path / "shared.yaml"
    robot_files.write_document(path, document)
    assert "*" not in path.read_text()
    assert to.CableRobot.from_file(path).attachments.tolist() == document["attachments"]


@pytest.mark.parametrize("name", ["", 5, None, b"robot", "lone \ud800 surrogate"])
def test_a_name_no_file_can_hold_is_refused_by_the_robot(name: object) -> None:
    """Each was taken by CableRobot; to_file wrote "" (refused by from_file), "5" and
    "None" (read back as other names), and failed on the surrogate with UnicodeEncodeError."""
    with pytest.raises(to.InvalidInputError, match=r"^name must be non-empty text"):
        _point_robot([[0.0, 0.0, 3.0], [2.0, 0.0, 3.0]], name=name)


# ------------------------------------------------------------------ preset files
def test_the_study_file_is_the_parametric_robot_at_the_defaults() -> None:
    assert_same_robot(to.presets.algae_harvester(), algae_harvester_from_parameters())
    robot = to.presets.algae_harvester()
    assert robot.t_min[0] == 258.6 * 9.81
    assert robot.cable == to.CableProperties.from_density(0.020, 7860.0)


def test_preset_files_hold_the_published_numbers() -> None:
    cogiro = to.presets.cogiro()
    assert cogiro.anchors[0].tolist() == [-7.1775, -5.4361, 5.3911]
    assert cogiro.attachments[6].tolist() == [0.5021, 0.275, -0.0007]
    assert (cogiro.mass, cogiro.com.tolist()) == (91.058, [-0.034, -0.013, 0.264])
    # CoGiRo's inertia about its centre of mass (CASPR, ref="com"), not the box default
    assert cogiro.inertia.tolist() == [[36.598, -0.453, 3.012], [-0.453, 35.982, -1.539],
                                       [3.012, -1.539, 25.439]]
    assert cogiro.cable == to.CableProperties(0.004, 0.064, 8.2051e-6 * 100e9)
    assert (cogiro.t_min == 100.0).all() and (cogiro.t_max == 5000.0).all()
    ipanema = to.presets.ipanema3()
    assert ipanema.cable == to.CableProperties.from_density(0.006, 980.0)
    assert ipanema.inertia.tolist() == np.diag([5.226154, 0.637352, 4.723802]).tolist()
    assert ipanema.attachments[0].tolist() == [-0.07, 0.648, -0.26]
    kntu = to.presets.kntu_planar()
    assert (kntu.g, kntu.t_min[0], kntu.t_max[0], kntu.inertia[2, 2]) == (0.0, 0.001, 60.0, 0.1)
    point = to.presets.point_xz_4cable()
    assert point.anchors.tolist() == [[0.5, 0, 0.5], [-0.5, 0, 0.5], [-0.5, 0, -0.5],
                                      [0.5, 0, -0.5]]


def test_material_labels_are_the_catalogue_names() -> None:
    from catenary.materials import material_names

    assert sorted(robot_files.MATERIAL_NAMES) == sorted(material_names(aliases=True))


# ------------------------------------------------------------------ validation
GOOD = ROOT / "tension_opt" / "robot" / "data" / "cogiro.yaml"


def _line_of(text: str, start: str, nth: int = 1) -> int:
    """1-based number of the ``nth`` line of ``text`` starting with ``start``."""
    found = [i for i, line in enumerate(text.splitlines(), 1) if line.startswith(start)]
    return found[nth - 1]


def _bad_file(tmp_path: Path, old: str, new: str) -> tuple[Path, str]:
    text = GOOD.read_text()
    assert old in text
    bad = text.replace(old, new, 1)
    path = tmp_path / "bad.yaml"
    path.write_text(bad)
    return path, bad


# (text to change, its replacement, field path, start of its line (or (start, nth); None:
# no line), a pattern of the message and its fix)
CASES = {
    "missing field": ("mass: 91.058\n", "", "mass", None, r"add it: Platform mass \(kg\)"),
    "wrong type": ("mass: 91.058", "mass: heavy", "mass", "mass:",
                   r"valid number \(got 'heavy'\); expected: Platform mass \(kg\), > 0"),
    "negative mass": ("mass: 91.058", "mass: -91.058", "mass", "mass:",
                      r"greater than 0 .*Platform mass \(kg\), > 0"),
    "unknown material": ("material: steel", "material: stele", "cable.material", "cable:",
                         "unknown cable material 'stele': use one of steel"),
    "attachments count": ("- [-0.5045, -0.3463, 0.9976]\n", "", "attachments",
                          "attachments:", "has 7 points but anchors has 8: give one"),
    "short row": ("- [7.1608, -5.5342, 5.3973]", "- [7.1608, -5.5342]", "anchors[7]",
                  "- [7.1608", r"at least 3 items.*one \[x, y, z\] per cable \(m\)"),
    "unknown kind": ("kind: spatial6", "kind: hexapod", "kind", "kind:",
                     "unknown kind 'hexapod': use one of point3, planar_point2"),
    "non-symmetric inertia": ("- [3.012, -1.539, 25.439]", "- [3.1, -1.539, 25.439]",
                              "inertia", "inertia:", "must be symmetric"),
    "unknown field": ("g: 9.81\n", "g: 9.81\ncolour: red\n", "colour", "colour:",
                      "unknown field; remove it or correct its spelling"),
    "negative bound": ("t_min: 100.0", "t_min: -100.0", "t_min", "t_min:",
                       "cables can only pull"),
    "bounds crossed": ("t_min: 100.0", "t_min: 6000.0", "t_min", "t_min:",
                       "exceeds t_max = 5000.0; lower t_min or raise t_max"),
    "home size": ("home: [0.0, 0.0, 2.0, 0.0, 0.0, 0.0]", "home: [0.0, 0.0, 2.0]", "home",
                  "home:", r"a spatial6 pose has 6: \(x, y, z, rx, ry, rz\)"),
    "units": ("length: m,", "length: mm,", "units.length", "units:", "metres"),
    "EA": ("EA: 820510.0", "EA: -1.0", "cable.EA", "cable:", r"Axial stiffness \(N\)"),
    "EA text": ("EA: 820510.0", "EA: stiff", "cable.EA", "cable:", 'number or "inf"'),
    "material only": ("linear_mass: 0.064, ", "", "cable", "cable:",
                      r"give exactly one of linear_mass .*the file gives neither "
                      r"\(material 'steel' is a label"),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_a_bad_file_names_the_field_its_line_and_the_fix(case: str, tmp_path: Path) -> None:
    old, new, field, line_start, fix = CASES[case]
    path, text = _bad_file(tmp_path, old, new)
    with pytest.raises(to.RobotFileError) as caught:
        to.CableRobot.from_file(path)
    error = caught.value
    assert isinstance(error, to.InvalidInputError) and isinstance(error, to.TensionOptError)
    assert str(path) in str(error) and error.path == str(path)
    fields = {problem[0]: problem for problem in error.problems}
    assert field in fields, error.problems
    _, line, message = fields[field]
    if line_start is None:
        assert line == 0 and f"  {field}: " in str(error)
    else:
        start, nth = line_start if isinstance(line_start, tuple) else (line_start, 1)
        assert line == _line_of(text, start, nth)
        assert f"line {line}: {field}: " in str(error)
    assert re.search(fix, message), message


def test_a_bad_json_file_names_the_field_and_its_line(tmp_path: Path) -> None:
    path = tmp_path / "robot.json"
    to.presets.kntu_planar().to_file(path)
    text = path.read_text().replace('"planar3"', '"planar4"')
    path.write_text(text)
    with pytest.raises(to.RobotFileError, match="unknown kind 'planar4'") as caught:
        to.CableRobot.from_file(path)
    (field, line, _), = caught.value.problems
    assert (field, line) == ("kind", _line_of(text, '  "kind"'))


@pytest.mark.parametrize(("text", "message"), [
    ("name: a\nname: b\n", "line 2: .*duplicate key 'name'"),
    ("name: a\nanchors: [[0, 0, 1]\n", "line 3: .*expected ','"),
    ("- 1\n- 2\n", "one mapping of fields"),
    ("", "one mapping of fields"),
])
def test_unreadable_yaml_is_a_file_error_with_its_line(text: str, message: str,
                                                       tmp_path: Path) -> None:
    path = tmp_path / "robot.yaml"
    path.write_text(text)
    with pytest.raises(to.RobotFileError, match=message):
        to.CableRobot.from_file(path)


def test_aliases_and_deep_nesting_are_file_errors_at_once(tmp_path: Path) -> None:
    """A few lines of aliases of aliases stand for 10^9 values (reading them took
    minutes and gigabytes): refused at the first alias; nesting beyond the parsers'
    depth is a file error, not a RecursionError."""
    lines = ["kind: point3", "mass: 1.0", "a0: &a0 [x, x, x, x, x, x, x, x, x, x]"]
    lines += [f"a{i}: &a{i} [" + ", ".join([f"*a{i - 1}"] * 10) + "]" for i in range(1, 9)]
    path = tmp_path / "bomb.yaml"
    path.write_text("\n".join([*lines, "notes: *a8"]) + "\n")
    with pytest.raises(to.RobotFileError, match=r"line 4: .*alias \*a0 is not allowed"):
        to.CableRobot.from_file(path)
    for suffix, text in ((".json", "[" * 100_000 + "]" * 100_000),
                         (".yaml", "a: " + "[" * 100_000 + "]" * 100_000)):
        deep = tmp_path / f"deep{suffix}"
        deep.write_text(text)
        with pytest.raises(to.RobotFileError, match="nest"):
            to.CableRobot.from_file(deep)


def test_unknown_suffix_missing_file_and_unregistered_kind_are_file_errors(
        tmp_path: Path) -> None:
    with pytest.raises(to.RobotFileError, match=r"suffix '\.txt'.*\.yaml, \.yml or \.json"):
        to.CableRobot.from_file(tmp_path / "robot.txt")
    with pytest.raises(to.RobotFileError, match="cannot be read"):
        to.CableRobot.from_file(tmp_path / "absent.yaml")
    from tension_opt.kinds import MotionPattern

    class Yz(MotionPattern):
        name, coordinates, positions, position_axes, wrench_rows = (
            "yz", ("y", "z"), (0, 1), (1, 2), (1, 2))

    robot = to.CableRobot(anchors=np.eye(3), attachments=np.zeros((3, 3)), mass=1.0,
                          kind=Yz())
    with pytest.raises(to.RobotFileError, match="kind 'yz' is not in"):
        robot.to_file(tmp_path / "yz.yaml")


def test_a_minimal_file_takes_the_documented_defaults(tmp_path: Path) -> None:
    path = tmp_path / "minimal.yaml"
    path.write_text("name: tripod\nkind: point3\nunits: {length: m, mass: kg, force: N}\n"
                    "anchors: [[0, 0, 3], [2, 0, 3], [0, 2, 3]]\n"
                    "attachments: [[0, 0, 0], [0, 0, 0], [0, 0, 0]]\nmass: 1e1\n")
    robot = to.CableRobot.from_file(path)
    assert (robot.mass, robot.g, robot.kind, robot.cable, robot.home) == (
        10.0, 9.81, "point3", None, None)
    assert robot.t_min.tolist() == [0.0] * 3 and robot.t_max.tolist() == [math.inf] * 3
    assert robot.com.tolist() == [0.0] * 3 and not robot.inertia.any()  # a point: no box


def test_density_and_inf_words_read_as_the_robot_api_makes_them(tmp_path: Path) -> None:
    path = tmp_path / "robot.json"
    path.write_text('{"name": "r", "kind": "point3", "units": {"length": "m", "mass": "kg",'
                    ' "force": "N"}, "anchors": [[0, 0, 3], [2, 0, 3], [0, 2, 3]],\n'
                    '"attachments": [[0, 0, 0], [0, 0, 0], [0, 0, 0]], "mass": 2,\n'
                    '"t_max": [5, "inf", "Infinity"],\n'
                    '"cable": {"diameter": 0.02, "density": 7860, "EA": "inf"}}\n')
    robot = to.CableRobot.from_file(path)
    assert robot.cable == to.CableProperties.from_density(0.02, 7860.0)
    assert robot.t_max.tolist() == [5.0, math.inf, math.inf]


def test_the_documented_example_is_a_valid_file(tmp_path: Path) -> None:
    text = (ROOT / "docs" / "robot_files.md").read_text()
    path = tmp_path / "example.yaml"
    path.write_text(re.search(r"```yaml\n(.*?)```", text, re.S).group(1))
    robot = to.CableRobot.from_file(path)
    assert (robot.m, robot.dof, robot.cable.EA, robot.home[2]) == (8, 6, 820510.0, 1.5)
    assert to.distribute(robot, robot.home).success.all()


# ------------------------------------------------------------------ command line
def test_check_summarises_a_valid_file(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["check", str(GOOD)]) == 0
    out = capsys.readouterr().out
    margin = float(to.capacity_margin(to.presets.cogiro(), [0, 0, 2.0, 0, 0, 0])[0])
    for expected in ("name:            CoGiRo", "kind:            spatial6", "cables:          8",
                     "DOF:             6", "mass:            91.058 kg",
                     "feasible at home: yes", f"capacity margin at home: {margin:.6g} N"):
        assert expected in out


def test_check_of_a_bad_file_exits_2_with_the_message(tmp_path: Path,
                                                      capsys: pytest.CaptureFixture[str]
                                                      ) -> None:
    path, _ = _bad_file(tmp_path, "mass: 91.058", "mass: -1")
    assert main(["check", str(path)]) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and "mass: input should be greater than 0" in captured.err
    # a valid file whose home puts the point mass on a drawing point
    study = to.presets.algae_harvester()
    path = tmp_path / "on_anchor.yaml"
    study.with_(home=study.anchors[0]).to_file(path)
    assert main(["check", str(path)]) == 2
    assert "home pose cannot be evaluated" in capsys.readouterr().err


def test_python_dash_m_tension_opt_robot_check(tmp_path: Path) -> None:
    good = subprocess.run([sys.executable, "-m", "tension_opt", "check", str(GOOD)],
                          capture_output=True, text=True, timeout=120)
    assert good.returncode == 0, good.stderr
    assert "cables:          8" in good.stdout and good.stderr == ""
    path, _ = _bad_file(tmp_path, "kind: spatial6", "kind: hexapod")
    bad = subprocess.run([sys.executable, "-m", "tension_opt", "check", str(path)],
                         capture_output=True, text=True, timeout=120)
    assert bad.returncode == 2 and "kind: unknown kind 'hexapod'" in bad.stderr


# ------------------------------------------------------------------ YAML 1.2 scalars
# A plain scalar and its value under the YAML 1.2 core schema. The second half are text in
# YAML 1.2 but numbers, booleans or dates in YAML 1.1 (PyYAML's default): 010 was 8,
# 1:30 was 90, 1_000 was 1000, yes was True, 2001-12-14 a date.
YAML_12 = {
    "010": 10, "0100": 100, "-010": -10, "+7": 7, "0": 0, "0o10": 8, "0x10": 16,
    "0xFf": 255, ".5": 0.5, "-.5": -0.5, "1e3": 1000.0, "1.": 1.0, "-0.0": -0.0,
    "1E-3": 0.001, "5e-324": 5e-324, ".inf": math.inf, "-.Inf": -math.inf,
    "+.INF": math.inf, ".NaN": math.nan, "true": True, "True": True, "FALSE": False,
    "null": None, "~": None, "": None,
    "1:30": "1:30", "1:30.5": "1:30.5", "1_000": "1_000", "1_000.5": "1_000.5",
    "0b10": "0b10", "-0x10": "-0x10", "0o8": "0o8", "0x": "0x", "1e": "1e", ".": ".",
    "yes": "yes", "no": "no", "on": "on", "off": "off", "y": "y", "Yes": "Yes",
    "tRUE": "tRUE", "2001-12-14": "2001-12-14", "inf": "inf", "nan": "nan", "=": "=",
    "<<": "<<",
}


@pytest.mark.parametrize("text", sorted(YAML_12))
def test_yaml_plain_scalars_follow_the_yaml_1_2_core_schema(text: str) -> None:
    got = parse_text(Path("robot.yaml"), f"v: {text}\n")["v"]
    expected = YAML_12[text]
    assert (type(got), repr(got)) == (type(expected), repr(expected))


@pytest.mark.parametrize(("old", "new", "field", "value"), [
    ("mass: 91.058", "mass: 010", "mass", 10.0),  # YAML 1.1: octal 8 kg
    ("t_max: 5000.0", "t_max: 0100", "t_max", 100.0),  # YAML 1.1: 64 N
    ("mass: 91.058", "mass: 0o10", "mass", 8.0),
    ("mass: 91.058", "mass: 0x10", "mass", 16.0),
    ("mass: 91.058", "mass: .5", "mass", 0.5),
    ("mass: 91.058", "mass: 1e3", "mass", 1000.0),
    ("name: CoGiRo", "name: yes", "name", "yes"),  # YAML 1.1: True, refused as a name
    ("name: CoGiRo", "name: on", "name", "on"),
    ("name: CoGiRo", "name: 1:30", "name", "1:30"),
])
def test_robot_file_numbers_are_yaml_1_2(old: str, new: str, field: str, value: object,
                                        tmp_path: Path) -> None:
    path, _ = _bad_file(tmp_path, old, new)
    got = getattr(to.CableRobot.from_file(path), field)
    assert (got if isinstance(got, str | float) else got.tolist()[0]) == value


@pytest.mark.parametrize(("new", "shown"), [
    ("mass: 1:30", "'1:30'"),  # YAML 1.1: 90 kg (base 60)
    ("mass: 1_000", "'1_000'"), ("mass: 0b10", "'0b10'"), ("mass: yes", "'yes'"),
    ("mass: 1:30.5", "'1:30.5'"),
])
def test_yaml_1_1_only_numbers_are_text_refused_where_a_number_is_needed(
        new: str, shown: str, tmp_path: Path) -> None:
    path, _ = _bad_file(tmp_path, "mass: 91.058", new)
    with pytest.raises(to.RobotFileError,
                       match=rf"mass: input should be a valid number \(got {shown}\)"):
        to.CableRobot.from_file(path)


def test_true_is_a_boolean_and_refused_as_a_name(tmp_path: Path) -> None:
    path, _ = _bad_file(tmp_path, "name: CoGiRo", "name: true")
    with pytest.raises(to.RobotFileError, match=r"name: input should be a valid string"):
        to.CableRobot.from_file(path)


# ------------------------------------------------------------------ anchors: memory, pairs, reach
def _many_cables(m: int) -> to.CableRobot:
    rng = np.random.default_rng(1)
    return to.CableRobot(anchors=rng.uniform(-50, 50, (m, 3)),
                         attachments=rng.uniform(-0.5, 0.5, (m, 3)), mass=10.0)


def _traced_peak(call: Callable[[], object]) -> int:
    tracemalloc.start()
    try:
        call()
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


@pytest.mark.parametrize(("suffix", "per_cable"), [(".json", 1500), (".yaml", 8000)])
def test_reading_a_large_file_takes_memory_linear_in_its_cables(suffix: str, per_cable: int,
                                                                tmp_path: Path) -> None:
    """The coincident-anchor checks built m x m x 3 arrays: reading 3000 cables peaked at
    578 MB, 8000 at 4.1 GB. Now the parsed text dominates: about 800 bytes a cable from
    JSON, 4.5 kB from YAML; the robot itself about 140."""
    m = 3000
    path = tmp_path / f"large{suffix}"
    robot = _many_cables(m)
    robot.to_file(path)
    peak = _traced_peak(lambda: to.CableRobot.from_file(path))
    assert peak < per_cable * m, f"{peak / 1e6:.1f} MB"
    peak = _traced_peak(lambda: robot.with_(mass=2.0))
    assert peak < 400 * m, f"{peak / 1e6:.1f} MB"


def _point_robot(anchors: list[list[float]], **changes: object) -> to.CableRobot:
    arguments: dict[str, object] = {"anchors": np.array(anchors, dtype=float),
                                    "attachments": np.zeros((len(anchors), 3)), "mass": 1.0}
    return to.CableRobot(**{**arguments, **changes})


def _point_file(tmp_path: Path, anchors: list[list[float]],
                extra: str = "") -> tuple[Path, str]:
    rows = "".join(f"- {[float(v) for v in a]}\n" for a in anchors)
    text = ("name: r\nkind: point3\nunits: {length: m, mass: kg, force: N}\n"
            f"anchors:\n{rows}attachments:\n" + "- [0, 0, 0]\n" * len(anchors)
            + f"mass: 1.0\n{extra}")
    path = tmp_path / "r.yaml"
    path.write_text(text)
    return path, text


# Anchors and the pair that coincides (None: none does): within 1e-9 of the pair's own
# largest coordinate, and within 1e-9 m near the origin. Cables may share a drawing point
# (NIST RoboCrane): the robot and its file are valid either way, and the summary of
# ``python -m tension_opt check`` names the pair.
PAIRS = {
    "exact": ([[1.0, 2.0, 3.0], [0.0, 0.0, 1.0], [1.0, 2.0, 3.0]], (0, 2)),
    "floor": ([[0.0, 0.0, 0.0], [1e-10, 0.0, 0.0], [1.0, 1.0, 1.0]], (0, 1)),
    "above the floor": ([[0.0, 0.0, 0.0], [1e-8, 0.0, 0.0], [1.0, 1.0, 1.0]], None),
    "far pair": ([[1e5, 0.0, 0.0], [1e5, 5e-5, 0.0], [0.0, 0.0, 1.0]], (0, 1)),
    "far, apart": ([[1e5, 0.0, 0.0], [1e5, 2e-4, 0.0], [0.0, 0.0, 1.0]], None),
    # one far anchor made the whole robot's tolerance 1 mm: 0 and 1 "coincided"
    "far anchor": ([[0.0, 0.0, 0.0], [5e-4, 0.0, 0.0], [1e6, 0.0, 1.0], [-1.0, 2.0, 3.0]],
                   None),
    # ... and the message named 0 and 1, 0.5 mm apart, not 2 and 3
    "the right pair": ([[0.0, 0.0, 0.0], [5e-4, 0.0, 0.0], [1e6, 0.0, 1.0],
                        [1e6, 0.0, 1.0001]], (2, 3)),
}


@pytest.mark.parametrize("case", sorted(PAIRS))
def test_shared_anchors_are_valid_and_named_within_a_tolerance_of_their_own_size(
        case: str, tmp_path: Path) -> None:
    from tension_opt.checks import coincident_pair
    from tension_opt.cli import summary

    anchors, pair = PAIRS[case]
    path, _ = _point_file(tmp_path, anchors)
    assert coincident_pair(np.array(anchors)) == pair
    assert _point_robot(anchors).m == len(anchors)
    robot = to.CableRobot.from_file(path)
    assert robot.anchors.tolist() == anchors
    named = [line for line in summary(robot).splitlines() if line.startswith("shared")]
    assert named == ([] if pair is None else
                     [f"shared anchors:  cables {pair[0]} and {pair[1]} leave one drawing point"])


_BASES = [(0.0, 0.0, 0.0), (1e-3, 0.0, 0.0), (1.0, 0.0, 2.0), (1e3, -1.0, 2.0),
           (9e5, 1.0, 0.0), (-5e5, 3e5, 7.0)]
_DIRECTIONS = [(1.0, 0.0, 0.0), (0.0, -1.0, 0.0), (0.6, 0.0, 0.8), (-0.5, 0.5, 0.5)]


@settings(max_examples=300, deadline=None)
@given(points=st.lists(st.tuples(st.sampled_from(_BASES), st.sampled_from(
    [0.0, 1e-11, 3e-10, 8e-10, 2e-9, 1e-6, 1e-4, 1e-3, 1.0]), st.sampled_from(_DIRECTIONS)),
    min_size=1, max_size=12))
def test_the_named_pair_is_one_that_coincides(
        points: list[tuple[tuple[float, ...], float, tuple[float, ...]]]) -> None:
    anchors = np.array([np.add(base, np.multiply(scale, direction))
                        for base, scale, direction in points])
    size = np.maximum(1.0, np.abs(anchors).max(axis=1))
    gap = np.linalg.norm(anchors[:, None] - anchors[None], axis=-1)
    close = np.triu(gap < 1e-9 * np.maximum(size[:, None], size[None]), k=1)
    pairs = {(int(i), int(j)) for i, j in np.argwhere(close)}
    from tension_opt.checks import coincident_pair

    assert _point_robot(anchors.tolist()).m == len(anchors)  # shared anchors are valid
    named = coincident_pair(anchors)
    assert (named in pairs) if pairs else named is None, (named, pairs)


@pytest.mark.parametrize(("field", "value", "path"), [
    ("anchors", [[0.0, 0.0, 0.0], [93.0, 0.0, 0.0], [1e11, 0.0, 0.0], [0.0, 1.0, 0.0]],
     "anchors[2][0]"),
    ("anchors", [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, -2e6, 0.0], [0.0, 1.0, 0.0]],
     "anchors[2][1]"),
    ("attachments", [[0.0, 0.0, 0.0] for _ in range(3)] + [[0.0, 0.0, 1.5e6]],
     "attachments[3][2]"),
    ("com", [0.0, 1e7, 0.0], "com[1]"),
])
def test_absurd_coordinates_are_refused_by_name(field: str, value: list, path: str,
                                                tmp_path: Path) -> None:
    """One anchor at 1e11 m made anchors 0 and 1, 93 m apart, "coincide"."""
    anchors = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 2.0, 0.0], [0.0, 1.0, 0.0]]
    changes = {field: np.array(value)}
    message = rf"{re.escape(path)} = [-\d.e+]+ m is beyond 1e\+06 m .*metres"
    with pytest.raises(to.InvalidInputError, match=message):
        _point_robot(changes.pop("anchors", anchors), **changes)
    document = robot_files.robot_document(_point_robot(anchors))
    document[field] = value
    file = tmp_path / "far.yaml"
    robot_files.write_document(file, document)
    with pytest.raises(to.RobotFileError) as caught:
        to.CableRobot.from_file(file)
    (where, line, text), = caught.value.problems
    assert where == path and line > 0 and re.search(message, f"{where} = {text}")
