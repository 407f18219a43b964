"""The campaign statistics records write the cells of a campaign's summary.json as before: the
detection block in the order its case gives (nominal, faulted, uncalibrated)."""

from __future__ import annotations

import json

from tools.campaign.stats_records import CellStats

COMMON = ('"detector":{"network":"chi2","calibrated":true},"runs":{"planned":2,"ok":2,"failed":0,"missing":0},'
          '"failed":[],"seeds":[1,2],')
TAIL = ('"position_error_rms_km":{"radio":{"n":2,"mean":1.5,"median":1.5,"max":2.0,"min":1.0}},'
        '"budget":{"max_utilisation":0.5,"overruns_total":0,"runs_with_overruns":0,"final_backlog_max":0,'
        '"max_backlog":1},"wall_time_s":{"n":2,"mean":3.0,"median":3.0,"max":4.0,"min":2.0,"total":6.0},'
        '"weights":{"chi2":{"filters":["radio"],"n":2,"mean":{"radio":1.0},"final":{"radio":1.0}}}}')
NOMINAL = ('{"key":"s / none / v","scenario":"s","fault":"none","variant":"v","fault_class":"none",' + COMMON
           + '"false_alarm":{"per_run":{"k":0,"n":2,"rate":0.0,"ci":[0.0,0.8418861169915811]},"per_day":{"k":0,'
           '"exposure_days":20.0,"per_day":0.0,"ci":[0.0,0.18444397270369653]}},"detection":null,' + TAIL)
FAULTED = ('{"key":"s / ob / v / magill","scenario":"s","fault":"ob","variant":"v / magill","base_variant":"v",'
           '"monitor":true,"fault_class":"optical-measurement",' + COMMON
           + '"detection":{"k":1,"n":2,"rate":0.5,"ci":[0.012579117349205488,0.9874208826507945]},'
           '"false_alarm":{"per_run":{"k":0,"n":2,"rate":0.0,"ci":[0.0,0.8418861169915811]},"per_day":null,'
           '"note":"declarations before the injected onset"},"latency":null,'
           '"characterization":{"k":0,"n":1,"rate":0.0,"ci":[0.0,0.975]},' + TAIL)
UNCALIBRATED = ('{"key":"s / ob / v","scenario":"s","fault":"ob","variant":"v","fault_class":"optical-measurement",'
                + COMMON.replace('"calibrated":true', '"calibrated":false')
                + '"detection":null,"false_alarm":null,"note":"detector network \'chi2\' not calibrated: no '
                'declarations possible",' + TAIL)


def test_cells_round_trip_in_their_case_order():
    for text in (NOMINAL, FAULTED, UNCALIBRATED):
        cell = CellStats.from_json(json.loads(text))
        assert json.dumps(cell.to_json(), separators=(",", ":")) == text
    nominal = CellStats.from_json(json.loads(NOMINAL))
    assert nominal.nominal and nominal.false_alarm.per_day.exposure_days == 20.0
    assert nominal.wall_time_s.total == 6.0 and nominal.weights["chi2"].after_onset is None
    assert not CellStats.from_json(json.loads(UNCALIBRATED)).detector.can_declare
