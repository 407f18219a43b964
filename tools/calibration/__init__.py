"""Detector calibration on the ground: fitting the anomaly detector's thresholds to nominal runs
(``thresholds``) and its command line on stored histories (``python -m tools.calibration``)."""
