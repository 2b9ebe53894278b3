"""Import of CASPR single-link robot models (bodies and cables XML files).

CASPR (the Cable-robot Analysis and Simulation Platform for Research, BSD 3-Clause)
describes a robot by a bodies file (links: joint type and initial pose, mass, centre of
mass, inertia) and a cables file (cable sets; each cable's bounds and its attachment
points on the base, link 0, and on the links). :func:`load_caspr` reads a model whose
bodies file has one rigid link (a free platform) and whose chosen cable set holds ideal
straight cables from the base to that link.

Joint types and robot kinds (:mod:`tension_opt.kinds`):

=====================  ================  ==========================================
CASPR joint            kind              pose
=====================  ================  ==========================================
``SPATIAL_EULER_XYZ``  ``spatial6``      x, y, z and Euler XYZ angles -> rotation vector
``T_XYZ``              ``point3``        x, y, z
``PLANAR_XY``          ``planar3``       x, y, rotation about z
``P_XZ``               ``planar_point2`` x, z
=====================  ================  ==========================================

Not imported (a :class:`~tension_opt.errors.RobotFileError` says so): several links or
a link attached elsewhere than at the base origin, other joint types (spherical, planar
in other planes, ...), cable models other than ``cable_ideal`` (springs), routing
elements other than one ``base_rotating_pulley`` per cable (which becomes a
:class:`~tension_opt.Pulley`) and cables attached to more than the base and the platform;
nor an element CASPR reads once (``<mass>``, ``<force_max>``, ...) given twice, or two
cable sets of one id (the first was used and the others ignored).
Gravity is CASPR's, 9.81 m/s^2 along -z, unless ``g`` is given. CASPR gives no cable
diameter or mass, so the robot has no :class:`~tension_opt.CableProperties`.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from os import PathLike
from pathlib import Path

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from tension_opt.errors import InvalidInputError, RobotFileError
from tension_opt.robot import CableRobot
from tension_opt.robot.pulleys import Pulley

__all__ = ["JOINT_KINDS", "cable_sets", "load_caspr"]

#: CASPR joint type -> robot kind.
JOINT_KINDS = {
    "SPATIAL_EULER_XYZ": "spatial6",
    "T_XYZ": "point3",
    "PLANAR_XY": "planar3",
    "P_XZ": "planar_point2",
}
_POSE_SIZES = {"SPATIAL_EULER_XYZ": 6, "T_XYZ": 3, "PLANAR_XY": 3, "P_XZ": 2}


def _fail(path: str | PathLike[str], where: str, message: str) -> RobotFileError:
    return RobotFileError(f"CASPR file {path}: {where}: {message}", str(path),
                          ((where, 0, message),))


def _root(path: str | PathLike[str], tag: str) -> ET.Element:
    try:
        root = ET.parse(path).getroot()
    except (OSError, ET.ParseError) as error:
        raise _fail(path, "(file)", f"cannot be read as XML: {error}") from None
    if root.tag != tag:
        raise _fail(path, root.tag, f"expected a CASPR <{tag}> file; check the argument order "
                    "(bodies file first, then cables file)")
    return root


def _numbers(path: str | PathLike[str], where: str, text: str | None, size: int | None
             ) -> NDArray:
    try:
        values = np.array([float(v) for v in (text or "").split()])
    except ValueError:
        raise _fail(path, where, f"expected numbers, got {text!r}") from None
    if (size is not None and values.size != size) or not np.isfinite(values).all():
        raise _fail(path, where, f"expected {size} finite numbers, got {text!r}")
    return values


def _only(path: str | PathLike[str], element: ET.Element, tag: str, where: str
          ) -> ET.Element | None:
    """The one ``<tag>`` child of ``element`` (None if absent); more than one is refused,
    as a robot file refuses a duplicated key (CASPR reads one, so the others would be
    ignored silently)."""
    found = element.findall(tag)
    if len(found) > 1:
        raise _fail(path, where, f"<{tag}> is given {len(found)} times; give it once "
                    "(keep the value meant and remove the others)")
    return found[0] if found else None


def _child(path: str | PathLike[str], element: ET.Element, tag: str, where: str
           ) -> ET.Element:
    found = _only(path, element, tag, where)
    if found is None:
        raise _fail(path, where, f"missing <{tag}>")
    return found


def _inertia(path: str | PathLike[str], physical: ET.Element, mass: float, com: NDArray
             ) -> NDArray:
    """Inertia about the centre of mass (kg m^2); a tensor given about the joint is moved."""
    element = _child(path, physical, "inertia", "link_rigid/physical")
    entries = {name: float(_numbers(path, f"inertia/{name}",
                                    _child(path, element, name, "inertia").text, 1)[0])
               for name in ("Ixx", "Iyy", "Izz", "Ixy", "Ixz", "Iyz")}
    e = entries
    inertia = np.array([[e["Ixx"], e["Ixy"], e["Ixz"]], [e["Ixy"], e["Iyy"], e["Iyz"]],
                        [e["Ixz"], e["Iyz"], e["Izz"]]])
    reference = element.get("ref", "com")
    if reference == "joint":  # parallel-axis theorem back to the centre of mass
        inertia = inertia - mass * (com @ com * np.eye(3) - np.outer(com, com))
    elif reference != "com":
        raise _fail(path, "inertia", f"ref={reference!r}; expected 'com' or 'joint'")
    return inertia


def _home(joint: str, q: NDArray) -> NDArray:
    """CASPR joint coordinates as a pose of the kind (Euler XYZ -> rotation vector)."""
    if joint == "SPATIAL_EULER_XYZ":
        # CASPR: R = Rx(alpha) Ry(beta) Rz(gamma), intrinsic XYZ.
        return np.concatenate([q[:3], Rotation.from_euler("XYZ", q[3:]).as_rotvec()])
    return q


def _read_bodies(path: str | PathLike[str]) -> dict:
    holder = _only(path, _root(path, "bodies_system"), "links", "bodies_system")
    links = [] if holder is None else list(holder)
    if len(links) != 1 or links[0].tag != "link_rigid":
        raise _fail(path, "links", f"{len(links)} links ({', '.join(k.tag for k in links)}); "
                    "only a single rigid link (one free platform) is imported")
    link = links[0]
    joint_element = _child(path, link, "joint", "link_rigid")
    joint = joint_element.get("type", "")
    if joint not in JOINT_KINDS:
        raise _fail(path, "joint", f"type {joint!r} is not imported; supported: "
                    f"{', '.join(f'{j} ({k})' for j, k in JOINT_KINDS.items())}")
    parent = _child(path, link, "parent", "link_rigid")
    location = _numbers(path, "parent/location", _child(path, parent, "location",
                                                        "parent").text, 3)
    if (_child(path, parent, "num", "parent").text or "").strip() != "0" or location.any():
        raise _fail(path, "parent", "the link must hang from the base (num 0) at its origin "
                    "(location 0 0 0)")
    physical = _child(path, link, "physical", "link_rigid")
    mass = float(_numbers(path, "physical/mass",
                          _child(path, physical, "mass", "link_rigid/physical").text, 1)[0])
    com = _numbers(path, "physical/com_location",
                   _child(path, physical, "com_location", "link_rigid/physical").text, 3)
    _only(path, physical, "end_location", "link_rigid/physical")
    q = _numbers(path, "joint/q_initial", joint_element.get("q_initial"), _POSE_SIZES[joint])
    return {"joint": joint, "mass": mass, "com": com,
            "inertia": _inertia(path, physical, mass, com), "home": _home(joint, q)}


def cable_sets(cables_xml: str | PathLike[str]) -> tuple[list[str], str | None]:
    """Ids of the cable sets in a CASPR cables file, and its default set."""
    root = _root(cables_xml, "cables")
    return [s.get("id", "") for s in root.findall("cable_set")], root.get("default_cable_set")


def _chosen_set(path: str | PathLike[str], cable_set: str | None) -> tuple[str, ET.Element]:
    root = _root(path, "cables")
    chosen = cable_set if cable_set is not None else root.get("default_cable_set")
    elements = root.findall("cable_set")
    ids = [s.get("id", "") for s in elements]
    for id_ in ids:
        if ids.count(id_) > 1:  # an ID in CASPR's cables.dtd: one set of each id
            raise _fail(path, "cables", f"cable_set id {id_!r} is given {ids.count(id_)} "
                        "times; give it once (rename or remove the other sets)")
    sets = dict(zip(ids, elements, strict=True))
    if chosen not in sets:
        raise _fail(path, "cable_set", f"no cable set {chosen!r}; the file has {list(sets)}")
    return chosen, sets[chosen]


def _rotating_pulley(path: str | PathLike[str], item: ET.Element, where: str
                     ) -> tuple[NDArray, Pulley]:
    """A ``<base_rotating_pulley>``: the point where the cable enters the wheel (our
    drawing point) and a :class:`Pulley` whose axis is against CASPR's entry vector
    (the cable's direction of travel into the wheel)."""
    tags = ("fixed_location", "pulley_radius", "cable_entry_vector")
    point, radius, entry = (_numbers(path, f"{where}/{tag}", _child(
        path, item, tag, where).text, 1 if tag == "pulley_radius" else 3) for tag in tags)
    try:
        return point, Pulley(float(radius[0]), -entry)
    except InvalidInputError as error:
        raise _fail(path, where, f"<base_rotating_pulley>: {error}") from None


def _cable_ends(path: str | PathLike[str], cable: ET.Element, where: str
                ) -> tuple[NDArray, NDArray, Pulley | None]:
    """Base point (m), link point relative to the joint (m, before the com shift) and
    the cable's guide pulley (None for a plain base attachment)."""
    ends: dict[int, NDArray] = {}
    pulley = None
    for item in _child(path, cable, "attachments", where):
        if item.tag == "base_rotating_pulley" and 0 not in ends:
            ends[0], pulley = _rotating_pulley(path, item, where)
            continue
        if item.tag != "attachment":
            raise _fail(path, where, f"<{item.tag}> is not imported (routing elements "
                        "other than one base_rotating_pulley); use a cable set of plain "
                        "attachments")
        link = (_child(path, item, "link", where).text or "").strip()
        if link not in ("0", "1") or int(link) in ends:
            raise _fail(path, where, "a cable must run from the base (link 0) to the "
                        f"platform (link 1) once each; got link {link!r}")
        ends[int(link)] = _numbers(path, f"{where}/location",
                                   _child(path, item, "location", where).text, 3)
    if len(ends) != 2:
        raise _fail(path, where, "a cable needs two attachments, link 0 and link 1")
    return ends[0], ends[1], pulley


def _read_cables(path: str | PathLike[str], cable_set: str | None) -> list[dict]:
    chosen, element = _chosen_set(path, cable_set)
    cables = []
    for k, cable in enumerate(element):
        where = f"cable_set {chosen!r}, cable {k} ({cable.get('name', '')!r})"
        if cable.tag != "cable_ideal":
            raise _fail(path, where, f"<{cable.tag}> is not imported; only cable_ideal "
                        "(straight, inextensible cables) is")
        reference = cable.get("attachment_reference", "joint")
        if reference not in ("joint", "com"):
            raise _fail(path, where, f"attachment_reference={reference!r}; expected 'joint' "
                        "or 'com'")
        properties = _child(path, cable, "properties", where)
        bounds = [float(_numbers(path, f"{where}/{tag}",
                                 _child(path, properties, tag, where).text, 1)[0])
                  for tag in ("force_min", "force_max")]
        anchor, attachment, pulley = _cable_ends(path, cable, where)
        cables.append({"anchor": anchor, "attachment": attachment, "reference": reference,
                       "t_min": bounds[0], "t_max": bounds[1], "pulley": pulley})
    if not cables:
        raise _fail(path, f"cable_set {chosen!r}", "holds no cables")
    return cables


def load_caspr(bodies_xml: str | PathLike[str], cables_xml: str | PathLike[str],
               cable_set: str | None = None, *, g: float = 9.81,
               name: str | None = None) -> CableRobot:
    """A :class:`~tension_opt.CableRobot` from a CASPR single-link model.

    Parameters
    ----------
    bodies_xml : path
        CASPR ``*_bodies.xml``: one ``link_rigid`` with its joint, mass (kg), centre of
        mass (m), inertia (kg m^2, about the centre of mass or the joint) and
        ``q_initial``, which becomes the robot's home pose.
    cables_xml : path
        CASPR ``*_cables.xml``: tension bounds ``force_min``/``force_max`` (N) and the
        attachment on the base (link 0, base frame, m) and on the platform (link 1,
        platform frame relative to the joint or to the centre of mass, m) of each cable.
    cable_set : str, optional
        Id of the cable set; default the file's ``default_cable_set``
        (:func:`cable_sets` lists them).
    g : float
        Gravitational acceleration (m/s^2) along -z; CASPR's 9.81 by default.
    name : str, optional
        Robot name; default the bodies file's name without ``_bodies.xml``.

    Returns
    -------
    CableRobot
        Cables in the order of the cable set; attachments relative to the joint (the
        platform reference point).

    Raises
    ------
    RobotFileError
        For what cannot be imported (see the module docstring), naming the element.
    """
    body = _read_bodies(bodies_xml)
    cables = _read_cables(cables_xml, cable_set)
    shift = {"joint": np.zeros(3), "com": body["com"]}
    attachments = np.array([c["attachment"] + shift[c["reference"]] for c in cables])
    default_name = Path(bodies_xml).name.removesuffix(".xml").removesuffix("_bodies")
    try:
        return CableRobot(
            anchors=np.array([c["anchor"] for c in cables]), attachments=attachments,
            mass=body["mass"], kind=JOINT_KINDS[body["joint"]], com=body["com"], g=g,
            t_min=np.array([c["t_min"] for c in cables]),
            t_max=np.array([c["t_max"] for c in cables]), home=body["home"],
            name=name if name is not None else default_name, inertia=body["inertia"],
            pulleys=[c["pulley"] for c in cables])
    except InvalidInputError as error:  # the robot's own checks: name both files
        raise RobotFileError(f"CASPR model {bodies_xml} + {cables_xml}: {error}",
                             str(cables_xml), (("(robot)", 0, str(error)),)) from None
