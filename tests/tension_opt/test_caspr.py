"""Import of CASPR single-link models: published sizes, full rank at the reference
pose, agreement with the preset files, frames, and what is refused."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

import tension_opt as to
from tension_opt.cli import main
from tension_opt.robot.caspr import cable_sets, load_caspr

CASPR = Path(__file__).resolve().parents[1] / "data" / "caspr" / "SCDM"


def _files(folder: str) -> tuple[Path, Path]:
    directory = CASPR / folder
    bodies = next(directory.glob("*_bodies.xml"))
    return bodies, directory / bodies.name.replace("_bodies", "_cables")


# Cables and DOF as published in the paper each model's README.txt cites.
PUBLISHED = {
    # Gouttefarde et al., IEEE T-RO 31(2), 2015: 8 cables, 6 DOF, suspended
    "spatial_manipulators/CoGiRo": ("spatial6", 8, 6),
    # Pott et al., IPAnema family, CDPR 2012 (MMS 12): IPAnema 1, 8 cables, 6 DOF
    "spatial_manipulators/IPAnema_1": ("spatial6", 8, 6),
    # Nan et al., FAST, 2011: the feed cabin hangs from 6 cables (6 towers), 6 DOF
    "spatial_manipulators/FAST": ("spatial6", 6, 6),
    # Miermeister et al., IROS 2016: the CableRobot simulator, 8 cables, 6 DOF
    "spatial_manipulators/The_Cable_Robot_Simulator": ("spatial6", 8, 6),
    # Gagliardini et al. (IRT Jules Verne): CAROCA, 8 cables, 6 DOF
    "spatial_manipulators/CAROCA": ("spatial6", 8, 6),
    # Mayhew et al., ICORR 2005: MACARM, 8 cables on a cubic frame, 6 DOF
    "spatial_manipulators/MACARM": ("spatial6", 8, 6),
    # Babaghasabha et al., CDPR 2015 (MMS 32): KNTU planar, 4 cables, 3 DOF
    "planar_manipulators/KNTU_planar": ("planar3", 4, 3),
}
OTHERS = ["spatial_manipulators/ACROBOT", "spatial_manipulators/IPAnema_2",
          "spatial_manipulators/SEGESTA"]


@pytest.mark.parametrize("folder", sorted(PUBLISHED))
def test_models_load_with_their_published_cables_and_dof(folder: str) -> None:
    robot = load_caspr(*_files(folder))
    assert (robot.kind, robot.m, robot.dof) == PUBLISHED[folder]


@pytest.mark.parametrize("folder", sorted(PUBLISHED) + OTHERS)
def test_structure_matrix_has_full_rank_at_the_reference_pose(folder: str) -> None:
    robot = load_caspr(*_files(folder))
    A = robot.structure_matrices(robot.home)[0]
    singular = np.linalg.svd(A, compute_uv=False)
    assert singular[-1] > 1e-6 * singular[0]
    assert np.linalg.matrix_rank(A) == robot.dof


def test_cogiro_from_caspr_is_the_preset_file_bit_for_bit() -> None:
    imported = load_caspr(*_files("spatial_manipulators/CoGiRo"))
    preset = to.presets.cogiro()
    for field in ("anchors", "attachments", "com", "inertia", "t_min", "t_max", "home"):
        assert np.array_equal(getattr(imported, field), getattr(preset, field)), field
    assert (imported.mass, imported.g, imported.name) == (preset.mass, preset.g, "CoGiRo")
    assert imported.cable is None  # CASPR has no cable diameter or mass


def test_kntu_from_caspr_matches_the_preset_up_to_gravity_across_the_plane() -> None:
    imported = load_caspr(*_files("planar_manipulators/KNTU_planar"))
    preset = to.presets.kntu_planar()
    for field in ("anchors", "attachments", "com", "inertia", "t_min", "t_max", "home"):
        assert np.array_equal(getattr(imported, field), getattr(preset, field)), field
    # CASPR's gravity (-z) is normal to the robot's plane: no planar wrench either way
    assert (imported.g, preset.g) == (9.81, 0.0)
    poses = [[0.1, -0.2, 0.3], [0.0, 0.0, 0.0]]
    np.testing.assert_array_equal(imported.required_wrench(poses), np.zeros((2, 3)))
    assert load_caspr(*_files("planar_manipulators/KNTU_planar"), g=0.0).g == 0.0


def test_cable_sets_are_listed_and_chosen() -> None:
    bodies, cables = _files("spatial_manipulators/IPAnema_1")
    assert cable_sets(cables) == (["original", "IROS_CASPR_2016"], "original")
    iros = load_caspr(bodies, cables, "IROS_CASPR_2016")
    assert iros.t_max.tolist() == [720.0] * 5 + [200.0] + [720.0] * 2
    assert iros.anchors[0].tolist() == [-2.0, 3.0, 5.0]
    with pytest.raises(to.RobotFileError, match=r"no cable set 'spare'.*'IROS_CASPR_2016'"):
        load_caspr(bodies, cables, "spare")


def _write_model(tmp_path: Path, joint: str, q: str, inertia_ref: str, reference: str,
                 links: int = 1) -> tuple[Path, Path]:
    link = f"""<link_rigid num="1" name="body">
        <joint type="{joint}" q_initial="{q}"/>
        <physical><mass>2.0</mass><com_location>0.1 -0.2 0.3</com_location>
          <end_location>0 0 0</end_location>
          <inertia ref="{inertia_ref}"><Ixx>1.0</Ixx><Iyy>2.0</Iyy><Izz>3.0</Izz>
            <Ixy>0.1</Ixy><Ixz>0.0</Ixz><Iyz>-0.2</Iyz></inertia></physical>
        <parent><num>0</num><location>0 0 0</location></parent></link_rigid>"""
    bodies = tmp_path / "test_bodies.xml"
    bodies.write_text(f"<bodies_system><links>{link * links}</links></bodies_system>")
    corners = [(x, y, z) for x in (-2, 2) for y in (-2, 2) for z in (0, 3)]
    cable = """<cable_ideal name="c{k}" attachment_reference="{ref}">
        <properties><force_min>1</force_min><force_max>100</force_max></properties>
        <attachments><attachment><link>0</link><location>{a}</location></attachment>
        <attachment><link>1</link><location>{b}</location></attachment></attachments>
        </cable_ideal>"""
    body = "".join(cable.format(k=k, ref=reference, a=" ".join(map(str, c)),
                                b=" ".join(str(v / 10) for v in c)) for k, c in enumerate(corners))
    cables = tmp_path / "test_cables.xml"
    cables.write_text(f'<cables default_cable_set="s"><cable_set id="s">{body}</cable_set>'
                      "</cables>")
    return bodies, cables


def test_euler_angles_com_reference_and_joint_inertia_are_converted(tmp_path: Path) -> None:
    a, b, g = 0.3, -0.4, 0.5
    robot = load_caspr(*_write_model(tmp_path, "SPATIAL_EULER_XYZ", f"1 2 1.5 {a} {b} {g}",
                                     "joint", "com"))
    # CASPR's orientation R = Rx(a) Ry(b) Rz(g), written out by hand
    Rx = np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])
    Ry = np.array([[np.cos(b), 0, np.sin(b)], [0, 1, 0], [-np.sin(b), 0, np.cos(b)]])
    Rz = np.array([[np.cos(g), -np.sin(g), 0], [np.sin(g), np.cos(g), 0], [0, 0, 1]])
    position, R = robot.frames(robot.home[None])
    np.testing.assert_allclose(R[0], Rx @ Ry @ Rz, atol=1e-15)
    np.testing.assert_array_equal(position[0], [1.0, 2.0, 1.5])
    # attachments given about the centre of mass are moved to the joint frame
    np.testing.assert_allclose(robot.attachments[0], [-0.2 + 0.1, -0.2 - 0.2, 0.0 + 0.3])
    # inertia about the joint, moved to the centre of mass: I_G = I_O - m (c.c 1 - c c^T)
    c = np.array([0.1, -0.2, 0.3])
    I_joint = np.array([[1.0, 0.1, 0.0], [0.1, 2.0, -0.2], [0.0, -0.2, 3.0]])
    np.testing.assert_allclose(robot.inertia, I_joint - 2.0 * (c @ c * np.eye(3)
                                                               - np.outer(c, c)), atol=1e-15)
    assert (robot.mass, robot.t_min[0], robot.t_max[0]) == (2.0, 1.0, 100.0)


@pytest.mark.parametrize(("joint", "q", "kind"), [("T_XYZ", "0.1 0.2 1.0", "point3"),
                                                  ("PLANAR_XY", "0.1 0.2 0.3", "planar3"),
                                                  ("P_XZ", "0.1 1.0", "planar_point2")])
def test_every_mapped_joint_gives_its_kind(joint: str, q: str, kind: str,
                                           tmp_path: Path) -> None:
    robot = load_caspr(*_write_model(tmp_path, joint, q, "com", "joint"))
    assert robot.kind == kind
    np.testing.assert_array_equal(robot.home, [float(v) for v in q.split()])


@pytest.mark.parametrize(("folder", "cable_set", "message"), [
    ("planar_manipulators/2_DoF_VSD", None, "type 'P_XY' is not imported; supported: "
     "SPATIAL_EULER_XYZ"),
    ("spherical_manipulators/myorob_shoulder", None, "type 'S_EULER_XYZ' is not imported"),
    ("planar_manipulators/2_DoF_VSD", "stiff", "P_XY"),
])
def test_what_is_not_imported_is_a_file_error_naming_it(folder: str, cable_set: str | None,
                                                         message: str) -> None:
    with pytest.raises(to.RobotFileError, match=message):
        load_caspr(*_files(folder), cable_set)


@pytest.mark.parametrize(("folder", "cable_set", "m"), [
    ("spatial_manipulators/NIST_ROBOCRANE", None, 6),
    ("spatial_manipulators/CAROCA", "gazebo_sim", 8),
])
def test_models_whose_cables_share_points_import(folder: str, cable_set: str | None,
                                                 m: int) -> None:
    """Cables meeting at one drawing point are a valid robot: the structure matrix's
    rank decides what it can hold."""
    robot = load_caspr(*_files(folder), cable_set)
    assert robot.m == m
    shared = {tuple(a) for a in robot.anchors.tolist()}
    assert len(shared) < m  # some cables leave one drawing point
    A = robot.structure_matrices(robot.home)[0]
    assert np.linalg.matrix_rank(A) == 6
    sol = to.distribute(robot, robot.home, "min_norm", "cvxpy:CLARABEL", accuracy="high")
    ref = to.distribute(robot, robot.home, "min_norm", "qpsolvers:clarabel", accuracy="high")
    assert sol.status[0] == ref.status[0]
    if sol.success[0]:
        np.testing.assert_allclose(sol.tensions, ref.tensions, rtol=1e-6, atol=1e-6)
        residual = A @ sol.tensions[0] - robot.required_wrench(robot.home)[0]
        assert np.abs(residual).max() <= 1e-7 * robot.weight


def test_multi_link_springs_and_swapped_files_are_refused(tmp_path: Path) -> None:
    bodies, cables = _write_model(tmp_path, "SPATIAL_EULER_XYZ", "0 0 1 0 0 0", "com",
                                  "joint", links=2)
    with pytest.raises(to.RobotFileError, match=r"2 links .*only a single rigid link"):
        load_caspr(bodies, cables)
    with pytest.raises(to.RobotFileError, match="check the argument order"):
        load_caspr(cables, bodies)
    springs = _files("planar_manipulators/2_DoF_VSD")[1]
    one = _write_model(tmp_path, "PLANAR_XY", "0 0 0", "com", "joint")[0]
    with pytest.raises(to.RobotFileError, match="<cable_vsd_torsion_spring> is not imported"):
        load_caspr(one, springs, "basic")


@pytest.mark.parametrize("suffix", [".yaml", ".json"])
def test_an_imported_model_round_trips_through_a_file(suffix: str, tmp_path: Path,
                                                      capsys: pytest.CaptureFixture[str]
                                                      ) -> None:
    bodies, cables = _files("spatial_manipulators/The_Cable_Robot_Simulator")
    out = tmp_path / f"simulator{suffix}"
    assert main(["from-caspr", str(bodies), str(cables), str(out)]) == 0
    assert "8 cables" in capsys.readouterr().out
    robot, back = load_caspr(bodies, cables), to.CableRobot.from_file(out)
    for field in ("anchors", "attachments", "com", "inertia", "t_min", "t_max", "home"):
        assert getattr(back, field).tobytes() == getattr(robot, field).tobytes(), field
    assert (back.mass, back.name, back.kind) == (robot.mass, robot.name, robot.kind)


# Text to repeat in the written model (bodies or cables file) and the element named.
DUPLICATES = {
    "mass": ("bodies", "<mass>2.0</mass>", "<mass>"),
    "com": ("bodies", "<com_location>0.1 -0.2 0.3</com_location>", "<com_location>"),
    "inertia entry": ("bodies", "<Ixx>1.0</Ixx>", "<Ixx>"),
    "joint": ("bodies", '<joint type="T_XYZ" q_initial="0.1 0.2 1.0"/>', "<joint>"),
    "parent": ("bodies", "<num>0</num>", "<num>"),
    "links": ("bodies", None, "<links>"),
    "bound": ("cables", "<force_max>100</force_max>", "<force_max>"),
    "properties": ("cables", "<properties><force_min>1</force_min><force_max>100</force_max>"
                   "</properties>", "<properties>"),
    "location": ("cables", "<location>-2 -2 0</location>", "<location>"),
    "link": ("cables", "<link>0</link>", "<link>"),
    "cable set": ("cables", None, "cable_set id 's'"),
}


@pytest.mark.parametrize("case", sorted(DUPLICATES))
def test_a_duplicated_element_is_refused_naming_it(case: str, tmp_path: Path) -> None:
    """A second <mass> (or any element CASPR reads once) was ignored: the first won."""
    files = dict(zip(("bodies", "cables"), _write_model(tmp_path, "T_XYZ", "0.1 0.2 1.0",
                                                         "com", "joint"), strict=True))
    which, element, name = DUPLICATES[case]
    path = files[which]
    text = path.read_text()
    if case == "links":
        start, end = text.index("<links>"), text.index("</links>") + len("</links>")
        text = text[:end] + text[start:end] + text[end:]
    elif case == "cable set":
        start, end = text.index('<cable_set id="s">'), text.index("</cables>")
        text = text[:end] + text[start:end] + text[end:]
    else:
        assert element in text
        text = text.replace(element, element + element.replace("1", "7"), 1)
    path.write_text(text)
    with pytest.raises(to.RobotFileError) as caught:
        load_caspr(files["bodies"], files["cables"])
    message = str(caught.value)
    assert f"CASPR file {path}: " in message and caught.value.path == str(path)
    assert re.search(rf"{re.escape(name)} is given 2 times.*give it once", message), message
