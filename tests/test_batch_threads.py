"""A batch job sets the compiled kernels' thread count for its own thread only, and restores it."""

from __future__ import annotations

import threading

from sarcli._native import threads
from sarcli.batch import run as batch_run
from sarcli.batch.plan import Job


def test_job_threads_are_its_own(tmp_path, monkeypatch):
    seen = {}

    def fake_form(job):
        seen[job.name] = threads()
        raise RuntimeError("stop after recording")

    monkeypatch.setattr(batch_run, "_form", fake_form)
    before = threads()

    def worker(name, n):
        threads(2)
        seen[name + " before"] = threads()
        res = batch_run.run_job(Job(name=name, input=str(tmp_path / "x.h5"), method="nufft", threads=n),
                                tmp_path)
        seen[name + " status"] = res.status
        seen[name + " after"] = threads()

    ts = [threading.Thread(target=worker, args=(f"job{n}", n)) for n in (1, 3)]
    for t in ts:
        t.start()
    for t in ts:
        t.join()
    assert seen["job1"] == 1 and seen["job3"] == 3
    assert seen["job1 status"] == seen["job3 status"] == "failed"
    assert seen["job1 after"] == seen["job3 after"] == 2
    assert threads() == before
