"""Where a diagnosis runs does not change what it finds: one worker, two worker processes
(whose fits finish in any order) and a Dask cluster of four worker processes give the same
diagnosis to the digit. Each fit rebuilds its comparison engine from the same data, the
warm starts (the base model's steady state at each event) included."""

from __future__ import annotations

import pytest
from vadsim.campaigns.synthetic import synthetic_campaign
from vadsim.fit.candidates import CANDIDATES
from vadsim.fit.diagnosis import diagnose

SMALL = dict(cycles=160, analyse_cycles=100)
TRIED = ["hydraulic_force[anvil]", "anvil_friction"]


@pytest.fixture(scope="module")
def campaign():
    truth = CANDIDATES["hydraulic_force[anvil]"].change({"f_ref": 64.0, "n": 2.0})
    return synthetic_campaign("7in-cde", (200.0, 300.0, 450.0, 600.0), change=truth,
                              duration_s=2.0, noise_g=0.3, seed=4, **SMALL)


def _diagnosis(campaign, **kw):
    d = diagnose(campaign, candidates=TRIED, nuisance=(), phases=2, progress=False,
                 cache=False, **SMALL, **kw)
    out = d.as_json()
    for volatile in ("elapsed_s", "evaluations"):  # how long, and how many runs each worker
        out.pop(volatile)                             # repeated: not what was found
    return out


@pytest.fixture(scope="module")
def one_worker(campaign):
    return _diagnosis(campaign, workers=1)


def test_the_diagnosis_finds_the_concealed_force(one_worker):
    assert one_worker["missing_physics_keys"] == ["hydraulic_force[anvil]"]
    assert one_worker["heldout_error_after"] < 0.5 * one_worker["heldout_error_before"]


def test_two_worker_processes_give_the_same_diagnosis(campaign, one_worker):
    assert _diagnosis(campaign, workers=2) == one_worker


@pytest.mark.slow
def test_a_dask_cluster_of_four_workers_gives_the_same_diagnosis(campaign, one_worker):
    distributed = pytest.importorskip("dask.distributed")
    with distributed.LocalCluster(n_workers=4, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster:
        got = _diagnosis(campaign, scheduler=cluster.scheduler_address)
    assert got == one_worker


def test_a_bad_scheduler_address_is_refused_by_name(campaign):
    with pytest.raises(ValueError, match="scheduler"):
        diagnose(campaign, candidates=TRIED, scheduler="", progress=False, cache=False)
