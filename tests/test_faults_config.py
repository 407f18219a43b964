"""Fault declarations: validation, YAML decoding, presets, windows and events."""

import numpy as np
import pytest

from fsw.interface.typed import DecodeError, decode
from fsw.interface.yamlconfig import parse_yaml
from sim.config import SimConfig
from sim.faults.apply import fault_events, fault_windows, optical_bias_px, range_bias_km
from sim.faults.config import FaultConfig, fault_ids
from sim.faults.presets import DEFAULT_ONSET_DAY, FAULT_PRESETS, preset


def test_unknown_type_or_missing_magnitude_is_an_error():
    with pytest.raises(ValueError, match="unknown fault type"):
        FaultConfig(type="gremlins", onset_day=1.0)
    with pytest.raises(ValueError, match="needs range_m"):
        FaultConfig(type="range-bias", onset_day=1.0)
    with pytest.raises(ValueError, match="needs line_px"):
        FaultConfig(type="optical-bias", onset_day=1.0, sample_px=1.0)
    with pytest.raises(ValueError, match="phase_s and/or frequency"):
        FaultConfig(type="clock-bias", onset_day=1.0)
    with pytest.raises(ValueError, match="does not take range_m"):
        FaultConfig(type="doppler-bias", onset_day=1.0, doppler_mhz=0.3, range_m=5.0)
    with pytest.raises(ValueError, match="after onset_day"):
        FaultConfig(type="range-bias", onset_day=5.0, end_day=4.0, range_m=5.0)
    with pytest.raises(ValueError, match="finite"):
        FaultConfig(type="range-bias", onset_day=5.0, range_m=float("nan"))
    assert FaultConfig(type="clock-bias", onset_day=1.0, frequency=1e-13).magnitude() == {"frequency": 1e-13}


def test_faults_decode_from_yaml_with_strict_errors():
    text = """
faults:
  - type: optical-bias
    onset_day: 12.5
    end_day: 30
    sample_px: 2.0
    line_px: 3.0
  - type: range-bias
    onset_day: 20
    range_m: 50
"""
    data, _ = parse_yaml(text)
    cfg = decode(SimConfig, data)
    assert cfg.faults[0].end_day == 30.0 and cfg.faults[1].range_m == 50.0
    assert fault_ids(cfg.faults) == ("optical-bias-0", "range-bias-1")
    bad, _ = parse_yaml("faults:\n  - type: range-bias\n    onset_day: 3\n")
    with pytest.raises(DecodeError, match="range_m"):
        decode(SimConfig, bad)
    bad, _ = parse_yaml("faults:\n  - type: clock-drift\n    onset_day: 3\n")
    with pytest.raises(DecodeError, match="faults\\[0\\].type"):
        decode(SimConfig, bad)
    with pytest.raises(ValueError, match="after the 45"):
        SimConfig(faults=(FaultConfig(type="range-bias", onset_day=46.0, range_m=1.0),))
    with pytest.raises(ValueError, match="unique"):
        SimConfig(faults=(FaultConfig(type="range-bias", onset_day=1.0, range_m=1.0, id="x"),
                          FaultConfig(type="doppler-bias", onset_day=1.0, doppler_mhz=1.0, id="x")))


def test_presets_follow_lubey_ely_table_2_and_section_4_4():
    expected = {
        "none": (),
        "optical-bias-small": (("optical-bias", {"sample_px": 0.2, "line_px": 0.3}),),
        "optical-bias-medium": (("optical-bias", {"sample_px": 2.0, "line_px": 3.0}),),
        "optical-bias-large": (("optical-bias", {"sample_px": 20.0, "line_px": 30.0}),),
        "radio-bias-small": (("range-bias", {"range_m": 5.0}), ("doppler-bias", {"doppler_mhz": 0.03})),
        "radio-bias-medium": (("range-bias", {"range_m": 50.0}), ("doppler-bias", {"doppler_mhz": 0.3})),
        "radio-bias-large": (("range-bias", {"range_m": 500.0}), ("doppler-bias", {"doppler_mhz": 3.0})),
        "clock-bias": (("clock-bias", {"phase_s": 1e-6, "frequency": 1e-13}),),
        "thruster-mismodel": (("thruster-mismodel", {"bias_sigma_factor": 3.0, "daily_sigma_factor": 10.0}),),
        "thruster-scale": (("thruster-scale", {"scale": 10.0}),),
    }
    assert set(FAULT_PRESETS) == set(expected)
    for name, (description, faults) in FAULT_PRESETS.items():
        assert description and "\n" not in description
        assert tuple((f.type, f.magnitude()) for f in faults) == expected[name]
        assert all(f.onset_day == DEFAULT_ONSET_DAY == 20.0 and f.end_day is None for f in faults)
    moved = preset("radio-bias-large", onset_day=3.0, end_day=9.0)
    assert [(f.onset_day, f.end_day) for f in moved] == [(3.0, 9.0), (3.0, 9.0)]
    with pytest.raises(ValueError, match="unknown fault preset"):
        preset("radio-bias-huge")


def test_windows_masks_and_events():
    faults = (FaultConfig(type="optical-bias", onset_day=1.0, end_day=2.0, sample_px=2.0, line_px=-3.0),
              FaultConfig(type="range-bias", onset_day=1.5, range_m=50.0))
    w = fault_windows(faults, 1000.0)
    t = 1000.0 + 86400.0 * np.array([0.5, 1.0, 1.6, 2.0])
    np.testing.assert_array_equal(optical_bias_px(w, t), [[0, 0], [2, -3], [2, -3], [0, 0]])
    np.testing.assert_array_equal(range_bias_km(w, t), [0, 0, 0.05, 0.05])
    ev = fault_events(w, 1000.0 + 86400.0 * 45)
    assert [(e.fault_id, e.event) for e in ev] == [("optical-bias-0", "start"), ("range-bias-1", "start"),
                                                   ("optical-bias-0", "end")]
    assert ev[0].fault_class == "optical-measurement" and ev[1].fault_class == "radiometric-measurement"
    assert ev[0].magnitude == {"sample_px": 2.0, "line_px": -3.0}


def test_sim_config_round_trips_through_its_declaration():
    from fsw.interface.typed import encode

    cfg = SimConfig(faults=preset("clock-bias") + preset("optical-bias-small", onset_day=2.0), truth_interval_s=60.0)
    assert decode(SimConfig, encode(cfg)) == cfg
    assert encode(SimConfig(), drop_defaults=True) == {}
