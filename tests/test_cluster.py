"""Cluster job requests (tyreroad.cluster): run length in steps and memory / run time per job."""

import copy
from pathlib import Path

import pytest
import yaml

from tyreroad.cluster import CLUSTER_RULES, job_resources, run_steps

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
    w = {"surface": "footprint", "mode": "dynamic", "accel": "500"}
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
