"""runs.jsonl: whole-line appends, torn last line skipped and repaired, later rows supersede."""

import json

import numpy as np

from tools.campaign.store import RunStore, load_weights, read_rows, repair


def _row(i, status="ok", **extra):
    return {"id": f"id{i}", "cell": {"scenario": "s", "fault": "none", "variant": "v"}, "seed": i,
            "status": status, **extra}


def test_append_and_read_back(tmp_path):
    with RunStore(tmp_path / "c") as store:
        for i in range(3):
            store.append(_row(i, value=np.float64(1.5), n=np.int64(i), bad=float("nan")))
    data = (tmp_path / "c" / "runs.jsonl").read_bytes()
    assert data.count(b"\n") == 3 and data.endswith(b"\n")
    rows = read_rows(tmp_path / "c" / "runs.jsonl").rows
    assert [r["seed"] for r in rows] == [0, 1, 2]
    assert rows[1]["value"] == 1.5 and rows[1]["n"] == 1 and rows[1]["bad"] is None  # strict JSON
    for line in data.splitlines():
        json.loads(line)


def test_torn_last_line_is_skipped_then_cut_before_appending(tmp_path):
    d = tmp_path / "c"
    with RunStore(d) as store:
        store.append(_row(0))
        store.append(_row(1))
    path = d / "runs.jsonl"
    whole = path.read_bytes()
    torn = json.dumps(_row(2)).encode()[:25]  # a crash in the middle of a write
    path.write_bytes(whole + torn)
    r = read_rows(path)
    assert [x["id"] for x in r.rows] == ["id0", "id1"] and r.torn_tail
    store = RunStore(d)
    assert store.open() == len(torn)
    store.append(_row(3))
    store.close()
    r = read_rows(path)
    assert [x["id"] for x in r.rows] == ["id0", "id1", "id3"] and not r.torn_tail and r.bad_lines == 0
    assert repair(path) == 0


def test_unreadable_middle_line_is_counted_and_latest_row_wins(tmp_path):
    path = tmp_path / "runs.jsonl"
    lines = [json.dumps(_row(0, status="failed")), "{not json", json.dumps([1, 2]), json.dumps(_row(1)),
             json.dumps(_row(0, status="ok"))]
    path.write_text("\n".join(lines) + "\n")
    r = read_rows(path)
    assert r.bad_lines == 2 and len(r.rows) == 3
    latest = r.latest()
    assert latest["id0"]["status"] == "ok" and set(latest) == {"id0", "id1"}


def test_weights_round_trip(tmp_path):
    with RunStore(tmp_path) as store:
        w = np.random.default_rng(1).random((7, 3))
        store.save_weights("abc", {"chi2": {"filters": ["radio", "optical", "fused"], "t_s": np.arange(7.0),
                                            "batch": np.arange(7), "weights": w}})
    got = load_weights(tmp_path, "abc", "chi2")
    assert list(got["filters"]) == ["radio", "optical", "fused"]
    np.testing.assert_array_equal(got["weights"], w)
    assert not list((tmp_path / "weights").rglob(".*tmp*"))
