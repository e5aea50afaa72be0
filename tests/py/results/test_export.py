"""Scenario files: the C++ core writes (tubempc.results.export through _core.io) and reads them, bit for bit."""

from __future__ import annotations

import json
import re
import subprocess
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from tubempc import _core
from tubempc.cli import main
from tubempc.config import load_config
from tubempc.design.library import controller_designs, controller_settings, initial_tube
from tubempc.results.export import read_scenario
from tubempc.scenario import Scenario, build_scenario, mpc_settings
from tubempc.sim.closed_loop import simulate


def _same_bits(a: Any, b: Any) -> bool:
    x, y = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    return x.shape == y.shape and x.tobytes() == y.tobytes()


def _fly_example(example: Path, path: Path, method: str, w_true: np.ndarray, tmp_path: Path) -> dict[str, Any]:
    """The C++ example's figures for ``method`` flying the scenario file ``path`` under the disturbances
    ``w_true`` of a Python run (it must exit 0)."""
    w = tmp_path / "w.txt"
    np.savetxt(w, w_true, fmt="%.17g")
    out = tmp_path / "cpp.json"
    proc = subprocess.run(
        [str(example), str(path), "--method", method, "--disturbance", str(w), "--json", str(out)],
        capture_output=True,
        text=True,
        check=False,
    )
    assert proc.returncode == 0, proc.stdout + proc.stderr
    result: dict[str, Any] = json.loads(out.read_text())["methods"][method]
    return result


@pytest.fixture(scope="module")
def exported(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Scenario]:
    cache = tmp_path_factory.mktemp("cache")
    out = tmp_path_factory.mktemp("scenario")
    assert main(["export-scenario", "--out", str(out), "--cache-dir", str(cache)]) == 0
    return out / "scenario.txt", build_scenario(load_config(), cache_dir=cache)


def test_scenario_file_holds_the_closed_loops_inputs_bit_for_bit(exported: tuple[Path, Scenario]) -> None:
    path, scn = exported
    s = read_scenario(str(path))
    assert s.directory == str(path.parent)
    assert s.mission_steps == scn.n_steps == 300
    for body, model, shape_file in ((s.model, scn.model, "shape.obj"), (s.truth, scn.truth, "shape.obj")):
        expected = model.config()
        params = body.params
        for name in (
            "mu_sun",
            "orbit_radius",
            "beta_srp",
            "spin_rate",
            "spin_angle0",
            "glide_slope_angle",
            "los_angle",
            "inertia_B",
            "boresight_B",
        ):
            assert _same_bits(getattr(params, name), expected[name]), name
        assert params.srp_enabled == expected["srp_enabled"]
        assert params.kinematics.name.lower() == expected["kinematics"]
        assert body.density == model.gravity.density
        assert body.shape == shape_file and body.shape_unit_scale == 1.0
    # The shape file holds the controller's mesh exactly (metres, 17 digits), read by the C++ loader.
    mesh = _core.gravity.load_shape(s.resolve(s.model.shape), s.model.shape_unit_scale)
    assert _same_bits(mesh.vertices, scn.shape.vertices) and np.array_equal(mesh.faces, scn.shape.faces)

    expected_settings = mpc_settings(scn)
    # every field of mpc::Settings::for_each_field (the scenario file's mpc.* records), scp_mode included
    bound = {n for n in dir(_core.mpc.Settings) if isinstance(getattr(_core.mpc.Settings, n), property)}
    assert set(_core.mpc.Settings.field_names()) == bound
    for name in _core.mpc.Settings.field_names():
        a, b = getattr(s.settings, name), getattr(expected_settings, name)
        enums = (
            _core.mpc.InputCost,
            _core.mpc.InitialCondition,
            _core.mpc.KktSolver,
            _core.mpc.QpSolver,
            _core.mpc.Linearization,
            _core.mpc.ScpMode,
        )
        assert (a == b) if isinstance(a, (bool, int, *enums)) else _same_bits(a, b), name
    assert s.propagator.method == _core.dynamics.Integrator.RK4
    assert s.propagator.substeps == scn.config.simulation.substeps
    assert _same_bits(s.reference.z, scn.reference.x.T) and _same_bits(s.reference.u, scn.reference.u.T)
    assert s.reference.t0 == 0.0
    assert _same_bits(s.x0, scn.x0) and _same_bits(s.xf, scn.xf)
    K, Pe = initial_tube(scn)
    assert _same_bits(s.tube.K, K) and _same_bits(s.tube.Pe, Pe)
    # the whole controller: identification, tube policy, both methods' designs and the library
    assert s.has_controller
    c, expected_c = s.controller, controller_settings(scn, "ffa")
    assert str(c.measured_input) == scn.config.identification.measured_input
    for a, b in ((c.identification_p, expected_c.identification_p), (c.identification_r, expected_c.identification_r)):
        assert (a.lambda_, a.prior_weight, a.eig_floor, a.pw_scale) == (b.lambda_, b.prior_weight, b.eig_floor, b.pw_scale)
        assert _same_bits(a.w0, b.w0) and _same_bits(a.S0, b.S0)
    assert c.tube.redesign_margin == scn.config.tube.redesign_margin
    assert c.tube.alpha_search_period == scn.config.tube.alpha_search_period
    for method, designs in (("tbmpc", s.tbmpc_designs), ("ffa", s.ffa_designs)):
        expected = controller_designs(scn, method)
        for a, b in (
            (designs.initial_p, expected.initial_p),
            (designs.initial_r, expected.initial_r),
            *zip(designs.library_p, expected.library_p, strict=True),
            *zip(designs.library_r, expected.library_r, strict=True),
        ):
            assert a.alpha == b.alpha and all(_same_bits(getattr(a, n), getattr(b, n)) for n in ("K", "P_W", "Pe"))
    assert len(s.ffa_designs.library_p) > 5 and not s.tbmpc_designs.library_p


def test_tube_is_the_closed_loops_first_tube(exported: tuple[Path, Scenario]) -> None:
    path, scn = exported
    s = read_scenario(str(path))
    rec = simulate(scn, "tbmpc", seed=0, max_steps=1, tube_threads=1)
    assert _same_bits(s.tube.K, rec.K[0])
    assert _same_bits(s.tube.Pe[:6, :6], rec.Pe_p[0]) and _same_bits(s.tube.Pe[6:, 6:], rec.Pe_r[0])
    ffa = simulate(scn, "ffa", seed=0, max_steps=1, tube_threads=1)
    assert _same_bits(s.ffa_designs.initial_p.Pe, ffa.Pe_p[0]) and _same_bits(s.ffa_designs.initial_r.K, ffa.K[0][3:, 6:])


@pytest.mark.parametrize("method", ["tbmpc", "ffa"])
def test_cpp_example_flies_the_python_run(exported: tuple[Path, Scenario], tmp_path: Path, method: str) -> None:
    """The C++ program (examples/cpp/closed_loop, the controller embedded without Python) flies the exported
    mission under the Python run's disturbance to the same final state (<= 1e-9) and J_p (<= 1e-9
    relative), with no background designs (``tube.design_worker = "none"``) and no allocation per step."""
    from tubempc.analysis.metrics import run_metrics
    from tubempc.testing.examples import find_example

    try:
        example = find_example(None)
    except FileNotFoundError as exc:
        pytest.skip(f"no built C++ example: {exc}")
    path, scn = exported
    rec = simulate(scn, method, seed=0, design_worker="none")
    cpp = _fly_example(example, path, method, rec.w_true, tmp_path)
    m = run_metrics(rec, scn.config.mpc.dt, scn.xf)
    np.testing.assert_allclose(cpp["final_state"], rec.x[-1], rtol=0, atol=1e-9)
    assert cpp["J_p"] == pytest.approx(m.J_p, rel=1e-9) and cpp["J_r"] == pytest.approx(m.J_r, rel=1e-9)
    assert cpp["steps_outside_tube"] == m.steps_outside_tube and cpp["allocations_controller"] == 0
    assert sum(cpp["tube_statuses"].values()) == scn.n_steps


def test_cpp_example_reports_the_memory_each_component_keeps_after_set_up(
    exported: tuple[Path, Scenario], tmp_path: Path
) -> None:
    """The set-up memory of ``tubempc bench instructions`` (examples/cpp/closed_loop's allocation counter): every
    component flown reports what it keeps, at least the arrays it must hold (the controller's reference, the
    shape's vertices and faces), never more than its peak; components not flown report null; the largest is
    named."""
    from tubempc.benchmarks.instructions import setup_memory
    from tubempc.testing.examples import find_example

    try:
        example = find_example(None)
    except FileNotFoundError as exc:
        pytest.skip(f"no built C++ example: {exc}")
    path, scn = exported
    out = tmp_path / "native.json"
    proc = subprocess.run([str(example), str(path), "--method", "ffa", "--json", str(out)], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    flight = json.loads(out.read_text())
    if not flight["allocations_counted"]:
        pytest.skip("the example does not count allocations (no glibc, or a sanitizer build)")
    memory = setup_memory(flight)
    assert memory is not None
    ffa = memory["methods"]["ffa"]
    assert ffa["navigation"] is None and ffa["actuation"] is None  # not flown by the default scenario
    reference_bytes = (scn.n_steps + 1) * 12 * 8  # the reference's states, doubles
    assert ffa["controller_setup"]["retained"] >= reference_bytes
    shape = scn.shape
    shape_bytes = 3 * 8 * len(shape.vertices) + 3 * 4 * len(shape.faces)  # both gravity models hold the shape
    assert memory["shared"]["models_and_ray_casters"]["retained"] >= 2 * shape_bytes
    parts = {**memory["shared"], **ffa}
    for name, m in parts.items():
        if m is not None:
            assert 0 <= m["retained"] <= m["peak"], name
    largest = max(m["retained"] for m in parts.values() if m is not None)
    assert memory["largest"]["retained"] == largest and memory["largest"]["component"].split(" ", 1)[1] in parts


def test_written_file_reads_back_to_the_same_text(exported: tuple[Path, Scenario], tmp_path: Path) -> None:
    path, _ = exported
    again = tmp_path / "again.txt"
    _core.io.write_scenario(str(again), read_scenario(str(path)))

    def records(p: Path) -> list[str]:
        return [line for line in p.read_text().splitlines() if not line.startswith("#")]

    assert records(again) == records(path)


def test_malformed_scenario_names_file_line_and_record(exported: tuple[Path, Scenario], tmp_path: Path) -> None:
    path, _ = exported
    lines = path.read_text().splitlines()
    at = lines.index("mpc.dt 1 1") + 1
    lines[at] = "two"
    bad = tmp_path / "bad.txt"
    bad.write_text("\n".join(lines) + "\n")
    message = f"{bad}:{at + 1}: mpc.dt: row 0, column 0: bad number 'two'"
    with pytest.raises(ValueError, match="^" + re.escape(message) + "$"):
        read_scenario(str(bad))
    with pytest.raises(ValueError, match=r"missing\.txt: cannot open the file"):
        read_scenario(str(tmp_path / "missing.txt"))


def test_cpp_shape_loader_matches_python_loader(tmp_path: Path) -> None:
    from tubempc.scenario.shapes import bennu_like_shape, load_shape, save_shape

    shape = bennu_like_shape(n_subdivisions=4)
    save_shape(tmp_path / "s.tab", shape, unit="km")
    py, cpp = load_shape(tmp_path / "s.tab", unit="km"), _core.gravity.load_shape(str(tmp_path / "s.tab"), 1000.0)
    assert _same_bits(py.vertices, cpp.vertices) and np.array_equal(py.faces, cpp.faces)
    _core.gravity.save_obj(str(tmp_path / "c.obj"), shape, 1.0)
    assert _same_bits(load_shape(tmp_path / "c.obj", unit="m").vertices, shape.vertices)
    (tmp_path / "bad.obj").write_text("v 0 0 0\nv 1 0 nan\n")
    with pytest.raises(ValueError, match=r"bad\.obj:2: vertex: non-finite number 'nan'"):
        _core.gravity.load_shape(str(tmp_path / "bad.obj"), 1.0)


def test_bindings_loop_flies_the_exported_mission(exported: tuple[Path, Scenario]) -> None:
    from tubempc.benchmarks.embed import python_loop
    from tubempc.testing.examples import find_example

    path, scn = exported
    r = python_loop(path)
    assert r["steps"] == 300 and r["statuses"] == {"solved": 300}
    final = np.asarray(r["final_state"])
    assert np.linalg.norm(final[:3] - scn.xf[:3]) < 0.05  # m, undisturbed
    assert np.all(np.asarray(r["time_mpc_s"]) > 0.0)
    assert np.all(np.asarray(r["time_call_s"]) >= np.asarray(r["time_controller_s"]))
    with pytest.raises(FileNotFoundError, match="no such file"):
        find_example(path.parent / "no_such_binary")


_REPO = Path(__file__).resolve().parents[3]
_THRUSTERS = _REPO / "examples" / "actuators" / "bennu_tag_thrusters.toml"


def _missing_records(text: str, prefix: str, settings: Any) -> list[str]:
    """The bound data fields of a settings object with no record ``<prefix>.<field>`` (or a nested one) in a
    scenario file's text."""
    names = {line.split(maxsplit=1)[0] for line in text.splitlines() if line.strip()}
    fields = [a for a in dir(settings) if not a.startswith("_") and not callable(getattr(settings, a))]
    return [
        f"{prefix}.{a}"
        for a in fields
        if f"{prefix}.{a}" not in names and not any(n.startswith(f"{prefix}.{a}.") for n in names)
    ]


@pytest.fixture(scope="module")
def reference_cache(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("reference_cache")


@pytest.mark.parametrize(
    ("source", "method", "overrides"),
    [
        ("bennu-tag-nav", "ffa", {}),
        ("bennu-tag-nav", "tbmpc", {}),
        (str(_THRUSTERS), "ffa", {}),
        # the OSIRIS-REx-like preset's opposed pairs and TBMPC-FFA's feed-forward (controller.feedforward*)
        ("bennu-tag-osirisrex", "ffa", {"mpc.t_f": "600 s", "boundary.hover_altitude": "30 m"}),
        # both at once: the thrusters' spacecraft flying on navigation (bennu-tag-nav's lit site and camera),
        # the truth on its own shape (truth_shape.obj: the sensors ray-cast it, the filter the controller's)
        (
            str(_THRUSTERS),
            "ffa",
            {
                "simulation.truth_shape_subdivisions": 11,
                "navigation.enabled": True,
                "boundary.site_longitude": "180 deg",
                "navigation.camera_fov": "44 deg",
                "navigation.site_landmarks": 300,
                "navigation.site_landmark_radius": "30 m",
            },
        ),
    ],
    ids=["nav-ffa", "nav-tbmpc", "thrusters-ffa", "osirisrex-ffa", "thrusters-nav-ffa"],
)
def test_cpp_example_flies_navigation_and_actuators_as_the_python_loop(
    reference_cache: Path, tmp_path: Path, source: str, method: str, overrides: dict[str, Any]
) -> None:
    """The scenario file carries [navigation] and the actuators of the run with seed 3: the C++ example flies
    the estimate of its NavigationSystem (IMU sub-steps, the error set) and the commands through its
    ActuationSystem to the Python run's final state (<= 1e-9; the same bits in practice) and J_p, with no heap
    allocation in the controller, navigation or actuation step. A file carrying the seed's run wrongly (another
    seed's sensor noise or thruster errors) fails this, and so does a settings field (navigation, sensors,
    filter, modulation, allocation, dumping, thruster or wheel) without its record in the file."""
    from tubempc.analysis.metrics import run_metrics
    from tubempc.results.export import export_scenario
    from tubempc.testing.examples import find_example

    try:
        example = find_example(None)
    except FileNotFoundError as exc:
        pytest.skip(f"no built C++ example: {exc}")
    cfg = load_config(source) if source.endswith(".toml") else load_config(scenario=source)
    cfg = cfg.with_overrides(overrides) if overrides else cfg
    seed = 3
    path = export_scenario(cfg, tmp_path / "scenario", cache_dir=reference_cache, seed=seed)
    s = read_scenario(str(path))
    assert (s.truth.shape != s.model.shape) == ("simulation.truth_shape_subdivisions" in overrides)
    assert s.navigation.enabled == cfg.navigation.enabled
    if cfg.navigation.enabled:  # every field of the navigation settings has its record (one name per option)
        from tubempc.scenario.navigation import navigation_settings

        nav, text = navigation_settings(cfg), path.read_text()
        groups = [("navigation", nav), ("navigation.filter", nav.filter)]
        for sensor in ("altimeter", "camera", "imu", "star_tracker"):
            groups += [(f"navigation.{sensor}", getattr(nav, sensor))]
            groups += [(f"navigation.filter.{sensor}", getattr(nav.filter, sensor))]
        assert not [m for prefix, obj in groups for m in _missing_records(text, prefix, obj)]
    assert s.actuators.enabled == (cfg.spacecraft.actuators != "ideal")
    scn = build_scenario(cfg, cache_dir=reference_cache)
    if scn.actuation is not None:  # and every field of the actuators' settings and specs
        from tubempc.scenario.actuators import actuation_settings

        suite, text = scn.actuation.suite, path.read_text()
        groups = [
            ("actuators", actuation_settings(suite)),
            ("actuators.modulation", suite.modulation),
            ("actuators.allocation", suite.allocation),
            ("actuators.momentum_dump", suite.wheels.dump_settings),
            ("actuators.thrusters[0]", suite.cluster.thruster(0)),
            ("actuators.wheels[0]", suite.wheels.wheel(0)),
        ]
        assert not [m for prefix, obj in groups for m in _missing_records(text, prefix, obj)]
    if cfg.identification.feedforward:
        assert s.controller.feedforward and s.controller.feedforward_limit == cfg.identification.feedforward_limit
    rec = simulate(scn, method, seed=seed, design_worker="none")
    cpp = _fly_example(example, path, method, rec.w_true, tmp_path)
    m = run_metrics(rec, scn.config.mpc.dt, scn.xf)
    np.testing.assert_allclose(cpp["final_state"], rec.x[-1], rtol=0, atol=1e-9)
    assert cpp["J_p"] == pytest.approx(m.J_p, rel=1e-9) and cpp["J_r"] == pytest.approx(m.J_r, rel=1e-9)
    assert cpp["steps_outside_tube"] == m.steps_outside_tube
    assert (cpp["allocations_controller"], cpp["allocations_navigation"], cpp["allocations_actuation"]) == (0, 0, 0)
    if cfg.navigation.enabled:
        assert rec.navigation is not None
        assert sum(cpp["navigation_statuses"].values()) == scn.n_steps + 1
        assert cpp["navigation_statuses"].get("ok", 0) == rec.navigation.status.count("ok")
    if s.actuators.enabled:
        assert sum(cpp["actuation_statuses"].values()) == scn.n_steps
        assert cpp["pulses"] == int(rec.pulses.sum()) > 0
        assert cpp["delta_v"] == pytest.approx(float(rec.delta_v.sum()), rel=1e-12)


@pytest.mark.parametrize(
    "overrides",
    [
        {"abort.command_time": "100 s"},
        {"faults.kind": "disturbance_burst", "faults.start": "60 s", "faults.burst_scale": 2.0},
    ],
    ids=["commanded", "burst"],
)
def test_cpp_example_flies_the_safe_abort_as_the_python_loop(
    reference_cache: Path, tmp_path: Path, overrides: dict[str, Any]
) -> None:
    """The scenario file carries [abort] (the supervision with the library's commit step, the hover, the abort's
    designs, a commanded step): the C++ example supervises every step as the Python loop does and enters the abort
    at the same step for the same cause (commanded; or under the Python run's 2x burst, which reaches C++ as its
    disturbance, from the controller's own triggers), then flies the abort controller to the Python run's final
    state (<= 1e-9), certified at every step, with no heap allocation in the supervised step."""
    from tubempc.analysis.metrics import run_metrics
    from tubempc.results.export import export_scenario
    from tubempc.testing.examples import find_example

    try:
        example = find_example(None)
    except FileNotFoundError as exc:
        pytest.skip(f"no built C++ example: {exc}")
    cfg = load_config(scenario="bennu-tag").with_overrides({"abort.enabled": True, "abort.entry_period": 25, **overrides})
    path = export_scenario(cfg, tmp_path / "scenario", cache_dir=reference_cache, seed=0)
    s = read_scenario(str(path))
    scn = build_scenario(cfg, cache_dir=reference_cache)
    assert s.abort.enabled and s.abort.settings.disturbance_limit == cfg.abort.disturbance_limit
    assert s.abort.command_step == (50 if "abort.command_time" in overrides else -1)
    rec = simulate(scn, "ffa", seed=0, design_worker="none")
    applied = rec.applied["abort"] if rec.applied else {}
    assert applied["entered_at_step"] is not None
    cpp = _fly_example(example, path, "ffa", rec.w_true, tmp_path)
    assert cpp["abort"]["cause"] == applied["cause"] and cpp["abort"]["entered_at_step"] == applied["entered_at_step"]
    assert cpp["abort"]["steps"] == scn.n_steps - applied["entered_at_step"]
    assert cpp["abort"]["uncertified_steps"] == 0 and cpp["abort"]["max_residual"] <= 0.0
    m = run_metrics(rec, scn.config.mpc.dt, scn.xf)
    np.testing.assert_allclose(cpp["final_state"], rec.x[-1], rtol=0, atol=1e-9)
    assert cpp["J_p"] == pytest.approx(m.J_p, rel=1e-9)
    assert cpp["allocations_controller"] == 0
