"""The [physical] section and disturbance.model: parsing, and the errors that name the field."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from tubempc.config import ConfigError, load_config


def _write(tmp_path: Path, text: str) -> Path:
    p = tmp_path / "physical.toml"
    p.write_text(text, encoding="utf-8")
    return p


def test_the_physical_scenarios_parse_with_the_packaged_section() -> None:
    default = load_config()
    assert default.disturbance.model == "drawn"
    for name in ("bennu-tag-physical", "bennu-paper-physical"):
        cfg = load_config(scenario=name)
        assert cfg.disturbance.model == "physical"
        assert cfg.simulation.truth_shape_subdivisions == 24
        p = cfg.physical
        assert p.n_plates == 10 and p.plate_normal_B.shape == (10, 3) and p.plate_center_B.shape == (10, 3)
        assert p.mass == 2110.0 and p.mass_error == 0.02 and p.solar_pressure == pytest.approx(4.56e-6)
        assert p.core_density == -126.0 and p.lobe_density == -189.0
        np.testing.assert_array_equal(p.lobe_center_A, [150.0, 0.0, 0.0])
    # the paper's mission; a partial file's drawn growth is an own mission's (unused without a draw)
    paper = load_config(scenario="bennu-paper-physical")
    physical = {"disturbance.model": "physical", "simulation.truth_shape_subdivisions": 24, "disturbance.growth_r": 1.0}
    # and the campaigns' dispersions (docs/model.md "Dispersions of the physical environment")
    dispersions = {
        "disturbance.scale_error_p": 0.01,
        "disturbance.misalignment_p": "0.2 deg",
        "disturbance.scale_error_r": 0.01,
        "disturbance.misalignment_r": "0.2 deg",
        "physical.mass_error_dispersion": 0.02,
        "physical.inertia_scale_dispersion": [0.03, 0.03, 0.03],
        "physical.inertia_products_dispersion": {"value": [10.0, 10.0, 10.0], "unit": "kg m^2"},
        "physical.center_of_mass_dispersion_B": {"value": [0.02, 0.02, 0.05], "unit": "m"},
        "physical.plate_specular_dispersion": 0.05,
        "physical.plate_diffuse_dispersion": 0.02,
        "physical.core_density_dispersion": "63 kg/m^3",
        "physical.lobe_density_dispersion": "63 kg/m^3",
    }
    assert paper == default.with_overrides({**physical, **dispersions})


def test_any_number_of_plates_in_any_unit(tmp_path: Path) -> None:
    cfg = load_config(
        _write(
            tmp_path,
            "[physical]\n"
            'plate_area = { value = [1e4, 2e4], unit = "cm^2" }\n'
            "plate_normal_B = [[0.0, 0.0, 2.0], [1.0, 0.0, 0.0]]\n"
            'plate_center_B = { value = [[0.0, 0.0, 10.0], [0.0, 50.0, 0.0]], unit = "cm" }\n'
            "plate_specular = [0.5, 0.0]\n"
            "plate_diffuse = [0.5, 0.2]\n",
        )
    )
    p = cfg.physical
    assert p.n_plates == 2
    np.testing.assert_allclose(p.plate_area, [1.0, 2.0])
    np.testing.assert_allclose(p.plate_center_B, [[0.0, 0.0, 0.1], [0.0, 0.5, 0.0]])


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ('[disturbance]\nmodel = "random"', r"disturbance\.model: expected one of \['drawn', 'physical'\]"),
        ("[physical]\nmass_error = 0.6", r"physical\.mass_error: expected in \(-0\.5, 0\.5\)"),
        ('[physical]\nmass = "-3 kg"', r"physical\.mass: expected > 0"),
        ('[physical]\nmass = "3 m"', r"physical\.mass: expected mass \[kg\]"),
        ("[physical]\ninertia_scale = [1.0, 2.5, 1.0]", r"physical\.inertia_scale: expected each in \(0\.5, 2\)"),
        (
            '[physical]\nplate_area = { value = [], unit = "m^2" }',
            r"physical\.plate_area\.value: expected shape \(n,\) with n >= 1",
        ),
        (
            "[physical]\nplate_normal_B = [1.0, 0.0, 0.0]",
            r"physical\.plate_normal_B: expected shape \(n, 3\) with n >= 1",
        ),
        (
            "[physical]\nplate_normal_B = [[1.0, 0.0, 0.0], [0.0, 0.0, 0.0]]",
            r"physical\.plate_normal_B: expected every row non-zero",
        ),
        (
            "[physical]\nplate_specular = [0.1, 0.1, 0.1]",
            r"physical\.plate_specular: 3 entries, but physical\.plate_area has 10 \(one per plate\)",
        ),
        (
            "[physical]\nplate_specular = [0.9, 0.1, 0.1, 0.1, 0.1, 0.1, 0.08, 0.05, 0.08, 0.05]",
            r"physical\.plate_diffuse: plate 0: specular \+ diffuse = 1\.2 exceeds 1",
        ),
        ("[physical]\nplate_diffuse = [1.3, 0.3, 0.3, 0.3, 0.3, 0.3, 0.02, 0.25, 0.02, 0.25]", r"physical\.plate_diffuse"),
        ("[physical]\ncore_scale = 1.0", r"physical\.core_scale: expected in \(0, 1\)"),
        ('[physical]\nlobe_density = "3 m"', r"physical\.lobe_density: expected density"),
        ("[physical]\nsrp = 1", r"physical\.srp: expected true or false"),
        (
            '[disturbance]\nmodel = "physical"\n[simulation]\nsrp_scale = 1.5',
            r"simulation\.srp_scale: must be 1 with disturbance\.model = \"physical\"",
        ),
        ("[physical]\nplates = 3", r"physical\.plates: unknown field"),
    ],
)
def test_errors_name_the_field(tmp_path: Path, text: str, message: str) -> None:
    path = _write(tmp_path, text + "\n")
    with pytest.raises(ConfigError, match=message) as info:
        load_config(path)
    assert str(path) in str(info.value)


def test_a_drawn_file_with_srp_scale_keeps_it() -> None:
    cfg = load_config().with_overrides({"simulation.srp_scale": 1.5})
    assert cfg.simulation.srp_scale == 1.5 and cfg.disturbance.model == "drawn"
    with pytest.raises(ConfigError, match=re.escape("simulation.srp_scale")):
        cfg.with_overrides({"disturbance.model": "physical"})
