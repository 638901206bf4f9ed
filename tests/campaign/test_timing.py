"""Campaign timing: worker processes counted as they ran, not as named across resumed sessions."""

from lnss_lib.campaign.timing import concurrent_workers


def test_a_run_resumed_with_new_worker_names_ran_on_two_workers():
    first = [{"generation": 1, "worker": w} for w in ("a", "b", "a", "b")]
    resumed = [{"generation": g, "worker": w} for g in (2, 3) for w in ("c", "d", "c")]
    assert concurrent_workers(first + resumed) == 2
    stopped = [
        {"generation": 4, "worker": w} for w in ("c", "d", "e", "f")
    ]  # stopped and resumed mid-generation
    assert concurrent_workers(first + resumed + stopped) == 2
    assert concurrent_workers(first[:1]) == 1
    assert concurrent_workers([]) == 1
