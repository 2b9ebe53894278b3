"""Cable catalogue (catenary.materials)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import catenary
from catenary import (
    MATERIALS,
    CableMaterial,
    InvalidCableError,
    breaking_load,
    cable_properties,
    get_material,
    material_names,
)


def test_reference_study_densities_are_kept():
    assert get_material("steel").density == 7860.0
    assert get_material("polyethylene").density == 1150.0
    assert get_material("kevlar").density == 1440.0
    assert 970.0 <= get_material("dyneema").density <= 980.0
    assert get_material("polyester").density == 1380.0


def test_aliases_and_names():
    assert get_material("uhmwpe") is get_material("dyneema")
    assert get_material("Kevlar") is get_material("aramid")
    assert get_material(" STEEL ") is MATERIALS["steel"]
    assert material_names() == ["steel", "dyneema", "aramid", "polyester", "polyethylene"]
    assert set(material_names(aliases=True)) == set(MATERIALS)
    mat = get_material("steel")
    assert get_material(mat) is mat


def test_unknown_material_lists_the_known_ones():
    with pytest.raises(InvalidCableError, match=r"unknown cable material 'wool'.*steel"):
        get_material("wool")
    with pytest.raises(InvalidCableError, match="a name or a CableMaterial"):
        get_material(7860.0)  # type: ignore[arg-type]


def test_line_properties_of_the_study_cable():
    w, EA = cable_properties("steel", 0.020)
    assert float(w) == pytest.approx(7860.0 * math.pi / 4 * 0.020**2 * 9.81)
    assert float(w) == pytest.approx(24.2238, abs=1e-4)  # 2.4693 kg/m in the study
    assert float(EA) == pytest.approx(100e9 * math.pi / 4 * 0.020**2)
    _, EA_material = cable_properties("steel", 0.020, rope=False)
    assert float(EA_material) == pytest.approx(200e9 * math.pi / 4 * 0.020**2)


def test_strengths_and_sources():
    steel = get_material("steel")
    # EN 12385-4: F_min = 0.356 d^2 R_r, d in mm, R_r = 1960 N/mm^2 -> 279.1 kN at 20 mm.
    assert float(breaking_load("steel", 0.020)) == pytest.approx(0.356 * 20**2 * 1960, rel=1e-12)
    assert steel.strength == 1960e6
    assert 0.4 * steel.strength < steel.rope_strength < 0.5 * steel.strength
    dyneema = get_material("dyneema")
    assert 3.3e9 <= dyneema.strength <= 3.9e9  # DSM SK75/SK78
    assert 2.9e9 <= get_material("kevlar").strength <= 3.6e9
    assert get_material("polyester").strength == pytest.approx(1.1e9)
    assert float(breaking_load("polyester", 0.024)) == pytest.approx(88e3, rel=0.01)
    # Unknown values are NaN, not zero.
    assert math.isnan(get_material("kevlar").rope_strength)
    assert math.isnan(get_material("polyethylene").strength)
    assert np.isnan(breaking_load("polyethylene", 0.020))
    for mat in MATERIALS.values():
        assert mat.note, mat.name
        if not math.isnan(mat.rope_strength):
            assert mat.rope_strength < mat.strength  # a rope never beats its fibres


def test_breaking_load_is_vectorised_and_scales_with_the_section():
    d = np.array([[0.010, 0.020], [0.030, 0.040]])
    load = breaking_load("dyneema", d)
    assert load.shape == (2, 2)
    assert np.allclose(load / load[0, 0], (d / 0.010) ** 2)
    fibre = get_material("dyneema").breaking_load(d, rope=False)
    assert np.all(fibre > load)


@pytest.mark.parametrize("bad", [0.0, -0.02, np.nan, np.inf, [0.01, -0.01]])
def test_bad_diameter_raises(bad):
    with pytest.raises(InvalidCableError, match="diameter must be finite and > 0"):
        breaking_load("steel", bad)
    with pytest.raises(InvalidCableError, match="diameter must be finite and > 0"):
        cable_properties("steel", bad)


def test_positional_construction_still_works():
    mat = CableMaterial("hemp", 1500.0, 10e9, 2e9, "natural fibre")
    assert math.isnan(mat.strength) and math.isnan(mat.rope_strength)
    w, _ = mat.line_properties(0.02)
    assert float(w) == pytest.approx(1500.0 * math.pi / 4 * 0.02**2 * 9.81)
    assert catenary.breaking_load(mat, 0.02) != catenary.breaking_load(mat, 0.02)  # NaN
