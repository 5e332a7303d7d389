"""splice-batch on a real dask.distributed LocalCluster: manifests, resume, pairing, failures."""

from __future__ import annotations

import json
import math
import os
import shutil
from pathlib import Path

import numpy as np
import pytest

distributed = pytest.importorskip("distributed")

from splicer.batch import (ManifestError, PairJob, is_finished, job_hash, job_size, largest_first, main,  # noqa: E402
                           pair_folders, read_manifest, run_batch)
from splicer.io.bvh import read_bvh, write_bvh  # noqa: E402
from splicer.pairing import decide_pairs  # noqa: E402
from splicer.evaluation.separate import separate  # noqa: E402
from splicer.evaluation.synth import make_gesture_take  # noqa: E402

MOTIONS = Path(__file__).resolve().parents[1] / "motions"


@pytest.fixture(scope="module")
def client():
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False, dashboard_address=":0") as c, \
            distributed.Client(c) as cl:
        yield cl


@pytest.fixture(scope="module")
def takes(tmp_path_factory):
    """Four takes split by the evaluation protocol (seeds 0..3): body/take{k}.bvh, hands (shuffled names)."""
    d = tmp_path_factory.mktemp("takes")
    (d / "body").mkdir()
    (d / "hands").mkdir()
    truth = {}
    shuffle = [2, 0, 3, 1]
    for k in range(4):
        take = make_gesture_take(20.0, 30.0, np.random.default_rng(40 + k))
        sep = separate(take, rng=np.random.default_rng(k))
        write_bvh(sep.body, d / "body" / f"take{k}.bvh")
        write_bvh(sep.hands, d / "hands" / f"hands_{shuffle[k]}.bvh")
        truth[f"hands_{shuffle[k]}.bvh"] = f"take{k}.bvh"
    return d, truth


def write_manifest(path: Path, takes_dir: Path, extra: str = "", options: str = "") -> Path:
    text = f"""# three pairs, one broken
{options}pairs:
  - body: {MOTIONS / 'sample_body.bvh'}
    hands: {MOTIONS / 'sample_hands.bvh'}
    constraints: {MOTIONS / 'sample_sync.yaml'}
    output: out/sample.bvh
  - body: {takes_dir / 'body' / 'take0.bvh'}
    hands: {takes_dir / 'hands' / 'hands_2.bvh'}
    output: out/take0.bvh
    options: {{side: left}}
  - name: broken
    body: {takes_dir / 'missing_body.bvh'}
    hands: {takes_dir / 'hands' / 'hands_0.bvh'}
    output: out/broken.bvh
{extra}"""
    path.write_text(text)
    return path


def test_manifest_run_then_rerun_skips_finished(client, takes, tmp_path):
    d, _ = takes
    jobs = read_manifest(write_manifest(tmp_path / "day.yaml", d))
    assert [j.name for j in jobs] == ["sample", "take0", "broken"]
    assert jobs[1].options == {"side": "left"} and jobs[0].output == str(tmp_path / "out" / "sample.bvh")
    rows = run_batch(jobs, tmp_path / "batch", client)
    assert [r["status"] for r in rows] == ["done", "done", "failed"]
    assert "missing_body.bvh" in rows[2]["error"] and "not found" in rows[2]["error"]
    assert rows[0]["body_frames"] == 601 and rows[0]["hands_frames"] == 1985 and rows[0]["sides"] == "left,right"
    assert rows[1]["sides"] == "left"
    # the sample's figures (its own splice: 24 % of the frames low confidence since 0.19.0, whose
    # second wrist round halves the left's frames 0.1 s off; 34 % in 0.18.0, whose risk model
    # flagged nearly every frame of the sample 0.1 s off and more of the left's good ones; 25 % in
    # 0.17.0, 33 % until 0.16.0; 0.33 against its hands played backwards; 23.6 % until 0.25.0, 23.8 %
    # from 0.26.0, whose wrist rounds until settled leave 18 frames 0.1 s off on the left, all flagged;
    # 11.1 % since 0.29.0, whose pass 1 reads the hand's turns in the forearm: no frame 0.1 s off)
    assert 0.0 < rows[0]["confidence"] < 1.0 and rows[0]["low_confidence_pct"] == pytest.approx(11.1, abs=0.1)
    # against its hands played backwards: 0.333 until 0.28.0; 0.187 since 0.29.0 (the pair aligned again
    # with noise matching is kept, and its own check is reported)
    assert rows[0]["uncovered_pct"] == 0.0 and rows[0]["backwards_ratio"] == pytest.approx(0.187, abs=0.001)
    rep = json.loads((tmp_path / "batch" / "reports" / "sample.json").read_text())
    assert rep["batch"]["hash"] == job_hash(jobs[0]) and rep["batch"]["status"] == "done"
    assert len(rep["sides"]["left"]["hands_frame"]) == 601
    assert read_bvh(tmp_path / "out" / "take0.bvh").n_frames == read_bvh(d / "body" / "take0.bvh").n_frames
    md = (tmp_path / "batch" / "summary.md").read_text()
    assert "3 pairs (2 done, 1 failed)" in md and "| broken | failed |" in md
    csv_lines = (tmp_path / "batch" / "summary.csv").read_text().splitlines()
    assert csv_lines[0].startswith("name,status,") and len(csv_lines) == 4

    stamp = {p: os.stat(p).st_mtime_ns for p in (tmp_path / "out").glob("*.bvh")}
    rows2 = run_batch(jobs, tmp_path / "batch", client)
    assert [r["status"] for r in rows2] == ["done earlier", "done earlier", "failed"]
    assert {p: os.stat(p).st_mtime_ns for p in (tmp_path / "out").glob("*.bvh")} == stamp  # nothing rewritten
    assert rows2[0]["body_frames"] == 601  # the summary row comes from the stored report
    assert {k: rows2[0][k] for k in ("confidence", "low_confidence_pct", "backwards_ratio")} == \
        {k: rows[0][k] for k in ("confidence", "low_confidence_pct", "backwards_ratio")}


def test_resume_after_kill_runs_only_unfinished(client, takes, tmp_path):
    d, _ = takes
    jobs = read_manifest(write_manifest(tmp_path / "day.yaml", d))[:2]
    out = tmp_path / "batch"
    run_batch(jobs, out, client)
    # a kill after the output of "take0" was written but before its report: not finished
    (out / "reports" / "take0.json").unlink()
    assert is_finished(jobs[0], out) is not None and is_finished(jobs[1], out) is None
    before = os.stat(tmp_path / "out" / "sample.bvh").st_mtime_ns
    rows = run_batch(jobs, out, client)
    assert [r["status"] for r in rows] == ["done earlier", "done"]
    assert os.stat(tmp_path / "out" / "sample.bvh").st_mtime_ns == before
    # a killed write leaves at most a temporary file: a missing output also means unfinished
    (tmp_path / "out" / "sample.bvh").unlink()
    assert [r["status"] for r in run_batch(jobs, out, client)] == ["done", "done earlier"]


def test_largest_pairs_run_first(takes, tmp_path):
    """A batch hands out its pairs largest first (input bytes), whatever the manifest's order:
    on one worker they start in that order (the reports' start times)."""
    d, _ = takes
    jobs = [PairJob("small", str(d / "body" / "take1.bvh"), str(d / "hands" / "hands_0.bvh"), str(tmp_path / "o1.bvh"),
                    options={"side": "left"}),
            PairJob("sample", str(MOTIONS / "sample_body.bvh"), str(MOTIONS / "sample_hands.bvh"), str(tmp_path / "o2.bvh"),
                    options={"side": "left"})]
    # the same small pair with its hands take twice as long
    long_hands = tmp_path / "long_hands.bvh"
    h = read_bvh(d / "hands" / "hands_0.bvh")
    write_bvh(h.with_channels(np.concatenate([h.channels, h.channels[::-1]])), long_hands)
    jobs.append(PairJob("long", str(d / "body" / "take1.bvh"), str(long_hands), str(tmp_path / "o3.bvh"),
                        options={"side": "left"}))
    sizes = {j.name: job_size(j) for j in jobs}
    jobs.sort(key=lambda j: sizes[j.name])  # given smallest first
    expected = [j.name for j in jobs][::-1]
    assert len(set(sizes.values())) == 3 and min(sizes.values()) > 0
    assert [j.name for j in largest_first(jobs)] == expected
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False, dashboard_address=":0") as c, \
            distributed.Client(c) as one:
        rows = run_batch(jobs, tmp_path / "batch", one)
    assert [r["status"] for r in rows] == ["done"] * 3
    started = {j.name: json.loads((tmp_path / "batch" / "reports" / f"{j.name}.json").read_text())["batch"]["started_unix_s"]
               for j in jobs}
    assert sorted(started, key=started.get) == expected


def test_changed_entry_or_input_is_run_again(client, takes, tmp_path):
    d, _ = takes
    jobs = read_manifest(write_manifest(tmp_path / "day.yaml", d))[1:2]
    out = tmp_path / "batch"
    run_batch(jobs, out, client)
    assert [r["status"] for r in run_batch(jobs, out, client)] == ["done earlier"]  # nothing to submit
    changed = read_manifest(write_manifest(tmp_path / "day.yaml", d, options="options: {band1: 25%}\n"))[1:2]
    assert job_hash(changed[0]) != job_hash(jobs[0])
    assert is_finished(changed[0], out) is None and is_finished(jobs[0], out) is not None
    assert [r["status"] for r in run_batch(changed, out, client)] == ["done"]
    # the hands file re-exported (new size/time): the pair is stale
    h = Path(jobs[0].hands)
    copy = tmp_path / "hands_copy.bvh"
    shutil.copy(h, copy)
    moved = PairJob(jobs[0].name, jobs[0].body, str(copy), jobs[0].output, None, jobs[0].options)
    assert job_hash(moved) != job_hash(jobs[0])


def test_csv_manifest_and_cli_with_scheduler(client, takes, tmp_path):
    d, _ = takes
    (tmp_path / "day.csv").write_text(
        "name,body,hands,constraints,output,options\n"
        f"s,{MOTIONS / 'sample_body.bvh'},{MOTIONS / 'sample_hands.bvh'},{MOTIONS / 'sample_sync.yaml'},s.bvh,"
        "side=right; band1=30%\n")
    jobs = read_manifest(tmp_path / "day.csv")
    assert jobs[0].options == {"side": "right", "band1": "30%"} and jobs[0].line == 2
    rc = main([str(tmp_path / "day.csv"), "-o", str(tmp_path / "b"), "--scheduler", client.scheduler.address,
               "--plot", "-q"])
    assert rc == 0
    page = (tmp_path / "b" / "summary.html").read_text()
    assert "<img src='plots/s.png'" in page and (tmp_path / "b" / "plots" / "s.png").stat().st_size > 1000
    assert (tmp_path / "s.bvh").is_file()


@pytest.mark.parametrize("text, match", [
    ("pairs:\n  - {body: a.bvh, hands: b.bvh}\n", r"line 2: 'output' is missing"),
    ("pairs:\n  - {body: a.bvh, hands: b.bvh, output: o.bvh, options: {bandd: 3}}\n",
     r"line 2: .*unknown option.*bandd"),
    ("pairs:\n  - {body: a.bvh, hands: b.bvh, output: o.bvh, options: {side: up}}\n", r"line 2: side must be one of"),
    ("pairs:\n  - {body: a.bvh, hands: b.bvh, output: o.bvh}\n  - {body: c.bvh, hands: d.bvh, output: o.bvh}\n",
     r"line 3: name 'o' is used twice \(first at line 2\)"),
    ("pairs:\n  - {body: a.bvh, hands: b.bvh, output: a.bvh}\n", r"line 2: output .* is an input"),
    ("pairs:\n  - {body: a.bvh, hands: b.bvh, output: o.bvh, colour: red}\n", r"line 2: unknown key\(s\) colour"),
    ("pairs: [\n", r"line \d+: not valid YAML"),
    ("take: 1\n", r"line 1: expected 'pairs:'"),
])
def test_manifest_errors_name_the_line(tmp_path, text, match):
    (tmp_path / "m.yaml").write_text(text)
    with pytest.raises(ManifestError, match=match):
        read_manifest(tmp_path / "m.yaml")


def test_csv_manifest_errors(tmp_path):
    (tmp_path / "m.csv").write_text("body,hands\na,b\n")
    with pytest.raises(ManifestError, match=r"line 1: the header lacks output"):
        read_manifest(tmp_path / "m.csv")
    (tmp_path / "m.csv").write_text("body,hands,output,options\na,b,c,side\n")
    with pytest.raises(ManifestError, match=r"line 2: options: expected key=value, found 'side'"):
        read_manifest(tmp_path / "m.csv")


def test_automatic_pairing_on_shuffled_protocol_pairs(client, takes, tmp_path):
    d, truth = takes
    jobs, decisions, costs = pair_folders(d / "body", d / "hands", tmp_path / "p", client)
    assert costs.shape == (4, 4) and np.isfinite(costs).all()
    got = {Path(x.hands).name: Path(x.body).name for x in decisions}
    assert got == truth
    assert all(x.reason == "paired" and x.margin >= 0.15 for x in decisions)
    assert sorted(j.name for j in jobs) == ["take0", "take1", "take2", "take3"]
    table = (tmp_path / "p" / "pairing.md").read_text()
    assert "| hands \\ body | take0 | take1 | take2 | take3 |" in table
    assert len((tmp_path / "p" / "pairing.csv").read_text().splitlines()) == 5


def test_ambiguous_pair_refused(client, takes, tmp_path):
    d, _ = takes
    body = tmp_path / "body"
    body.mkdir()
    shutil.copy(d / "body" / "take1.bvh", body / "take1.bvh")
    shutil.copy(d / "body" / "take2.bvh", body / "take2.bvh")
    # a second export of take1 (a tiny re-sampling difference): both fit its hands take equally
    m = read_bvh(d / "body" / "take1.bvh")
    noise = np.random.default_rng(0).normal(0.0, 0.01, m.channels.shape)
    write_bvh(m.with_channels(m.channels + noise), body / "take1_again.bvh")
    hands = tmp_path / "hands"
    hands.mkdir()
    shutil.copy(d / "hands" / "hands_0.bvh", hands / "h_take1.bvh")  # seed-1 take -> hands_0
    shutil.copy(d / "hands" / "hands_3.bvh", hands / "h_take2.bvh")
    jobs, decisions, _ = pair_folders(body, hands, tmp_path / "p", client)
    by = {Path(x.hands).name: x for x in decisions}
    assert by["h_take1.bvh"].body is None and by["h_take1.bvh"].reason.startswith("ambiguous")
    assert Path(by["h_take2.bvh"].body).name == "take2.bvh"
    assert [j.name for j in jobs] == ["take2"]


def test_cli_folders_refusal_in_summary(client, takes, tmp_path):
    d, _ = takes
    body = tmp_path / "body"
    body.mkdir()
    shutil.copy(d / "body" / "take1.bvh", body / "take1.bvh")
    (body / "junk.bvh").write_text("HIERARCHY\nROOT x\n")  # unreadable: not comparable, not paired
    hands = tmp_path / "hands"
    hands.mkdir()
    shutil.copy(d / "hands" / "hands_0.bvh", hands / "h1.bvh")
    shutil.copy(d / "hands" / "hands_3.bvh", hands / "h2.bvh")
    rc = main(["--body-dir", str(body), "--hands-dir", str(hands), "-o", str(tmp_path / "out"),
               "--scheduler", client.scheduler.address, "-q"])
    md = (tmp_path / "out" / "summary.md").read_text()
    assert rc == 1  # a refused pair
    assert "| take1 | done |" in md and "| h2 | refused |" in md
    assert "junk.bvh" in (tmp_path / "out" / "pairing.md").read_text()


def test_decide_pairs_known_answers():
    b, h = ["b0", "b1", "b2"], ["h0", "h1", "h2"]
    costs = np.array([[10.0, 20.0, 30.0],    # h0 -> b0, margin 50 %
                      [20.0, 10.5, 11.0],    # h1 -> b1, runner-up 11 -> margin 4.5 %: ambiguous
                      [math.nan, 9.0, math.nan]])  # h2 -> b1 cheaper than h1 -> h1 contested
    d = decide_pairs(costs, b, h, margin=0.15)
    assert (d[0].body, d[0].reason) == ("b0", "paired") and d[0].margin == pytest.approx(0.5)
    assert d[1].body is None and d[1].reason.startswith("contested")
    # h2: its only candidate b1; b1's other hands cost 10.5 >= 9 -> margin (10.5 - 9) / 10.5
    assert d[2].body is None and d[2].margin == pytest.approx(1.5 / 10.5) and d[2].reason.startswith("ambiguous")
    d = decide_pairs(costs, b, h, margin=0.1)
    assert d[2].body == "b1"
    d = decide_pairs(np.array([[math.nan, math.nan]]), ["a", "b"], ["x"])
    assert d[0].body is None and d[0].reason == "no body take could be compared"


def test_decide_pairs_max_cost_without_runner_up():
    d = decide_pairs(np.array([[26.5]]), ["b"], ["h"])
    assert d[0].body == "b" and d[0].margin == math.inf  # nothing to compare with
    d = decide_pairs(np.array([[26.5]]), ["b"], ["h"], max_cost=20.0)
    assert d[0].body is None and d[0].reason == "too expensive: best b costs 26.5 > 20"


def test_summary_figures_from_a_report_worked_example():
    from splicer.batch_summary import summary_row
    from splicer.manifest import PairJob

    rep = {"body": {"frames": 4}, "hands": {"frames": 9}, "warnings": ["w"],
           "sides": {"left": {"hands_frame": [None, 1.0, 2.0, 3.0], "confidence": [0.0, 0.9, 0.5, 0.1],
                              "low_confidence": [[3, 3]], "uncovered": [[0, 0]],
                              "pass1": {"cost": 2.0, "backwards_ratio": 0.4}},
                     "right": {"hands_frame": [0.0, 1.0, 2.0, 3.0], "confidence": [0.8, 0.8, 0.8, 0.8],
                               "low_confidence": [], "uncovered": [],
                               "pass1": {"cost": 3.0, "backwards_ratio": 0.97}}}}
    r = summary_row(PairJob("p", "b.bvh", "h.bvh", "o.bvh"), "done", rep=rep, seconds=1.234)
    # left: mean over its 3 covered frames (0.9 + 0.5 + 0.1) / 3 = 0.5, lower than right's 0.8
    assert r["confidence"] == 0.5 and r["low_confidence_pct"] == 25.0 and r["uncovered_pct"] == 25.0
    assert r["backwards_ratio"] == 0.97 and r["pass1_cost"] == 5.0 and r["seconds"] == 1.23
    empty = summary_row(PairJob("p", "b.bvh", "h.bvh", "o.bvh"), "failed", error="x")
    assert (empty["confidence"], empty["low_confidence_pct"], empty["backwards_ratio"]) == (None, None, None)


def test_local_cluster_workers_drop_only_the_closing_heartbeat_traceback():
    """The local cluster's worker processes carry the filter for distributed's shutdown race
    (a closing worker's heartbeat meeting the closed scheduler logged an ERROR with two
    tracebacks in CI); a running worker's heartbeat failure and every other record still pass."""
    import logging

    from distributed.core import Status

    from splicer._dask_shutdown import HEARTBEAT_FAILED, ClosingHeartbeatFilter
    from splicer.batch import dask_client

    def check():
        import logging

        from splicer._dask_shutdown import ClosingHeartbeatFilter
        return [type(f).__name__ for f in logging.getLogger("distributed.worker").filters
                if isinstance(f, ClosingHeartbeatFilter)]

    with dask_client(workers=1) as cl:
        on_workers = cl.run(check)
    assert list(on_workers.values()) == [["ClosingHeartbeatFilter"]]

    class W:
        status = Status.running

    w = W()
    f = ClosingHeartbeatFilter(w)

    def rec(msg):
        return logging.LogRecord("distributed.worker", logging.ERROR, __file__, 1, msg, None, None)

    assert f.filter(rec(HEARTBEAT_FAILED + "."))
    for s in (Status.closing, Status.closing_gracefully, Status.closed):
        w.status = s
        assert not f.filter(rec(HEARTBEAT_FAILED + "."))
        assert f.filter(rec("Unexpected exception during heartbeat. Closing worker."))
    del w
    assert f.filter(rec(HEARTBEAT_FAILED + "."))  # the worker gone: the filter passes everything


def test_local_cluster_workers_keep_malloc_trimming_and_run_no_profiler():
    """dask_client's own workers: glibc's default memory trimming (Dask's MALLOC_TRIM_THRESHOLD_
    made a splice cost 12-15 % more CPU), no sampling profiler (it takes the GIL from the
    pair's thread every 10 ms: 6-8 % of a warm batch's wall time), and the event loop's check
    and system monitor at 1 s and 5 s on the workers, the nanny and the scheduler."""
    from splicer.batch import dask_client

    def check(dask_worker):
        import os

        pc = dask_worker.periodic_callbacks
        return (os.environ.get("MALLOC_TRIM_THRESHOLD_"), sorted(k for k in pc if k.startswith("profile")),
                pc["tick"].callback_time, pc["monitor"].callback_time)

    def on_scheduler(dask_scheduler):
        pc = dask_scheduler.periodic_callbacks
        return pc["tick"].callback_time, pc["monitor"].callback_time

    def nannies(cluster):
        return [(n.periodic_callbacks["tick"].callback_time, n.periodic_callbacks["monitor"].callback_time)
                for n in cluster.workers.values()]

    with dask_client(workers=1) as cl:
        on_workers = list(cl.run(check).values())
        sched = cl.run_on_scheduler(on_scheduler)
        nanny = nannies(cl.cluster)
    assert on_workers == [(None, [], 1000.0, 5000.0)]
    assert sched == (1000.0, 5000.0) and nanny == [(1000.0, 5000.0)]
    # the check reads what it claims: a plain LocalCluster's worker has Dask's defaults
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, dashboard_address=":0") as c, \
            distributed.Client(c) as cl:
        plain = list(cl.run(check).values())
        sched = cl.run_on_scheduler(on_scheduler)
        nanny = nannies(c)
    assert plain == [("65536", ["profile", "profile-cycle"], 20.0, 500.0)]
    assert sched == (20.0, 500.0) and nanny == [(20.0, 500.0)]
