"""Parameter studies of the reference robot (benchmarks.studies)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

import catenary
from benchmarks import cli, studies
from benchmarks.studies import (
    NOMINAL_ASPECT_RATIO,
    NOMINAL_POND_AREA,
    STUDY_PARAMETERS,
    material_study,
    study_robot,
    sweep,
)
from tension_opt.errors import InvalidInputError

OFFSET = 6.1  # tower offset of the reference robot (m)
NOMINAL = [0.0, 0.0, 0.0]
POSES = [[0.0, 0.0, 0.0], [8.0, -5.0, 2.0]]


def _pond(robot) -> tuple[float, float]:
    """Pond length (x) and width (y) of an algae-harvester robot from its anchors (m)."""
    half = robot.anchors[:, :2].max(axis=0) - OFFSET
    assert np.allclose(robot.anchors[:, :2].min(axis=0), -robot.anchors[:, :2].max(axis=0))
    return 2.0 * half[0], 2.0 * half[1]


# ----------------------------------------------------------------------------
# the study's numbers


def test_material_study_reproduces_published_sag():
    """Nominal-pose D: 207.4-207.5 mm (steel), 4.2 (polyethylene), 6.6 mm (Kevlar)."""
    table = material_study(["steel", "polyethylene", "kevlar"], poses=NOMINAL,
                           models=("thesis",))
    assert len(table) == 3 * 4
    assert (table["status_thesis"] == "converged").all()
    D = 1e3 * table.groupby("value", sort=False)["D_thesis"].agg(["min", "max"])
    assert list(D.index) == ["steel", "polyethylene", "kevlar"]
    assert np.allclose(D["min"], D["max"])  # four equal cables at the centre
    assert 207.4 - 0.2 <= D.loc["steel", "max"] <= 207.5 + 0.2
    assert D.loc["polyethylene", "max"] == pytest.approx(4.2, abs=0.2)
    assert D.loc["kevlar", "max"] == pytest.approx(6.6, abs=0.2)
    first = table.groupby("value", sort=False).first()
    assert first.loc["kevlar", "material"] == "aramid"
    assert first["density"].tolist() == pytest.approx([7860.0, 1150.0, 1440.0])
    assert np.isinf(first["EA"]).all()  # the study's inextensible cables
    assert first.loc["steel", "breaking_load"] == pytest.approx(279.1e3, rel=1e-3)
    assert np.isnan(first.loc["kevlar", "breaking_load"])


@pytest.mark.parametrize(("parameter", "value"),
                         [("diameter", 0.020), ("density", 7860.0), ("mass", 258.6)])
def test_nominal_point_equals_snapshot_1(parameter, value):
    """At the nominal value every sweep gives the published snapshot 1 (T 4714.6 N, L 56.7 m)."""
    table = sweep(parameter, [value], poses=NOMINAL)
    assert len(table) == 4
    assert (table["status_lp"] == "optimal").all()
    assert np.abs(table["T_lp"] - 4714.6).max() <= 0.15
    assert np.abs(table["T_pinv"] - 4714.6).max() <= 0.15
    assert np.abs(table["L_thesis"] - 56.7).max() <= 0.01
    assert np.abs(1e3 * table["D_thesis"] - 207.4).max() <= 0.2
    assert np.allclose(table["T_thesis"], table["T_lp"], rtol=1e-9)  # LP tension imposed
    assert table["iterations_thesis"].eq(0).all()
    assert (table["status_coupled"] == "converged").all()


def test_default_sweeps_cover_the_study_ranges():
    assert STUDY_PARAMETERS["diameter"].defaults[0] == 0.010
    assert STUDY_PARAMETERS["diameter"].defaults[-1] == 0.030
    assert STUDY_PARAMETERS["density"].defaults[::9] == (1000.0, 10000.0)
    assert STUDY_PARAMETERS["mass"].defaults[::12] == (100.0, 400.0)
    ratios = STUDY_PARAMETERS["aspect_ratio"].defaults
    assert min(ratios) == 0.25 and max(ratios) == 4.0
    table = sweep("diameter", models=("thesis",))
    n_values = len(STUDY_PARAMETERS["diameter"].defaults)
    assert len(table) == n_values * 2 * 4
    assert table[["x", "y", "z"]].drop_duplicates().values.tolist() == POSES
    assert list(table["point"].unique()) == list(range(n_values))


# ----------------------------------------------------------------------------
# analytic scalings


def test_small_sag_follows_d4_and_the_taut_string_formula():
    """D ~ (w cos(theta))^2 Le^3 / (24 T^2), so D grows as d^4 at fixed tension."""
    d1, d2 = 0.002, 0.004
    table = sweep("diameter", [d1, d2], poses=POSES, models=("thesis",))
    assert (table["status_thesis"] == "converged").all()
    rise = 7.6 - table["z"]
    cos = np.sqrt(table["Le"] ** 2 - rise**2) / table["Le"]
    approx = (table["w"] * cos) ** 2 * table["Le"] ** 3 / (24.0 * table["T_lp"] ** 2)
    assert np.allclose(table["D_thesis"], approx, rtol=0.01)
    D = table.pivot_table(index=["pose", "cable"], columns="value", values="D_thesis")
    ratio = D[d2] / D[d1]
    assert np.allclose(ratio, (d2 / d1) ** 4, rtol=0.01)


@pytest.mark.parametrize(("parameter", "values"),
                         [("diameter", [0.010, 0.020, 0.030]),
                          ("density", [1000.0, 5000.0, 10000.0])])
def test_straight_tensions_do_not_depend_on_the_cable(parameter, values):
    table = sweep(parameter, values, poses=POSES, models=("thesis",))
    for column in ("T_lp", "T_pinv"):
        T = table.pivot_table(index=["pose", "cable"], columns="value", values=column)
        assert np.allclose(T.to_numpy(), T.to_numpy()[:, :1], rtol=1e-12)
    # ... while the sag grows with the cable weight.
    D = table.pivot_table(index=["pose", "cable"], columns="value", values="D_thesis")
    assert (np.diff(D.to_numpy(), axis=1) > 0).all()


def test_tensions_are_proportional_to_the_mass():
    masses = [100.0, 200.0, 400.0]
    table = sweep("mass", masses, poses=POSES, models=("thesis",))
    assert (table["status_lp"] == "optimal").all()
    # t_min = m g follows the mass, so the whole LP scales with it.
    assert np.allclose(table["t_min"], table["mass"] * 9.81)
    for column in ("T_lp", "T_pinv"):
        T = table.pivot_table(index=["pose", "cable"], columns="value", values=column)
        assert np.allclose(T.to_numpy() / np.array(masses), (T[100.0] / 100.0).to_numpy()[:, None],
                           rtol=1e-10)


def test_pond_area_sweep_keeps_the_aspect_ratio():
    areas = [0.5 * NOMINAL_POND_AREA, NOMINAL_POND_AREA, 3.0 * NOMINAL_POND_AREA]
    for area in areas:
        length, width = _pond(study_robot("pond_area", area))
        assert length * width == pytest.approx(area, rel=1e-12)
        assert length / width == pytest.approx(80.9 / 50.0, rel=1e-12)
    length, width = _pond(study_robot("pond_area", NOMINAL_POND_AREA))
    assert (length, width) == pytest.approx((80.9, 50.0), rel=1e-12)
    table = sweep("pond_area", areas, poses=POSES, models=("thesis",))
    points = table.groupby("point").first()
    assert np.allclose(points["pond_length"] * points["pond_width"], areas)
    assert np.allclose(points["pond_length"] / points["pond_width"], NOMINAL_ASPECT_RATIO)
    # Larger pond, longer cables at the centre.
    Le = table[table["pose"] == 0].groupby("point")["Le"].first()
    assert (np.diff(Le) > 0).all()


def test_aspect_ratio_sweep_keeps_the_area():
    ratios = [0.25, 1.0, 4.0]
    for ratio in ratios:
        length, width = _pond(study_robot("aspect_ratio", ratio))
        assert length * width == pytest.approx(NOMINAL_POND_AREA, rel=1e-12)
        assert length / width == pytest.approx(ratio, rel=1e-12)
    table = sweep("aspect_ratio", ratios, poses=POSES, models=("thesis",))
    points = table.groupby("point").first()
    assert np.allclose(points["pond_length"] * points["pond_width"], NOMINAL_POND_AREA)
    assert np.allclose(points["pond_length"] / points["pond_width"], ratios)
    # A square pond is symmetric: the four cables of the centre pose are alike, and the
    # ratios 1/4 and 4 mirror each other at the centre.
    centre = table[table["pose"] == 0].pivot_table(index="cable", columns="value", values="Le")
    assert np.allclose(centre[1.0], centre[1.0].iloc[0])
    assert np.allclose(np.sort(centre[0.25]), np.sort(centre[4.0]))


# ----------------------------------------------------------------------------
# coupled model, failures


def test_coupled_model_balances_the_load_where_converged():
    table = sweep("diameter", [0.010, 0.020, 0.030], poses=POSES, models=("coupled",))
    converged = table["status_coupled"] == "converged"
    assert converged.any()
    assert (table.loc[converged, "residual_coupled"] < 1e-6).all()
    assert (table.loc[converged, "iterations_coupled"] >= 1).all()
    assert table.loc[converged, "L_coupled"].notna().all()
    assert "L_thesis" not in table and "L_difference" not in table


def test_infeasible_and_failed_points_keep_their_rows():
    # A 40 mm steel cable under the light platform carries no taut catenary at the
    # LP tension (thesis), and a very low t_max leaves no feasible tensions at all.
    table = sweep("diameter", [0.020, 0.040], poses=POSES, mass=100.0)
    assert len(table) == 2 * 2 * 4
    heavy = table[table["value"] == 0.040]
    assert (heavy["status_thesis"] == "catenary_failed").all()
    assert heavy["L_thesis"].isna().all() and heavy["D_thesis"].isna().all()
    assert heavy["T_lp"].notna().all()  # the straight statics still has its numbers

    tight = sweep("t_max", [3000.0, 1e5], poses=POSES, models=("thesis",))
    low = tight[tight["value"] == 3000.0]
    assert (low["status_lp"] == "infeasible").all()
    assert low["T_lp"].isna().all() and low["L_thesis"].isna().all()
    assert (low["status_thesis"] == "infeasible").all()
    assert (tight.loc[tight["value"] == 1e5, "status_lp"] == "optimal").all()


def test_a_library_error_is_recorded_not_raised(monkeypatch):
    real = catenary.inverse_kinematics

    def flaky(robot, poses, model="thesis", **kwargs):
        if model == "coupled" and robot.cable.diameter > 0.015:
            raise RuntimeError("solver exploded")
        return real(robot, poses, model=model, **kwargs)

    monkeypatch.setattr(catenary, "inverse_kinematics", flaky)
    table = sweep("diameter", [0.010, 0.020], poses=POSES)
    bad = table[table["value"] == 0.020]
    good = table[table["value"] == 0.010]
    assert (bad["status_coupled"] == "error").all()
    assert bad["L_coupled"].isna().all() and (bad["iterations_coupled"] == -1).all()
    assert bad["note"].str.contains("RuntimeError: solver exploded").all()
    assert (bad["status_thesis"] == "converged").all()
    assert (good["status_coupled"] == "converged").all() and (good["note"] == "").all()


# ----------------------------------------------------------------------------
# executors


def _small_sweep(executor) -> pd.DataFrame:
    return sweep("mass", [150.0, 258.6, 350.0], poses=POSES, executor=executor, chunk_size=1)


def test_process_pool_gives_the_same_table():
    expected = _small_sweep(None)
    pd.testing.assert_frame_equal(_small_sweep("processes:2"), expected)
    table = material_study(["steel", "kevlar"], poses=POSES, executor="processes:2",
                           chunk_size=2)
    pd.testing.assert_frame_equal(table, material_study(["steel", "kevlar"], poses=POSES))


@pytest.mark.filterwarnings("ignore:Port .* is already in use")
def test_dask_cluster_gives_the_same_table():
    distributed = pytest.importorskip("dask.distributed")
    expected = _small_sweep("inprocess")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  host="127.0.0.1", dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        pd.testing.assert_frame_equal(_small_sweep(client), expected)


# ----------------------------------------------------------------------------
# input errors


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda: sweep("diameters"), "unknown study parameter 'diameters'"),
        (lambda: sweep("diameter", [-0.01]), "cable_diameter must be a positive"),
        (lambda: sweep("diameter", [0.0]), "cable_diameter must be a positive"),
        (lambda: sweep("diameter", ["thick"]), "must be numbers"),
        (lambda: sweep("mass", [np.nan]), "must be finite"),
        (lambda: sweep("pond_area", [-1.0]), "pond_area must be > 0"),
        (lambda: sweep("tower_height"), "no default values"),
        (lambda: sweep("diameter", [0.02], colour="red"), "unknown robot override"),
        (lambda: sweep("diameter", [0.02], cable_diameter=0.01), "is swept"),
        (lambda: sweep("density", [1000.0], material="steel"), "sets the cable density"),
        (lambda: sweep("diameter", [0.02], elastic=True), "elastic=True"),
        (lambda: sweep("diameter", [0.02], models=("straight",)), "models must be"),
        (lambda: sweep("diameter", [0.02], poses=[[0, 0]]), "poses must have shape"),
        (lambda: sweep("diameter", [0.02], chunk_size=0), "chunk_size"),
        (lambda: sweep("diameter", [0.02], executor="threads"), "unknown executor"),
        (lambda: sweep("material", ["unobtainium"]), "unknown cable material 'unobtainium'"),
        (lambda: material_study(["steel", "mithril"]), "unknown cable material 'mithril'"),
        (lambda: material_study(["steel"], diameter=-0.02), "cable_diameter must be a positive"),
        (lambda: study_robot("mass", -5.0), "mass must be a positive"),
    ],
)
def test_bad_input_raises_a_clear_error(call, message):
    with pytest.raises(ValueError, match=message):
        call()


def test_unknown_parameter_names_the_known_ones():
    with pytest.raises(InvalidInputError, match="aspect_ratio") as info:
        sweep("area")
    assert "material" in str(info.value)


# ----------------------------------------------------------------------------
# materials in sweeps, command line


def test_elastic_material_stretches_the_cable():
    rigid = sweep("diameter", [0.020], poses=NOMINAL, material="dyneema", models=("thesis",))
    elastic = sweep("diameter", [0.020], poses=NOMINAL, material="dyneema", elastic=True,
                    models=("thesis",))
    EA = catenary.get_material("dyneema").rope_modulus * np.pi / 4 * 0.020**2
    assert np.allclose(elastic["EA"], EA) and np.isinf(rigid["EA"]).all()
    assert (rigid["density"] == 975.0).all() and (rigid["material"] == "dyneema").all()
    # The unstretched length is shorter by about T L / EA.
    stretch = rigid["L_thesis"] - elastic["L_thesis"]
    assert np.allclose(stretch, rigid["T_lp"] * rigid["Le"] / EA, rtol=0.02)


def test_summary_and_command_line(tmp_path, capsys):
    out = tmp_path / "mass.csv"
    code = cli.main(["study", "mass", "--values", "200", "300", "--pose", "0", "0", "0",
                     "--models", "thesis", "--out", str(out), "--no-progress"])
    assert code == 0
    table = pd.read_csv(out)
    assert len(table) == 2 * 4 and set(table["value"]) == {200.0, 300.0}
    printed = capsys.readouterr().out
    assert "max_D_thesis_mm" in printed and "converged" in printed
    summary = studies.summarize(sweep("mass", [200.0, 300.0], poses=POSES))
    assert len(summary) == 4
    assert (summary["sum_T_pinv"] >= summary["sum_T_lp"] - 1e-6).all()
    for argv, message in [
        (["diameter", "--values", "-0.01"], "cable_diameter must be a positive"),
        (["mass", "--values", "abc"], "--values takes numbers"),
        (["mass", "--set", "mass=abc"], "--set takes KEY=NUMBER"),
        (["mass", "--materials", "steel"], "--materials goes with the 'material' sweep"),
    ]:
        with pytest.raises(SystemExit) as stop:
            cli.main(["study", *argv, "--no-progress"])
        assert stop.value.code == 2
        assert message in capsys.readouterr().err


def test_values_may_be_any_iterable_or_one_number():
    expected = sweep("mass", [200.0, 300.0], poses=[[0.0, 0.0, 0.0]], models=("thesis",))
    for values in ((m for m in [200.0, 300.0]), np.array([200.0, 300.0]), (200.0, 300.0)):
        got = sweep("mass", values, poses=[[0.0, 0.0, 0.0]], models=("thesis",))
        pd.testing.assert_frame_equal(got, expected)
    one = sweep("mass", 250.0, poses=[[0.0, 0.0, 0.0]], models=("thesis",))
    assert set(one["value"]) == {250.0}
