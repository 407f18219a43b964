"""End to end with the onboard chi-square gating network: bank records → weights → detector."""

from __future__ import annotations

import numpy as np

from tools.calibration.thresholds import calibrate
from fsw.fdir.detector import AnomalyDetector
from fsw.filters.record import BankRecord
from fsw.gating.registry import make_network, params_type
from test_fdir_synthetic import BANK3, names

M = 50  # measurements per gating batch (small, to keep the test fast)


def gating_run(rng, n_batches: int, optical_bias: float = 0.0, onset: int = 10**9):
    """Unit-covariance residuals for radio (scalar, 3 in 4 measurements) and optical (2-D) data;
    a bias on the optical residuals from batch ``onset`` on, seen by the filters that process
    optical data. Returns the network's WeightsUpdates."""
    net = make_network("chi2", names(BANK3), params_type("chi2")(batch_size=M))
    out = []
    seq = 0
    for b in range(n_batches):
        for j in range(M):
            optical = j % 4 == 0
            n = 2 if optical else 1
            r = rng.normal(size=(3, n))
            if optical and b >= onset:
                r[1:] += optical_bias
            rec = BankRecord(
                t=3600.0 * b + j, seq=seq, kind="optical" if optical else "range", filters=names(BANK3),
                residual=r, S=np.broadcast_to(np.eye(n), (3, n, n)).copy(), chi2=np.sum(r * r, axis=1),
                processed=np.array([not optical, optical, True]),
            )
            seq += 1
            update = net.update(rec)
            if update is not None:
                out.append(update)
    return out


def test_chi2_network_weights_drive_the_detector():
    rng = np.random.default_rng(123)
    nominal = [np.array([u.weights for u in gating_run(rng, 30)]) for _ in range(60)]
    config, report = calibrate(nominal, 0.05, network="chi2", filters=names(BANK3))
    assert report.method == "empirical"
    for bias, onset in ((0.0, 10**9), (1.0, 15)):
        det = AnomalyDetector(config, BANK3)
        states = [det.consume(u) for u in gating_run(rng, 30, bias, onset)]
        if bias == 0.0:
            assert not any(s.flag for s in states)
        else:
            assert states[-1].flag and states[-1].anomaly_class == "optical-measurement"
            assert abs(states[-1].onset_t - (3600.0 * onset + M - 1)) <= 2 * 3600.0, states[-1].onset_t
            assert states[-1].evidence["radio"] > states[-1].evidence["optical"]
