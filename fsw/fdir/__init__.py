"""Anomaly detection and characterization on gating-network weights (Lubey & Ely 2022 §5 future work).

Modules: ``detector`` (AnomalyDetector, AnomalyState), ``config`` (DetectorConfig and its YAML
form), ``statistic`` (the nominal band and the detection statistic D), ``persistence`` (k-of-n
rule), ``characterize`` (decision tree), ``families`` (filter family tags), ``errors``. The
calibration that fits a DetectorConfig to nominal runs is ground work: :mod:`tools.calibration`.
"""
