"""``python -m benchmarks.bench_peers``: the toolkit's side alone, the arguments, and the
WireX driver built and run against a small fake WireX source tree (the fixture below:
WireLib's class and method names with WireX's documented conventions, no Eigen), whose
answers must reproduce the toolkit's structure matrix, closed form and elastic
stiffness on the same poses."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

from benchmarks import bench_peers, peers_toolkit
from benchmarks import wirex_driver as wx

HAS_GXX = shutil.which("g++") is not None
needs_gxx = pytest.mark.skipif(
    not HAS_GXX, reason="no g++ on this machine: the WireX driver cannot be built"
)

_ROBOT_DATA_H = r"""#pragma once
#include <cmath>
#include <vector>
namespace fake {
struct MatrixXd {
    int r = 0, c = 0;
    std::vector<double> d;
    MatrixXd() {}
    MatrixXd(int rows, int cols) : r(rows), c(cols), d(rows * cols, 0.0) {}
    double& operator()(int i, int j) { return d[i * c + j]; }
    double operator()(int i, int j) const { return d[i * c + j]; }
    double& operator()(int i) { return d[i]; }
    double operator()(int i) const { return d[i]; }
    int rows() const { return r; }
    int cols() const { return c; }
};
struct Vector3d {
    double v[3] = {0, 0, 0};
    Vector3d() {}
    Vector3d(double x, double y, double z) : v{x, y, z} {}
    double operator()(int i) const { return v[i]; }
};
struct Matrix3d {
    double v[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
    double& operator()(int i, int j) { return v[3 * i + j]; }
    double operator()(int i, int j) const { return v[3 * i + j]; }
};
}  // namespace fake
using fake::Matrix3d;
using fake::MatrixXd;
using fake::Vector3d;
namespace PCRL {
class CRobotData {
public:
    typedef enum { MP3T = 4, MP3R3T = 32 } MotionPatternType;
    double fmin = 0, fmax = 0;
    explicit CRobotData(const unsigned int& now = 7, const MotionPatternType mp = MP3R3T)
        : base(now), platform(now) {}
    void setBase(const int& i, const Vector3d& b) { base[i] = b; }
    void setPlatform(const int& i, const Vector3d& p) { platform[i] = p; }
    void setForceLimits(const double& a, const double& b) { fmin = a; fmax = b; }
    const Vector3d& getBase(const int& i) { return base[i]; }
    const Vector3d& getPlatform(const int& i) { return platform[i]; }
    int getNow() const { return (int)base.size(); }
    int getDof() const { return 6; }
private:
    std::vector<Vector3d> base, platform;
};
}  // namespace PCRL
"""

_STRUCTURE_MATRIX_H = r"""#pragma once
#include "RobotData.h"
namespace PCRL {
class CStructureMatrix {
protected:
    CRobotData* pRobot;
    MatrixXd AT;
    std::vector<double> length;
public:
    explicit CStructureMatrix(CRobotData& robot) : pRobot(&robot) {}
    bool getStructureMatrix(const Vector3d& r, const Matrix3d& R);
    void getMatrix(MatrixXd& At) const { At = AT; }
};
class CForceDistribution : public CStructureMatrix {
public:
    explicit CForceDistribution(CRobotData& robot) : CStructureMatrix(robot) {}
    bool getDistributionClosedFormCore(MatrixXd& AT, MatrixXd& w, MatrixXd& f_ref,
                                       MatrixXd& f_wires);
    bool getDistributionClosedForm(MatrixXd& w, MatrixXd& f_min, MatrixXd& f_max,
                                   MatrixXd& f_wires);
    bool getDistributionAdvancedClosedForm(MatrixXd& AT, MatrixXd& w, MatrixXd& f_min,
                                           MatrixXd& f_max, MatrixXd& f_wires);
    bool getDistributionAdvancedClosedForm(MatrixXd& w, MatrixXd& f_min, MatrixXd& f_max,
                                           MatrixXd& f_wires)
        { return getDistributionAdvancedClosedForm(AT, w, f_min, f_max, f_wires); }
    bool getDistributionQuadraticProgramming(MatrixXd& w, MatrixXd& f_wires);
};
class CStiffness : public CStructureMatrix {
    double k = 0;
    MatrixXd l_additional, K;
public:
    explicit CStiffness(CRobotData& robot)
        : CStructureMatrix(robot), l_additional(robot.getNow(), 1) {}
    void setStiffnessCoefficient(const double& k_) { k = k_; }
    void setAdditionalCableLength(const int i, const double& l) { l_additional(i) = l; }
    bool StiffnessMatrixMain(const Vector3d& r, const Matrix3d& R, const MatrixXd& f);
    MatrixXd getStiffnessMatrix() { return K; }
};
}  // namespace PCRL
"""

_STRUCTURE_MATRIX_CPP = r"""#include "StructureMatrix.h"
extern "C" int cvxgen_solve(void);  // an optional solver the fake tree does not have
namespace PCRL {
bool CStructureMatrix::getStructureMatrix(const Vector3d& r, const Matrix3d& R) {
    int m = pRobot->getNow();
    AT = MatrixXd(6, m);
    length.assign(m, 0.0);
    for (int i = 0; i < m; ++i) {
        double P[3], u[3];
        for (int a = 0; a < 3; ++a) {
            P[a] = 0;
            for (int b = 0; b < 3; ++b) P[a] += R(a, b) * pRobot->getPlatform(i)(b);
            u[a] = pRobot->getBase(i)(a) - r(a) - P[a];
        }
        double L = std::sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
        length[i] = L;
        for (int a = 0; a < 3; ++a) u[a] /= L;
        for (int a = 0; a < 3; ++a) AT(a, i) = u[a];
        AT(3, i) = P[1] * u[2] - P[2] * u[1];
        AT(4, i) = P[2] * u[0] - P[0] * u[2];
        AT(5, i) = P[0] * u[1] - P[1] * u[0];
    }
    return true;
}
// f = f_ref - A^T' (A A^T')^-1 (w + A f_ref), A = AT (n x m), by Gaussian elimination
bool CForceDistribution::getDistributionClosedFormCore(MatrixXd& A, MatrixXd& w,
                                                       MatrixXd& f_ref, MatrixXd& f) {
    int n = A.rows(), m = A.cols();
    if (m < n) return false;
    std::vector<double> M(n * (n + 1));
    for (int i = 0; i < n; ++i) {
        double rhs = w(i);
        for (int k = 0; k < m; ++k) rhs += A(i, k) * f_ref(k);
        for (int j = 0; j < n; ++j) {
            double s = 0;
            for (int k = 0; k < m; ++k) s += A(i, k) * A(j, k);
            M[i * (n + 1) + j] = s;
        }
        M[i * (n + 1) + n] = rhs;
    }
    for (int p = 0; p < n; ++p) {
        int best = p;
        for (int i = p + 1; i < n; ++i)
            if (std::fabs(M[i * (n + 1) + p]) > std::fabs(M[best * (n + 1) + p])) best = i;
        for (int j = 0; j <= n; ++j) std::swap(M[p * (n + 1) + j], M[best * (n + 1) + j]);
        for (int i = p + 1; i < n; ++i) {
            double q = M[i * (n + 1) + p] / M[p * (n + 1) + p];
            for (int j = p; j <= n; ++j) M[i * (n + 1) + j] -= q * M[p * (n + 1) + j];
        }
    }
    std::vector<double> y(n);
    for (int i = n - 1; i >= 0; --i) {
        double s = M[i * (n + 1) + n];
        for (int j = i + 1; j < n; ++j) s -= M[i * (n + 1) + j] * y[j];
        y[i] = s / M[i * (n + 1) + i];
    }
    f = MatrixXd(m, 1);
    for (int k = 0; k < m; ++k) {
        double s = 0;
        for (int i = 0; i < n; ++i) s += A(i, k) * y[i];
        f(k) = f_ref(k) - s;
    }
    return true;
}
bool CForceDistribution::getDistributionClosedForm(MatrixXd& w, MatrixXd& f_min,
                                                   MatrixXd& f_max, MatrixXd& f_wires) {
    MatrixXd f_ref(f_min.rows(), 1);
    for (int k = 0; k < f_min.rows(); ++k) f_ref(k) = 0.5 * (f_min(k) + f_max(k));
    return getDistributionClosedFormCore(AT, w, f_ref, f_wires);
}
// the closed form; the cable of the largest violation fixed at its bound, recursively
bool CForceDistribution::getDistributionAdvancedClosedForm(MatrixXd& A, MatrixXd& w,
        MatrixXd& f_min, MatrixXd& f_max, MatrixXd& f_wires) {
    int m = A.cols(), n = A.rows(), index = -1;
    MatrixXd f_ref(m, 1);
    for (int k = 0; k < m; ++k) f_ref(k) = 0.5 * (f_min(k) + f_max(k));
    if (!getDistributionClosedFormCore(A, w, f_ref, f_wires)) return false;
    double violation = 0;
    for (int i = 0; i < m; ++i) {
        if (f_min(i) - f_wires(i) > violation) { violation = f_min(i) - f_wires(i); index = i; }
        if (f_wires(i) - f_max(i) > violation) { violation = f_wires(i) - f_max(i); index = i + m; }
    }
    if (index == -1) return true;
    if (m == n) return false;
    int fixed = index % m;
    double value = index < m ? f_min(fixed) : f_max(fixed);
    MatrixXd Ared(n, m - 1), lo(m - 1, 1), hi(m - 1, 1), wred = w, fred;
    for (int i = 0, j = 0; i < m; ++i) {
        if (i == fixed) continue;
        for (int a = 0; a < n; ++a) Ared(a, j) = A(a, i);
        lo(j) = f_min(i);
        hi(j++) = f_max(i);
    }
    for (int a = 0; a < n; ++a) wred(a) += A(a, fixed) * value;
    bool ok = getDistributionAdvancedClosedForm(Ared, wred, lo, hi, fred);
    for (int i = 0, j = 0; i < m; ++i) f_wires(i) = i == fixed ? value : fred(j++);
    return ok;
}
bool CForceDistribution::getDistributionQuadraticProgramming(MatrixXd& w, MatrixXd& f) {
    return cvxgen_solve() == 0;
}
// K = AT diag(k / (l + l_additional)) AT^T: the elastic part, as WireX's K
bool CStiffness::StiffnessMatrixMain(const Vector3d& r, const Matrix3d& R, const MatrixXd& f) {
    getStructureMatrix(r, R);
    int m = pRobot->getNow();
    K = MatrixXd(6, 6);
    for (int a = 0; a < 6; ++a)
        for (int b = 0; b < 6; ++b)
            for (int i = 0; i < m; ++i)
                K(a, b) += AT(a, i) * AT(b, i) * k / (length[i] + l_additional(i));
    return true;
}
}  // namespace PCRL
"""


def make_fake_wirex(top: Path) -> Path:
    """A fake WireX tree under ``top``: WireLib's robot model and structure matrix, an
    optional source that does not compile, and a reference to an absent solver."""
    lib = top / "WireLib"
    lib.mkdir(parents=True)
    (lib / "RobotData.h").write_text(_ROBOT_DATA_H)
    (lib / "RobotData.cpp").write_text('#include "RobotData.h"\n')
    (lib / "StructureMatrix.h").write_text(_STRUCTURE_MATRIX_H)
    (lib / "StructureMatrix.cpp").write_text(_STRUCTURE_MATRIX_CPP)
    (lib / "Kinematics.cpp").write_text('#include "levmar/absent.h"\n')
    return top


@pytest.fixture(scope="module")
def cases() -> list[peers_toolkit.PeerCase]:
    return peers_toolkit.peer_cases(12, seed=3)


@pytest.fixture(scope="module")
def driven(
    tmp_path_factory: pytest.TempPathFactory, cases: list[peers_toolkit.PeerCase]
) -> tuple[wx.Build, wx.DriverResult]:
    """The driver built against the fake tree and run on the cases."""
    if not HAS_GXX:
        pytest.skip("no g++ on this machine: the WireX driver cannot be built")
    folder = tmp_path_factory.mktemp("driver")
    top = make_fake_wirex(folder / "wirex")
    build = wx.build_driver(wx.check_checkout(top), folder, "g++")
    data = folder / "cases.txt"
    wx.write_cases([peers_toolkit.wirex_case(c) for c in cases], data, repeats=2)
    return build, wx.run_driver(build, data)


def test_cases_hold_what_their_names_say(cases: list[peers_toolkit.PeerCase]) -> None:
    names = [c.name for c in cases]
    assert names == ["cogiro_inside", "cogiro_active", "ipanema_active", "cogiro_stiffness"]
    for case in cases[:3]:
        t = peers_toolkit.centred_unbounded(case.robot, case.poses)
        inside = np.all((t > case.robot.t_min) & (t < case.robot.t_max), axis=1)
        assert inside.all() if case.name.endswith("inside") else not inside.any()
        assert np.all(case.tensions >= case.robot.t_min - 1e-6)
        assert np.all(case.tensions <= case.robot.t_max + 1e-6)


def test_data_file_round_trips(tmp_path: Path, cases: list[peers_toolkit.PeerCase]) -> None:
    case = peers_toolkit.wirex_case(cases[1])
    path = tmp_path / "cases.txt"
    wx.write_cases([case], path, repeats=5)
    words = path.read_text().split()
    assert words[:8] == ["1", "cogiro_active", "8", "12", "5", repr(case.EA), "1", "0"]
    values = np.array(words[8:], dtype=float)
    m, n = case.m, case.n
    head = np.concatenate([case.anchors.ravel(), case.attachments.ravel(), case.f_min, case.f_max])
    assert np.array_equal(values[: len(head)], head)
    rows = values[len(head) :].reshape(n, 3 + 9 + 6 + m)
    assert np.array_equal(rows[:, :3], case.positions)
    assert np.array_equal(rows[:, 3:12].reshape(n, 3, 3), case.rotations)
    robot, poses = cases[1].robot, cases[1].poses
    assert np.array_equal(rows[:, 12:18], -robot.required_wrench(poses))
    assert np.array_equal(rows[:, 18:], cases[1].tensions)


@needs_gxx
def test_driver_reproduces_the_toolkit(
    driven: tuple[wx.Build, wx.DriverResult], cases: list[peers_toolkit.PeerCase]
) -> None:
    build, result = driven
    assert build.skipped == ("WireLib/Kinematics.cpp",)
    assert build.unresolved == ("cvxgen_solve",)
    for case in cases:
        A = case.robot.structure_matrices(case.poses[:1])[0]
        got = result.checks[("matrix", case.name)].reshape(A.shape)
        np.testing.assert_allclose(got, A, atol=1e-12)
    inside = cases[0]
    closed = result.checks[("closed_form", "cogiro_inside")]
    improved = result.checks[("improved", "cogiro_inside")]
    assert closed[0] == 1 and improved[0] == 1
    np.testing.assert_allclose(closed[1:], inside.tensions[0], atol=1e-7)
    np.testing.assert_allclose(improved[1:], inside.tensions[0], atol=1e-7)
    assert result.solved["cogiro_inside"] == (12, 12)
    robot = inside.robot
    A = robot.structure_matrices(inside.poses[:1])[0]
    L = robot.inverse_kinematics(inside.poses[:1])[0][0]
    K = A @ np.diag(robot.cable.EA / L) @ A.T
    np.testing.assert_allclose(
        result.checks[("stiffness", "cogiro_stiffness")].reshape(6, 6), K, rtol=1e-10, atol=1e-6
    )
    works = {
        ("cogiro_inside", "closed_form"),
        ("cogiro_inside", "improved"),
        ("cogiro_active", "improved"),
        ("ipanema_active", "improved"),
        ("cogiro_stiffness", "stiffness"),
    }
    assert works <= set(result.times)
    assert all(t > 0 for t in result.times.values())


@needs_gxx
def test_command_with_the_fake_tree_prints_both_sides(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    top = make_fake_wirex(tmp_path / "wirex")
    out = tmp_path / "peers.md"
    code = bench_peers.main(
        ["--wirex", str(top), "--poses", "8", "--repeats", "2", "--out", str(out)]
    )
    text = capsys.readouterr().out
    assert code == 0
    assert "not run" not in text
    assert "WireLib/Kinematics.cpp" in text and "cvxgen_solve" in text
    assert (
        "improved closed form solves 8 of 8 poses of cogiro_inside within the bounds "
        "(the toolkit: 8 certified optimal)"
    ) in text
    table = out.read_text()
    assert "| work, per pose | WireX (C++) | toolkit | toolkit / WireX |" in table
    rows = [line for line in table.splitlines() if line.startswith("| CoGiRo")]
    assert len(rows) == 2
    assert all(line.rstrip(" |").endswith("x") for line in rows)
    assert "(improved, checks bounds)" in rows[0]


def test_without_wirex_the_toolkit_side_runs_and_says_what_is_missing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "peers.md"
    code = bench_peers.main(["--poses", "6", "--repeats", "1", "--out", str(out)])
    text = capsys.readouterr().out
    assert code == 0
    assert "WireX: no checkout given (--wirex DIR" in text
    assert '`distribute(..., "centered", "closed_form")` batch' in text
    assert "`PoseStiffness` one pose per call" in text
    assert "IPAnema 3, bounds active" in text
    assert text.count("| not run |") == 4
    assert "WireX: no checkout given" in out.read_text()


def test_without_a_compiler_the_toolkit_side_runs(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    top = make_fake_wirex(tmp_path / "wirex")
    code = bench_peers.main(
        ["--wirex", str(top), "--cxx", "no-such-compiler-xyz", "--poses", "4", "--repeats", "1"]
    )
    text = capsys.readouterr().out
    assert code == 0
    assert "no C++ compiler (no-such-compiler-xyz not found" in text
    assert "`Distributor` loop" in text


@pytest.mark.parametrize("make", ["missing", "empty"])
def test_a_folder_that_is_no_wirex_checkout_is_refused(
    make: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    folder = tmp_path / "not_wirex"
    if make == "empty":
        folder.mkdir()
        (folder / "README.md").write_text("something else\n")
    with pytest.raises(SystemExit) as info:
        bench_peers.main(["--wirex", str(folder)])
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert f"--wirex {folder}" in err
    assert "checkout of WireX's public source" in err
    assert ("missing WireLib/RobotData.h" in err) == (make == "empty")


@needs_gxx
def test_a_driver_that_does_not_compile_is_reported(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    top = make_fake_wirex(tmp_path / "wirex")
    (top / "WireLib" / "StructureMatrix.cpp").write_text("this is not C++\n")
    code = bench_peers.main(["--wirex", str(top), "--poses", "4", "--repeats", "1"])
    text = capsys.readouterr().out
    assert code == 1
    assert "WireX: StructureMatrix.cpp did not compile" in text
    assert "`Distributor` loop" in text


def test_table_cells() -> None:
    assert bench_peers.fmt_time(850.4) == "850 ns"
    assert bench_peers.fmt_time(3712.0) == "3.71 us"
    side = bench_peers.WirexSide(
        results={
            "-O2": wx.DriverResult(times={("cogiro_stiffness", "stiffness"): 3700.0}),
            "-O3": wx.DriverResult(times={("cogiro_stiffness", "stiffness"): 2300.0}),
        }
    )
    toolkit = {
        ("cogiro_stiffness", "stiffness_batch"): 12600.0,
        ("cogiro_stiffness", "stiffness_loop"): 9000.0,
    }
    (row,) = bench_peers.table_rows(toolkit, side)
    assert row.wirex == "3.7 us (-O2), 2.3 us (-O3)"
    assert row.ratio == "3.4-5.5x, 2.4-3.9x"
