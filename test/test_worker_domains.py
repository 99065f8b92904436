"""The ROS domain of each pytest-xdist worker (test/conftest.py): the workers of one run never
share a domain, and every domain stays in the 1..100 the project uses."""

import os

import pytest
from conftest import worker_domain


@pytest.mark.parametrize("workers", [1, 2, 3, 4])
def test_the_workers_of_a_run_have_domains_of_their_own(workers: int) -> None:
    for run_domain in range(1, 101):
        domains = {worker_domain(run_domain, f"gw{k}", workers) for k in range(workers)}
        assert len(domains) == workers
        assert all(1 <= d <= 100 for d in domains)
    assert worker_domain(37, "gw0", 2) == 37  # the first worker keeps the run's domain


def test_this_process_is_on_a_loopback_domain() -> None:
    assert os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "LOCALHOST"
    assert 1 <= int(os.environ["ROS_DOMAIN_ID"]) <= 100
