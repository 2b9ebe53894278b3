"""A C++ timing driver against a checkout of WireX (Andreas Pott's cable-robot library,
MIT licence), for :mod:`benchmarks.bench_peers`.

The driver is generated here, written with the robots and poses (a plain text file it
reads) into a temporary folder and built there with the system's C++ compiler against
the checkout's own sources: WireLib's robot model (``CRobotData``), structure matrix,
force distribution (``CForceDistribution``: the closed form and the improved closed
form) and stiffness (``CStiffness``), with tinyXML and WireLib's algorithm base where the
checkout has them. Nothing of WireX is copied into this repository. Parts of WireLib
that the driver never calls (optional solvers, pulley kinematics, XML files) may be left
out: a source of them that does not compile is skipped, and symbols left undefined are
reported and linked as absent (the driver calls none of them).

WireX's conventions, which the data file follows: the structure equation is
``A^T f + w = 0`` with ``w`` the wrench applied to the platform (so ``w`` is minus the
toolkit's required wrench), ``A^T`` has rows ``u_i`` and ``(R b_i) x u_i`` with ``u_i``
the unit vector from the platform's attachment to the base anchor, and the closed form
is ``f = f_ref - A^+ (w + A^T f_ref)`` with ``f_ref = (f_min + f_max) / 2``: the
toolkit's ``"centered"`` objective without bounds.
"""

from __future__ import annotations

import concurrent.futures
import os
import re
import shutil
import subprocess
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "BASE_FLAGS",
    "NATIVE_FLAGS",
    "REQUIRED",
    "Build",
    "Case",
    "DriverError",
    "DriverResult",
    "NotACheckoutError",
    "build_driver",
    "check_checkout",
    "compiler_version",
    "driver_source",
    "eigen_includes",
    "find_compiler",
    "run_driver",
    "write_cases",
]

FloatArray = NDArray[np.float64]

#: Files a WireX checkout has (relative to its top folder), checked before building.
REQUIRED = (
    "WireLib/RobotData.h",
    "WireLib/RobotData.cpp",
    "WireLib/StructureMatrix.h",
    "WireLib/StructureMatrix.cpp",
)
#: Further WireLib sources compiled where present (skipped if they do not compile).
OPTIONAL = ("WireLib/Algorithm.cpp", "WireLib/Reflection.cpp", "WireLib/Kinematics.cpp")
#: Flags of every build (WireX's own CMake files add ``-fpermissive -w``).
BASE_FLAGS = ("-std=c++14", "-fpermissive", "-w", "-DNDEBUG")
#: Optimisation of the default build and of the ``--native`` one.
DEFAULT_OPT = ("-O2",)
NATIVE_FLAGS = ("-O3", "-march=native")
_UNDEFINED = re.compile(r"undefined reference to [`']([^']+)'")


class NotACheckoutError(ValueError):
    """The folder given as ``--wirex`` is not a checkout of WireX's source."""


class DriverError(RuntimeError):
    """The driver did not build or run; the message holds the compiler's or the
    driver's own words."""


@dataclass(frozen=True)
class Case:
    """One robot and its poses, in WireX's terms (a 6-DOF robot, one row per pose).

    Attributes
    ----------
    name : str
        A word (no spaces), the key of the driver's results.
    anchors, attachments : ndarray, shape (m, 3)
        Base anchors (world frame) and platform attachments (platform frame), m.
    f_min, f_max : ndarray, shape (m,)
        Tension bounds (N).
    positions : ndarray, shape (N, 3)
        Platform positions (m).
    rotations : ndarray, shape (N, 3, 3)
        Platform orientations (rotation matrices, platform to world).
    wrenches : ndarray, shape (N, 6)
        Wrench applied to the platform (N, N m): minus the required wrench.
    tensions : ndarray, shape (N, m)
        Given tensions of the stiffness work (N).
    EA : float
        Axial stiffness of the cables (N), WireX's "specific spring constant".
    works : tuple of str
        ``"distribution"`` (closed form and improved closed form) and/or
        ``"stiffness"`` (stiffness matrix of straight cables, tensions given).
    """

    name: str
    anchors: FloatArray
    attachments: FloatArray
    f_min: FloatArray
    f_max: FloatArray
    positions: FloatArray
    rotations: FloatArray
    wrenches: FloatArray
    tensions: FloatArray
    EA: float
    works: tuple[str, ...] = ("distribution",)

    @property
    def m(self) -> int:
        """Number of cables."""
        return int(self.anchors.shape[0])

    @property
    def n(self) -> int:
        """Number of poses."""
        return int(self.positions.shape[0])


@dataclass(frozen=True)
class Build:
    """A built driver: its executable, the flags it was built with, what was left out."""

    label: str
    flags: tuple[str, ...]
    executable: Path
    skipped: tuple[str, ...] = ()
    unresolved: tuple[str, ...] = ()


@dataclass
class DriverResult:
    """What one run of the driver printed.

    Attributes
    ----------
    times : dict
        ``(case, work) -> ns per pose``: the median over repeats of the time of a pass
        over all poses divided by their number; work is ``"closed_form"``,
        ``"improved"`` or ``"stiffness"``.
    checks : dict
        ``(kind, case) -> values`` of the first pose: ``"matrix"`` (the structure
        matrix, row-major, 6*m), ``"closed_form"`` and ``"improved"`` (the returned flag,
        then the m tensions), ``"stiffness"`` (WireX's elastic stiffness matrix ``K``,
        row-major, 36).
    solved : dict
        ``case -> (poses where the improved closed form returned true with tensions
        within the bounds, poses)``.
    """

    times: dict[tuple[str, str], float] = field(default_factory=dict)
    checks: dict[tuple[str, str], FloatArray] = field(default_factory=dict)
    solved: dict[str, tuple[int, int]] = field(default_factory=dict)


def check_checkout(path: str | os.PathLike[str]) -> Path:
    """The top folder of a WireX checkout, checked.

    Raises
    ------
    NotACheckoutError
        If ``path`` is no folder or lacks WireLib's robot model or structure matrix.
    """
    top = Path(path).expanduser()
    fix = (
        "pass the top folder of a checkout of WireX's public source (the folder that "
        "holds WireLib/ and tinyXML/), e.g. a git clone of WireX"
    )
    if not top.is_dir():
        raise NotACheckoutError(f"--wirex {path}: no such folder; {fix}")
    missing = [name for name in REQUIRED if not (top / name).is_file()]
    if missing:
        raise NotACheckoutError(
            f"--wirex {path}: not a WireX checkout (missing {', '.join(missing)}); {fix}"
        )
    return top.resolve()


def eigen_includes(checkout: Path, eigen: str | os.PathLike[str] | None = None) -> list[Path]:
    """Folders holding ``Eigen/Eigen``: ``eigen`` if given, an Eigen copy in the checkout
    (``Eigen/Eigen/Eigen``), the system's ``/usr/include/eigen3``; those that exist."""
    candidates = [Path(eigen)] if eigen is not None else []
    candidates += [checkout / "Eigen", checkout, Path("/usr/include/eigen3")]
    return [c for c in dict.fromkeys(candidates) if (c / "Eigen" / "Eigen").is_file()]


def compiler_version(cxx: str) -> str:
    """First line of ``cxx --version`` ('' if it cannot be run)."""
    try:
        done = subprocess.run([cxx, "--version"], capture_output=True, text=True, timeout=30)
    except (OSError, subprocess.SubprocessError):
        return ""
    return done.stdout.splitlines()[0] if done.stdout else ""


def _sources(checkout: Path) -> tuple[list[Path], list[Path]]:
    """(required, optional) sources: WireLib's model and structure matrix; its algorithm
    base, reflection and kinematics, and tinyXML, where present."""
    required = [checkout / name for name in REQUIRED if name.endswith(".cpp")]
    optional = [checkout / name for name in OPTIONAL if (checkout / name).is_file()]
    optional += sorted((checkout / "tinyXML").glob("*.cpp"))
    return required, optional


def _compile(cxx: str, flags: list[str], source: Path, obj: Path) -> str | None:
    """Compile one source; None on success, else the compiler's last lines."""
    done = subprocess.run(
        [cxx, *flags, "-c", str(source), "-o", str(obj)], capture_output=True, text=True
    )
    if done.returncode == 0:
        return None
    return "\n".join((done.stderr or done.stdout).strip().splitlines()[-25:])


def build_driver(
    checkout: Path,
    folder: Path,
    cxx: str = "g++",
    opt: tuple[str, ...] = DEFAULT_OPT,
    label: str = "-O2",
    eigen: str | os.PathLike[str] | None = None,
) -> Build:
    """Write the driver into ``folder`` and build it with ``cxx`` against ``checkout``.

    Parameters
    ----------
    checkout : Path
        A checked WireX checkout (:func:`check_checkout`).
    folder : Path
        A scratch folder (its ``build{label}`` subfolder takes the objects).
    cxx : str
        The C++ compiler.
    opt : tuple of str
        Optimisation flags (``("-O2",)``, or :data:`NATIVE_FLAGS`).
    label : str
        Name of the build in the table.
    eigen : path, optional
        A folder holding ``Eigen/Eigen`` (default: found by :func:`eigen_includes`).

    Raises
    ------
    DriverError
        If the driver or a required WireX source does not compile, or the link fails
        for another reason than symbols of parts the driver never calls.
    """
    out = folder / ("build" + re.sub(r"[^A-Za-z0-9]+", "_", label))
    out.mkdir(parents=True, exist_ok=True)
    driver = folder / "bench_peers_driver.cpp"
    driver.write_text(driver_source())
    includes = [f"-I{checkout}"] + [f"-I{p}" for p in eigen_includes(checkout, eigen)]
    flags = [*BASE_FLAGS, *opt, *includes]
    required, optional = _sources(checkout)
    jobs = [(driver, True), *((s, True) for s in required), *((s, False) for s in optional)]
    objects = {src: out / f"{k}_{src.stem}.o" for k, (src, _) in enumerate(jobs)}
    with concurrent.futures.ThreadPoolExecutor(max(1, os.cpu_count() or 1)) as pool:
        errors = dict(
            zip(
                (src for src, _ in jobs),
                pool.map(lambda job: _compile(cxx, flags, job[0], objects[job[0]]), jobs),
                strict=True,
            )
        )
    skipped = []
    for src, needed in jobs:
        if errors[src] is None:
            continue
        if needed:
            hint = (
                (
                    "\n(Eigen not found: install it, e.g. apt-get install libeigen3-dev, "
                    "or pass --eigen DIR)"
                )
                if "Eigen" in (errors[src] or "")
                else ""
            )
            raise DriverError(
                f"{src.name} did not compile ({cxx} {' '.join(opt)}):\n{errors[src]}{hint}"
            )
        skipped.append(str(src.relative_to(checkout)))
    objs = [str(objects[src]) for src, _ in jobs if errors[src] is None]
    exe = out / "bench_peers_driver"
    unresolved = _link(cxx, list(opt), objs, exe)
    return Build(label, tuple(opt), exe, tuple(skipped), tuple(unresolved))


def _link(cxx: str, opt: list[str], objs: list[str], exe: Path) -> list[str]:
    """Link the driver; returns the symbols left undefined (those of sources left out or
    of optional dependencies), linked as absent: the driver calls none of them.

    Raises
    ------
    DriverError
        If the link fails for another reason.
    """
    done = subprocess.run([cxx, *opt, *objs, "-o", str(exe)], capture_output=True, text=True)
    unresolved: list[str] = []
    if done.returncode != 0:
        unresolved = sorted(set(_UNDEFINED.findall(done.stderr)))
        if unresolved:
            absent = ["-no-pie", "-Wl,--unresolved-symbols=ignore-all"]
            done = subprocess.run(
                [cxx, *opt, *absent, *objs, "-o", str(exe)], capture_output=True, text=True
            )
    if done.returncode != 0:
        raise DriverError(f"the driver did not link:\n{done.stderr.strip()[-3000:]}")
    return unresolved


def write_cases(cases: list[Case], path: Path, repeats: int) -> None:
    """Write ``cases`` into the driver's data file ``path`` (plain text, see
    :func:`driver_source`)."""
    lines = [str(len(cases))]
    for c in cases:
        lines.append(
            f"{c.name} {c.m} {c.n} {repeats} {c.EA!r} "
            f"{int('distribution' in c.works)} {int('stiffness' in c.works)}"
        )
        for block in (c.anchors, c.attachments, c.f_min, c.f_max):
            lines.append(" ".join(repr(float(v)) for v in np.ravel(block)))
        rows = np.hstack([c.positions, c.rotations.reshape(c.n, 9), c.wrenches, c.tensions])
        lines.extend(" ".join(repr(float(v)) for v in row) for row in rows)
    path.write_text("\n".join(lines) + "\n")


def run_driver(build: Build, data: Path, timeout: float = 600.0) -> DriverResult:
    """Run a built driver on a data file and read what it printed.

    Raises
    ------
    DriverError
        If the driver fails (the message has its output).
    """
    try:
        done = subprocess.run(
            [str(build.executable), str(data)], capture_output=True, text=True, timeout=timeout
        )
    except subprocess.TimeoutExpired as err:
        raise DriverError(f"the driver ({build.label}) ran over {timeout:.0f} s") from err
    if done.returncode != 0:
        raise DriverError(
            f"the driver ({build.label}) failed with code {done.returncode}:"
            f"\n{(done.stderr or done.stdout).strip()[-3000:]}"
        )
    result = DriverResult()
    for line in done.stdout.splitlines():
        kind, *rest = line.split()
        if kind == "time":
            result.times[(rest[0], rest[1])] = float(rest[2])
        elif kind == "solved":
            result.solved[rest[0]] = (int(rest[1]), int(rest[2]))
        elif kind in ("matrix", "closed_form", "improved", "stiffness"):
            result.checks[(kind, rest[0])] = np.array(rest[1:], dtype=float)
    return result


def driver_source() -> str:
    """C++ source of the driver.

    It reads the data file of :func:`write_cases` (argument 1): the number of cases,
    then per case a line ``name m N repeats EA distribution stiffness``, the anchors,
    the attachments, ``f_min``, ``f_max`` and one line per pose ``r (3) R (9,
    row-major) w (6) f (m)``. For each case it prints the checks of the first pose
    (``matrix``, ``closed_form``, ``improved``, ``stiffness`` lines), the count of
    poses the improved closed form solves (``solved``), and the time per pose of each
    work (``time case work ns``): the median over the repeats of one pass over all
    poses, after one untimed pass. Each work includes the structure matrix of the
    pose, as the toolkit's calls do.
    """
    return _DRIVER


_DRIVER = r"""// Timing driver of python -m benchmarks.bench_peers (generated; see wirex_driver.py).
#include "WireLib/RobotData.h"
#include "WireLib/StructureMatrix.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

static volatile double sink = 0.0;

static double median(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    size_t k = v.size() / 2;
    return v.size() % 2 ? v[k] : 0.5 * (v[k - 1] + v[k]);
}

template <class Work>
static double per_pose_ns(int n, int repeats, Work work) {
    for (int i = 0; i < n; ++i) work(i);
    std::vector<double> times;
    for (int r = 0; r < repeats; ++r) {
        auto t0 = std::chrono::steady_clock::now();
        for (int i = 0; i < n; ++i) work(i);
        auto t1 = std::chrono::steady_clock::now();
        times.push_back(std::chrono::duration<double, std::nano>(t1 - t0).count() / n);
    }
    return median(times);
}

static void print_values(const char* kind, const std::string& name, const MatrixXd& M,
                         int flag = -1) {
    std::printf("%s %s", kind, name.c_str());
    if (flag >= 0) std::printf(" %d", flag);
    for (int i = 0; i < M.rows(); ++i)
        for (int j = 0; j < M.cols(); ++j) std::printf(" %.17g", M(i, j));
    std::printf("\n");
}

int main(int argc, char** argv) {
    if (argc < 2) { std::fprintf(stderr, "usage: driver DATAFILE\n"); return 2; }
    std::ifstream in(argv[1]);
    int cases = 0;
    in >> cases;
    for (int c = 0; c < cases; ++c) {
        std::string name;
        int m, n, repeats, distribution, stiffness;
        double ea;
        in >> name >> m >> n >> repeats >> ea >> distribution >> stiffness;
        if (!in) { std::fprintf(stderr, "bad data file\n"); return 3; }
        std::vector<double> a(3 * m), b(3 * m);
        for (auto& x : a) in >> x;
        for (auto& x : b) in >> x;
        MatrixXd fmin(m, 1), fmax(m, 1), out(m, 1);
        for (int j = 0; j < m; ++j) in >> fmin(j, 0);
        for (int j = 0; j < m; ++j) in >> fmax(j, 0);
        std::vector<Vector3d> r(n);
        std::vector<Matrix3d> R(n);
        std::vector<MatrixXd> w(n), f(n);
        for (int i = 0; i < n; ++i) {
            double x, y, z;
            in >> x >> y >> z;
            r[i] = Vector3d(x, y, z);
            for (int k = 0; k < 9; ++k) in >> R[i](k / 3, k % 3);
            w[i] = MatrixXd(6, 1);
            for (int k = 0; k < 6; ++k) in >> w[i](k, 0);
            f[i] = MatrixXd(m, 1);
            for (int k = 0; k < m; ++k) in >> f[i](k, 0);
        }
        if (!in) { std::fprintf(stderr, "bad data file (case %s)\n", name.c_str()); return 3; }

        PCRL::CRobotData robot(m, PCRL::CRobotData::MP3R3T);
        for (int j = 0; j < m; ++j) {
            robot.setBase(j, Vector3d(a[3 * j], a[3 * j + 1], a[3 * j + 2]));
            robot.setPlatform(j, Vector3d(b[3 * j], b[3 * j + 1], b[3 * j + 2]));
        }
        robot.setForceLimits(fmin(0, 0), fmax(0, 0));
        PCRL::CForceDistribution fd(robot);
        PCRL::CStiffness st(robot);
        st.setStiffnessCoefficient(ea);
        for (int j = 0; j < m; ++j) st.setAdditionalCableLength(j, 0.0);

        MatrixXd AT;
        fd.getStructureMatrix(r[0], R[0]);
        fd.getMatrix(AT);
        print_values("matrix", name, AT);
        if (distribution) {
            int ok = fd.getDistributionClosedForm(w[0], fmin, fmax, out);
            print_values("closed_form", name, out, ok);
            ok = fd.getDistributionAdvancedClosedForm(w[0], fmin, fmax, out);
            print_values("improved", name, out, ok);
            int solved = 0;
            for (int i = 0; i < n; ++i) {
                fd.getStructureMatrix(r[i], R[i]);
                bool within = fd.getDistributionAdvancedClosedForm(w[i], fmin, fmax, out);
                for (int j = 0; j < m; ++j)
                    within = within && out(j, 0) >= fmin(j, 0) * (1 - 1e-9) - 1e-9
                             && out(j, 0) <= fmax(j, 0) * (1 + 1e-9) + 1e-9;
                solved += within;
            }
            std::printf("solved %s %d %d\n", name.c_str(), solved, n);
            double t = per_pose_ns(n, repeats, [&](int i) {
                fd.getStructureMatrix(r[i], R[i]);
                fd.getDistributionClosedForm(w[i], fmin, fmax, out);
                sink = sink + out(0, 0);
            });
            std::printf("time %s closed_form %.6g\n", name.c_str(), t);
            t = per_pose_ns(n, repeats, [&](int i) {
                fd.getStructureMatrix(r[i], R[i]);
                fd.getDistributionAdvancedClosedForm(w[i], fmin, fmax, out);
                sink = sink + out(0, 0);
            });
            std::printf("time %s improved %.6g\n", name.c_str(), t);
        }
        if (stiffness) {
            st.StiffnessMatrixMain(r[0], R[0], f[0]);
            print_values("stiffness", name, st.getStiffnessMatrix());
            double t = per_pose_ns(n, repeats, [&](int i) {
                sink = sink + st.StiffnessMatrixMain(r[i], R[i], f[i]);
            });
            std::printf("time %s stiffness %.6g\n", name.c_str(), t);
        }
        std::fflush(stdout);
    }
    return 0;
}
"""


def find_compiler(cxx: str | None) -> str | None:
    """The C++ compiler to use: ``cxx``, else ``$CXX``, else ``g++``; None if it is not
    on the PATH."""
    name = cxx or os.environ.get("CXX") or "g++"
    return shutil.which(name)
