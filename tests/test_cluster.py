"""Cluster job requests (tyreroad.cluster): run length in steps and memory / run time per job."""

import copy
from pathlib import Path

import pytest
import yaml

from tyreroad.cluster import CLUSTER_RULES, job_resources, rolling_pass_steps, run_steps, solver_path
from tyreroad.loading import LoadingPreset

ROOT = Path(__file__).resolve().parents[1]


def _merge(base, overlay):
    for key, value in overlay.items():
        if isinstance(value, dict) and isinstance(base.get(key), dict):
            _merge(base[key], value)
        else:
            base[key] = value
    return base


def _config(*overlays):
    config = yaml.safe_load((ROOT / "config/config.yaml").read_text())
    for name in overlays:
        _merge(config, yaml.safe_load((ROOT / "config" / name).read_text()))
    return config


STUDY_SOLVER = {"d_max": 2.5e-4, "quasistatic_step": 1.0e-6}


@pytest.mark.parametrize(
    "mode, accel, steps",
    # the step counts of the paper's study runs (results/contact/*, benchmarks/README.md)
    [("dynamic", 500, 53), ("dynamic", 250, 74), ("dynamic", 50, 163), ("quasistatic", 0, 251)],
)
def test_run_steps_match_the_solver(mode, accel, steps):
    assert run_steps(STUDY_SOLVER, 51200.0, mode, accel) == steps


def test_run_steps_rejects_bad_mode_and_acceleration():
    with pytest.raises(ValueError, match="mode"):
        run_steps(STUDY_SOLVER, 51200.0, "static", 1.0)
    with pytest.raises(ValueError, match="accel"):
        run_steps(STUDY_SOLVER, 51200.0, "dynamic", 0.0)


def _jobs(config):
    surface = config["study"]["surface"]
    yield "prepare_surface", {"surface": surface}
    yield "element_springs", {"surface": surface, "material": "tread"}
    yield "greens", {"material": "tread"}
    yield "contact", {"surface": surface, "material": "tread", "mode": "quasistatic", "accel": "0"}
    yield "contact", {"surface": surface, "material": "tread", "mode": "dynamic", "accel": "50"}


def test_paper_study_runs_ask_for_under_a_gigabyte():
    """20 x 20: a contact job peaked at 0.65 GB on the test cluster (0.27 GB the run itself), 2-12 s of work."""
    config = _config()
    for rule, wildcards in _jobs(config):
        res = job_resources(rule, config, wildcards)
        # the one surface job is charged for its 100 mm field like the footprint's (measured 0.4 GB)
        assert 700 <= res["mem_mb"] <= (2000 if rule == "prepare_surface" else 1000), (rule, res)
        assert 5 <= res["runtime"] <= 10, (rule, res)
    contact = job_resources("contact", config, {"surface": "iso10844", "mode": "dynamic", "accel": "500"})
    assert contact == {"mem_mb": 800, "runtime": 6}


def test_footprint_jobs_cover_the_measured_peaks():
    """150 x 200 jobs on the test cluster (sacct MaxRSS of batch + job step) fit their requests."""
    small, large = _config(), _config("footprint.yaml")
    for (rule, w_small), (_, w_large) in zip(_jobs(small), _jobs(large)):
        r_small, r_large = job_resources(rule, small, w_small), job_resources(rule, large, w_large)
        assert r_large["mem_mb"] > r_small["mem_mb"] and r_large["runtime"] >= r_small["runtime"], rule
    measured_mb = {  # MaxRSS of the batch step + the job step, sacct, config/footprint.yaml
        ("prepare_surface", ""): 160 + 2567,
        ("element_springs", ""): 194 + 1620,
        ("greens", ""): 194 + 1813,
        ("contact", "quasistatic"): 194 + 1831,
        ("contact", "dynamic"): 194 + 2011,  # 500 m/s^2
    }
    for rule, wildcards in _jobs(large):
        if wildcards.get("accel") == "50":
            wildcards = {**wildcards, "accel": "500"}
        requested = job_resources(rule, large, wildcards)["mem_mb"]
        assert 1.15 * measured_mb[rule, wildcards.get("mode", "")] <= requested <= 8000, rule


def test_longer_runs_ask_for_more():
    config = _config("footprint.yaml")
    slow = job_resources("contact", config, {"surface": "footprint", "mode": "dynamic", "accel": "50"})
    fast = job_resources("contact", config, {"surface": "footprint", "mode": "dynamic", "accel": "500"})
    assert slow["mem_mb"] > fast["mem_mb"] and slow["runtime"] > fast["runtime"]


def test_dense_path_is_charged_for_its_cubic_cost():
    config = _config("footprint.yaml")
    dense = copy.deepcopy(config)
    dense["solver"]["method"] = "dense"
    w = {"surface": "footprint", "mode": "dynamic", "accel": "500"}
    assert job_resources("contact", dense, w)["runtime"] > 10 * job_resources("contact", config, w)["runtime"]


def test_a_retry_asks_for_twice_as_much():
    config = _config()
    for rule, wildcards in _jobs(config):
        first, second = job_resources(rule, config, wildcards), job_resources(rule, config, wildcards, attempt=2)
        assert second["mem_mb"] == pytest.approx(2 * first["mem_mb"], abs=100), rule
        assert second["runtime"] == pytest.approx(2 * first["runtime"], abs=1), rule


def test_unknown_rule_is_an_error():
    with pytest.raises(ValueError, match="report"):
        job_resources("report", _config(), {})
    assert "report" not in CLUSTER_RULES


def _with_method(config, method):
    out = copy.deepcopy(config)
    out["solver"]["method"] = method
    return out


def test_a_dynamic_run_longer_than_the_kept_lags_is_costed_on_the_fft_path():
    """20 x 20 (400 elements, not above the FFT threshold): solver.method auto takes the FFT path for
    a dynamic run longer than greens.n_lags = 256 steps, and the request follows the solver."""
    config = _config()
    assert config["greens"]["n_lags"] == 256 and config["solver"]["method"] == "auto"
    slow = {"surface": "iso10844", "material": "tread", "mode": "dynamic", "accel": "5"}
    assert run_steps(config["solver"], 51200.0, "dynamic", 5.0) == 513  # 51200 sqrt(2 2.5e-4 / 5) + 1
    fft, dense = _with_method(config, "fft"), _with_method(config, "dense")
    assert job_resources("contact", config, slow) == job_resources("contact", fft, slow)
    assert job_resources("contact", config, slow) != job_resources("contact", dense, slow)
    # the load-unload cycle of the default config: 755 steps, also beyond the kept lags
    cycle = {"surface": "iso10844", "material": "tread", "mode": "dynamic", "loading": "cycle"}
    _, d, _ = LoadingPreset("cycle", config["loadings"]["cycle"]).path("dynamic", 51200.0, 1e-5)
    assert d.size > 256
    assert job_resources("loading_run", config, cycle) == job_resources("loading_run", fft, cycle)
    assert job_resources("loading_run", config, cycle) != job_resources("loading_run", dense, cycle)
    # the path itself: beyond 256 lags (or 400 elements) fft, else dense; a quasi-static kernel has 1 lag
    assert [solver_path(config, 400, n, True) for n in (53, 256, 257, 513)] == ["dense", "dense", "fft", "fft"]
    assert solver_path(config, 400, 2501, False) == "dense"
    assert solver_path(config, 401, 53, True) == solver_path(config, 401, 26, False) == "fft"
    assert solver_path(dense, 400, 513, True) == "dense" and solver_path(fft, 400, 53, True) == "fft"
    for w in ({**slow, "accel": "500"}, {**slow, "mode": "quasistatic", "accel": "0"}):
        assert job_resources("contact", config, w) == job_resources("contact", dense, w), w


def test_rolling_pass_steps_follow_the_pass_of_the_job():
    """d0 given: x_c from -(a + 3 c) before the first element centre to as far past the last,
    a = sqrt(2 R d0); 150 elements of 1 mm, R = 0.3 m, d0 = 1e-4 m: a = 7.746 mm, x_c from
    -10.246 mm to 160.246 mm (170.49 mm); at 20 m/s, dx = 20 / 51200 m: ceil(436.46) + 1 steps."""
    config = _config()
    config["rolling"].update(d0=1.0e-4, load=None)
    assert rolling_pass_steps(config, "iso10844-strip", "dynamic", 20.0) == 438
    assert rolling_pass_steps(config, "iso10844-strip", "quasistatic", 20.0) == 1706  # ceil(1704.92) + 1
    # with a load, d0 is bounded by the spring table (zeta_max = 1 mm): a longer pass is planned
    assert rolling_pass_steps(_config(), "iso10844-strip", "dynamic", 20.0) > 438


def test_rolling_jobs_are_cluster_jobs_sized_for_the_strip():
    config = _config()
    assert {"rolling_greens", "rolling_run"} <= set(CLUSTER_RULES)
    # the strips' Green's functions cover 150 x 20 offsets: more than the study's 20 x 20
    assert job_resources("rolling_greens", config, {"material": "tread"})["mem_mb"] > job_resources(
        "greens", config, {"material": "tread"})["mem_mb"]
    w = {"surface": "iso10844-strip", "material": "tread", "mode": "dynamic"}
    slow, fast = (job_resources("rolling_run", config, {**w, "speed": v}) for v in ("5", "20"))
    # measured (docs/rolling.md, bench_rolling.py): 0.4 GB peak; 44 s at 5 m/s, 10 s at 20 m/s with 2 threads
    for res, seconds in ((slow, 44.0), (fast, 10.0)):
        assert 400 + 1.15 * 400 <= res["mem_mb"] <= 1500, res
        assert res["runtime"] * 60 >= 3 * 2 * seconds, res  # 1 thread: at most twice the 2-thread time
    assert slow["runtime"] > fast["runtime"]
    retry = job_resources("rolling_run", config, {**w, "speed": "5"}, attempt=2)
    assert retry["runtime"] == pytest.approx(2 * slow["runtime"], abs=1)
    assert retry["mem_mb"] == pytest.approx(2 * slow["mem_mb"], abs=100)


def test_sensitivity_points_and_the_transient_spectrum_are_costed_from_measurements():
    """A sensitivity point (its own small study) asks for at least its measured peak (0.43 GB) and three
    times its measured 23 s; K*(f) pays for its transient states' dynamic runs (d0 fs / v steps each)."""
    config = _config()
    point = job_resources("sensitivity_point", config, {"point": "reference"})
    assert point["mem_mb"] >= 400 + 1.25 * 430 and point["runtime"] * 60 >= 3 * 23
    slow = copy.deepcopy(config)
    slow.setdefault("stiffness_spectrum", {})["transient_speed"] = 0.001  # 100x the steps of the transient runs
    w = {"surface": "iso10844", "material": "tread"}
    assert job_resources("stiffness_spectrum", slow, w)["runtime"] > job_resources("stiffness_spectrum", config, w)[
        "runtime"]
