"""Loading a configuration: a file or a packaged scenario, with the packaged defaults of partial files."""

from __future__ import annotations

import importlib.resources
import tomllib
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from .parse import BORESIGHT_DEFAULTS, Config, parse
from .quantities import ConfigError

#: The packaged paper scenario, under tubempc/data: the defaults of a partial file.
DEFAULT_FILE = "bennu_paper.toml"

#: Fields whose value in the paper scenario (bennu_paper.toml) belongs to that scenario alone: a file
#: that leaves them out (an own mission) gets these instead. The paper scenario's attitude disturbance
#: grows to 2.5x the prior's 3-sigma support (chosen to reproduce the paper's Figs. 10-11); an own
#: mission starts from a stationary disturbance inside the prior's 3-sigma ellipsoid.
OWN_MISSION_DEFAULTS: dict[tuple[str, str], Any] = {
    ("disturbance", "growth_p"): 1.0,
    ("disturbance", "growth_r"): 1.0,
}

#: Packaged scenarios (``tubempc scenarios``): name -> (file under tubempc/data, one-line description).
SCENARIOS: dict[str, tuple[str, str]] = {
    "bennu-paper": (DEFAULT_FILE, "the paper's landing at Bennu's pole (Tables 1-2); the default"),
    "bennu-paper-within-prior": (
        "scenarios/bennu_paper_within_prior.toml",
        "the paper's landing with a stationary attitude disturbance inside the prior's 3-sigma bound",
    ),
    "bennu-equator": (
        "scenarios/bennu_equator.toml",
        "a site near Bennu's equator, approached from hovering 500 m above it; the cone turns with Bennu",
    ),
    "bennu-tag": (
        "scenarios/bennu_tag.toml",
        "touch-and-go at 56 deg N (as OSIRIS-REx's Nightingale) from hovering 125 m above, contact at 0.1 m/s",
    ),
    "bennu-tag-nav": (
        "scenarios/bennu_tag_nav.toml",
        "bennu-tag flown on navigation (camera, altimeter, IMU, star tracker, EKF), a lit site at 180 deg",
    ),
    "bennu-tag-faults": (
        "scenarios/bennu_tag_faults.toml",
        "bennu-tag-nav with one random fault per run and the certified safe abort (the fault campaign)",
    ),
    "bennu-tag-osirisrex": (
        "scenarios/bennu_tag_osirisrex.toml",
        "bennu-tag over the real TAG's 20 min, flown by the OSIRIS-REx-like thrusters and wheels (5 s period)",
    ),
    "bennu-paper-nav": (
        "scenarios/bennu_paper_nav.toml",
        "the paper's landing flown on navigation: a thermal-infrared camera and an altimeter mounted to see the body",
    ),
    "bennu-tag-physical": (
        "scenarios/bennu_tag_physical.toml",
        "bennu-tag in a physical environment: heterogeneous body, flat-plate SRP, gravity gradient, mass and inertia errors",
    ),
    "bennu-paper-physical": (
        "scenarios/bennu_paper_physical.toml",
        "the paper's landing in a physical environment (no drawn disturbance; as bennu-tag-physical)",
    ),
    "itokawa-like": (
        "scenarios/itokawa_like.toml",
        "a generated 535 x 294 x 209 m contact binary (1900 kg/m^3, 12.13 h), a site on its smaller lobe",
    ),
}


def packaged_text(name: str) -> str:
    """The text of a packaged file under tubempc/data ("bennu_paper.toml", "scenarios/...")."""
    return importlib.resources.files("tubempc").joinpath("data", *name.split("/")).read_text(encoding="utf-8")


def _with_boresight_defaults(data: Mapping[str, Any], defaults: Mapping[str, Any]) -> dict[str, Any]:
    """``defaults`` with the :data:`BORESIGHT_DEFAULTS` fields set to the boresight of ``data`` (the
    file's spacecraft.boresight_B, else the default's)."""
    spacecraft = data.get("spacecraft", {})
    given = spacecraft.get("boresight_B") if isinstance(spacecraft, Mapping) else None
    boresight = defaults["spacecraft"]["boresight_B"] if given is None else given
    out = {name: dict(section) for name, section in defaults.items()}
    for section, name in BORESIGHT_DEFAULTS:
        out[section][name] = boresight
    return out


def _packaged_defaults() -> dict[str, Any]:
    """The defaults of partial files: the packaged paper scenario's raw TOML content with
    :data:`OWN_MISSION_DEFAULTS` in place of the paper's engineered disturbance growth."""
    data = tomllib.loads(packaged_text(DEFAULT_FILE))
    for (section, name), value in OWN_MISSION_DEFAULTS.items():
        data[section][name] = value
    return data


def _check_shape_unit(data: Mapping[str, Any], source: str) -> None:
    """A partial file that names a shape file must say its unit: the packaged default ("km", for
    the PDS radar models) read a file in metres as a body 1000 times too large."""
    asteroid = data.get("asteroid", {})
    if not isinstance(asteroid, Mapping):
        return
    shape = asteroid.get("shape")
    if isinstance(shape, str) and shape != "generated" and "shape_unit" not in asteroid:
        raise ConfigError(
            f'{source}: asteroid.shape_unit: missing; give the unit of {shape!r}\'s coordinates, "m" or "km" '
            "(PDS radar models are in km, `tubempc make-body` writes metres); it is not inferred"
        )


def scenario_file(name: str) -> str:
    """Package-relative file of a packaged scenario; ConfigError naming the known ones."""
    if name not in SCENARIOS:
        raise ConfigError(f"unknown scenario {name!r} (known: {', '.join(SCENARIOS)}; see 'tubempc scenarios')")
    return SCENARIOS[name][0]


def load_config(path: str | Path | None = None, *, scenario: str | None = None) -> Config:
    """Load and validate a scenario TOML: a file, or the packaged scenario ``scenario`` (None and None:
    the packaged bennu_paper.toml). A file may leave out sections and fields: they are taken from
    the packaged bennu_paper.toml (but :data:`OWN_MISSION_DEFAULTS`, the paper scenario's own
    disturbance growth) and listed in ``Config.defaulted``. A file that names a shape file must give
    its ``asteroid.shape_unit``."""
    if path is not None and scenario is not None:
        raise ConfigError("give a configuration file or a packaged scenario, not both")
    packaged = scenario_file(scenario or "bennu-paper") if path is None else None
    if packaged is not None:
        text, source = packaged_text(packaged), f"<package>/data/{packaged}"
    else:
        source = str(path)
        try:
            text = Path(source).read_text(encoding="utf-8")
        except OSError as exc:
            raise ConfigError(f"{source}: cannot read: {exc}") from exc
        except UnicodeDecodeError as exc:
            line = Path(source).read_bytes()[: exc.start].count(b"\n") + 1
            raise ConfigError(f"{source}:{line}: not UTF-8 text (byte 0x{exc.object[exc.start]:02x})") from exc
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{source}: invalid TOML: {exc}") from exc
    if packaged == DEFAULT_FILE:
        return parse(data, source)
    _check_shape_unit(data, source)
    return parse(data, source, _with_boresight_defaults(data, _packaged_defaults()))
