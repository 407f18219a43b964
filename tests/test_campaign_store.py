"""runs.jsonl: whole-line appends, torn last line skipped and repaired, later rows supersede."""

import dataclasses
import json

import numpy as np

from campaign_rows import complete_row
from ground.report.row_types import ResultRow
from ground.report.run_weights import RunWeights
from tools.campaign.store import RunStore, encode_row, load_weights, read_rows, repair

# a row as campaigns have always written it: runs.jsonl of existing campaign directories
OLD_ROW = (
    b'{"id":"0f3c2a","cell":{"scenario":"insight-approach","fault":"optical-bias-medium","variant":"chi2"},'
    b'"seed":3,"fault_class":"optical-measurement","detector":{"network":"chi2","calibrated":true},'
    b'"span_days":4.0,"host":"node1","pid":4242,"status":"ok","error":null,"summary":{"scenario":"insight-approach",'
    b'"seed":3,"t0":1000.0,"fault":{"preset":"optical-bias-medium","class":"optical-measurement","events":'
    b'[{"id":"f1","type":"optical-bias","event":"start","t_s":87400.0,"day":1.0,"magnitude":{"bias_px":2.0}}]},'
    b'"measurements":{"published":10,"processed":9,"rejected":1,"lost":0,"duplicates":0,"reordered":0},'
    b'"filters":["radio","optical"],"gating":{"chi2":{"mean_weights":{"radio":0.7,"optical":0.3},"updates":4,'
    b'"mean_weights_before_onset":{"radio":0.5,"optical":0.5},"mean_weights_after_onset":{"radio":0.9,'
    b'"optical":0.1},"final_weights":{"radio":0.9,"optical":0.1}}},"anomaly":{"detector":true,"declared":true,'
    b'"time":97400.0,"time_day":1.1157407407407407,"onset_true":87400.0,"onset_true_day":1.0,'
    b'"onset_estimate":88000.0,"latency_s":10000.0,"class":"optical-measurement","true_class":'
    b'"optical-measurement","confidence":0.9,"network":"chi2","false_alarm":false,"correct_class":true,'
    b'"final_flag":true,"final_class":"optical-measurement","first_class":"unknown",'
    b'"latency_day":0.11574074074074074},"position_error_rms_km":{"radio":1.5,"combined":1.2},'
    b'"position_error_final_km":{"radio":1.0,"combined":0.8},"position_within_3sigma":{"radio":1.0,'
    b'"combined":1.0},"budget":{"frames":12,"reports":12,"overruns":0,"max_utilisation":0.25,'
    b'"mean_utilisation_busy":0.125,"max_backlog":2,"final_backlog":0,"errors":0,"mode":"work-units"},'
    b'"wall_time_s":3.5,"monitors":{"magill":{"error":{"type":"FdirInputError","message":"NaN weights",'
    b'"traceback":"Traceback ..."}}}},"wall_time_s":3.75,"finished_utc":"2026-11-20T10:00:00Z",'
    b'"campaign":"c","executor":"local"}\n'
)
OLD_FAILED_ROW = (
    b'{"id":"9a","cell":{"scenario":"s","fault":"none","variant":"v"},"seed":1,"fault_class":"none",'
    b'"detector":{"network":"chi2","calibrated":false},"span_days":2.0,"status":"failed","error":{"type":'
    b'"BrokenProcessPool","message":"gone","traceback":"..."},"summary":null,"wall_time_s":null,'
    b'"finished_utc":"2026-11-20T10:00:00Z","campaign":"c","executor":"local"}\n'
)


def _row(i, status="ok", **extra):
    summary = {"scenario": "s", "seed": i} if status == "ok" else None
    return ResultRow.from_json(complete_row({"id": f"id{i}", "seed": i, "status": status, "summary": summary,
                                             **extra}))


def test_a_row_written_the_old_way_loads_and_writes_back_byte_for_byte(tmp_path):
    path = tmp_path / "runs.jsonl"
    path.write_bytes(OLD_ROW + OLD_FAILED_ROW)
    r = read_rows(path)
    assert r.bad_lines == 0 and [x.id for x in r.rows] == ["0f3c2a", "9a"]
    ok, failed = r.rows
    a = ok.summary.anomaly
    assert a.anomaly_class == "optical-measurement" and a.first_class == "unknown" and a.detected
    assert ok.summary.gating["chi2"].mean_weights_after_onset == {"radio": 0.9, "optical": 0.1}
    assert ok.summary.monitors["magill"].error.type == "FdirInputError" and ok.pid == 4242
    assert failed.summary is None and failed.host is None and not failed.detector.calibrated
    assert encode_row(ok) == OLD_ROW and encode_row(failed) == OLD_FAILED_ROW


def test_append_and_read_back(tmp_path):
    with RunStore(tmp_path / "c") as store:
        for i in range(3):
            # numpy scalars, as a worker's arithmetic leaves them
            store.append(dataclasses.replace(_row(i), pid=np.int64(i), wall_time_s=np.float64(1.5)))
    data = (tmp_path / "c" / "runs.jsonl").read_bytes()
    assert data.count(b"\n") == 3 and data.endswith(b"\n")
    rows = read_rows(tmp_path / "c" / "runs.jsonl").rows
    assert [r.seed for r in rows] == [0, 1, 2]
    assert rows[1].wall_time_s == 1.5 and rows[1].pid == 1 and type(rows[1].pid) is int  # plain JSON numbers
    for line in data.splitlines():
        json.loads(line)


def test_torn_last_line_is_skipped_then_cut_before_appending(tmp_path):
    d = tmp_path / "c"
    with RunStore(d) as store:
        store.append(_row(0))
        store.append(_row(1))
    path = d / "runs.jsonl"
    whole = path.read_bytes()
    torn = encode_row(_row(2))[:25]  # a crash in the middle of a write
    path.write_bytes(whole + torn)
    r = read_rows(path)
    assert [x.id for x in r.rows] == ["id0", "id1"] and r.torn_tail
    store = RunStore(d)
    assert store.open() == len(torn)
    store.append(_row(3))
    store.close()
    r = read_rows(path)
    assert [x.id for x in r.rows] == ["id0", "id1", "id3"] and not r.torn_tail and r.bad_lines == 0
    assert repair(path) == 0


def test_unreadable_middle_line_is_counted_and_latest_row_wins(tmp_path):
    path = tmp_path / "runs.jsonl"
    lines = [encode_row(_row(0, status="failed")), b"{not json", json.dumps([1, 2]).encode() + b"\n",
             b'{"id": "x", "seed": 1}\n', encode_row(_row(1)), encode_row(_row(0, status="ok"))]
    path.write_bytes(b"".join(x if x.endswith(b"\n") else x + b"\n" for x in lines))
    r = read_rows(path)
    assert r.bad_lines == 3 and len(r.rows) == 3
    latest = r.latest()
    assert latest["id0"].status == "ok" and set(latest) == {"id0", "id1"}


def test_weights_round_trip(tmp_path):
    with RunStore(tmp_path) as store:
        w = np.random.default_rng(1).random((7, 3))
        store.save_weights("abc", {"chi2": RunWeights(filters=("radio", "optical", "fused"), t_s=np.arange(7.0),
                                                      batch=np.arange(7), weights=w)})
    got = load_weights(tmp_path, "abc", "chi2")
    assert got.filters == ("radio", "optical", "fused") and got.group_names == ()
    np.testing.assert_array_equal(got.weights, w)
    assert not list((tmp_path / "weights").rglob(".*tmp*"))
