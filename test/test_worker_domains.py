"""The ROS domain of each pytest-xdist worker (test/conftest.py): the workers of one run never
share a domain, and the domains they move to stay in the 1..100 the project uses."""

import os

import pytest
from conftest import worker_domain


@pytest.mark.parametrize("workers", [1, 2, 3, 4])
def test_the_workers_of_a_run_have_domains_of_their_own(workers: int) -> None:
    for run_domain in range(0, 102):  # ROS 2's portable range; the Makefile picks 1..100
        domains = [worker_domain(run_domain, f"gw{k}", workers) for k in range(workers)]
        assert len(set(domains)) == workers
        assert domains[0] == run_domain  # the first worker keeps the run's domain
        assert all(1 <= d <= 100 for d in domains[1:])


def test_this_process_is_on_a_valid_domain() -> None:
    assert 0 <= int(os.environ["ROS_DOMAIN_ID"]) <= 101
