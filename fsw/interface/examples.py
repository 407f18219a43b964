"""One realistic example of every ICD message (documentation, schema checks, tests)."""

from __future__ import annotations

from fsw.interface import messages as m

_T = 596_505_600.0  # 2018-11-26T12:00 TDB-ish, seconds past J2000
_STAMP = m.Stamp(sec=1_543_233_531, nsec=816_000_000)


def examples() -> dict[str, list]:
    """ICD type name -> example instances."""
    return {
        "Measurement": [
            m.Measurement(seq=0, t_s=_T, timestamp=_STAMP, kind="range", source="DSS-14",
                          value=(1.52e8,), sigma=(1.0e-3,)),
            m.Measurement(seq=1, t_s=_T + 60.0, timestamp=_STAMP, kind="doppler", source="DSS-43",
                          value=(-12.345678,), sigma=(1.0e-7,), count_time_s=60.0),
            m.Measurement(seq=2, t_s=_T + 90.0, timestamp=_STAMP, kind="optical", source="phobos",
                          value=(501.25, 530.75), sigma=(0.25, 0.25), attitude_q=(0.5, -0.5, 0.5, 0.5)),
            m.Measurement(seq=3, t_s=1.0, timestamp=m.Stamp(sec=0, nsec=0), kind="generic-linear",
                          source="chaer-tracking", value=(10.0, 1.0), sigma=(1.0, 0.1)),
        ],
        "Truth": [
            m.Truth(t_s=_T, timestamp=_STAMP, position_km=(-1.2e5, 3.4e5, 1.1e5), velocity_km_s=(0.9, -2.4, -0.8),
                    clock_phase_s=1.2e-9, clock_frequency=3.0e-15, clock_drift_per_s=3.5e-21, srp_scale=1.04,
                    acs_accel_km_s2=(5e-12, 0.0, 0.0), active_faults=("optical-bias-0",)),
        ],
        "FaultEvent": [
            m.FaultEvent(t_s=_T, timestamp=_STAMP, fault_id="optical-bias-0", fault_type="optical-bias",
                         event="start", fault_class="optical-measurement",
                         magnitude={"sample_px": 2.0, "line_px": 3.0}),
        ],
        "FilterWeights": [
            m.FilterWeights(t_s=_T, timestamp=_STAMP, network="chi2", batch=12, filters=("radio", "optical", "fused"),
                            weights=(0.9, 0.06, 0.04), statistic=(1010.2, 8123.0, 5230.9)),
            m.FilterWeights(t_s=_T, timestamp=_STAMP, network="hierarchical", batch=3, filters=("a1", "a2", "b1"),
                            weights=(0.2, 0.3, 0.5), groups={"a": 0.5, "b": 0.5}),
        ],
        "AnomalyReport": [
            m.AnomalyReport(t_s=_T, timestamp=_STAMP, flag=True, anomaly_class="optical-measurement", confidence=0.93,
                            onset_s=_T - 3600.0, declared_s=_T, network="chi2", statistic=0.61, threshold=0.12,
                            evidence={"radio": 0.9, "optical": 0.06, "fused": 0.04}),
            m.AnomalyReport(t_s=_T, timestamp=_STAMP, flag=False, anomaly_class="none", confidence=0.0),
        ],
        "Estimate": [
            m.Estimate(t_s=_T, timestamp=_STAMP, filter="fused", position_km=(-1.2e5, 3.4e5, 1.1e5),
                       velocity_km_s=(0.9, -2.4, -0.8), position_sigma_km=3.2,
                       state_names=("x", "y", "z", "vx", "vy", "vz"), state=(-1.2e5, 3.4e5, 1.1e5, 0.9, -2.4, -0.8),
                       sigma=(2.0, 2.0, 1.5, 1e-5, 1e-5, 1e-5)),
        ],
        "Residuals": [
            m.Residuals(t_s=_T, timestamp=_STAMP, filters=("radio", "optical"), samples=(
                m.ResidualSample(t_s=_T - 30.0, seq=41, kind="range", source="DSS-14", residual=((0.0012,), (0.8,)),
                                 sigma=((0.0011,), (72.4,)), normalised=((1.09,), (0.011,)), nis=(1.19, 0.0001),
                                 processed=(True, False)),)),
        ],
        "BPlane": [
            m.BPlane(t_s=_T, timestamp=_STAMP, filter="combined", b_dot_r_km=473.4, b_dot_t_km=6677.1,
                     covariance_km2=((153.8, 44.2), (44.2, 44.6)), periapsis_s=_T + 3.9e6, periapsis_sigma_s=10.8,
                     v_inf_km_s=2.957),
        ],
        "BudgetReport": [
            m.BudgetReport(frame=7, t_s=_T, timestamp=_STAMP, mode="cpu", used=0.012, budget=0.05, utilisation=0.24,
                           processed=31, deferred=0, backlog=0, overruns=0),
        ],
        "Telecommand": [
            m.Telecommand(id="c1", command="set-param", network="chi2", param="sigma_w", value=0.1),
            m.Telecommand(id="c2", command="disable-filter", filter="optical"),
            m.Telecommand(id="c3", command="status"),
        ],
        "TelecommandReply": [
            m.TelecommandReply(id="c1", ok=True, status={"measurements_processed": 1234.0}),
            m.TelecommandReply(id="", ok=False, error="Telecommand.command: expected one of …"),
        ],
        "CommandRecord": [
            m.CommandRecord(t_s=_T, timestamp=_STAMP, taken=1234,
                            telecommand=m.Telecommand(id="c1", command="set-param", network="chi2", param="sigma_w",
                                                      value=0.1),
                            reply=m.TelecommandReply(id="c1", ok=True, status={"sigma_w": 0.1})),
            m.CommandRecord(t_s=_T, timestamp=_STAMP, taken=1240, telecommand=None, payload="{\"id\": 7}",
                            reply=m.TelecommandReply(id="", ok=False, error="malformed telecommand: …")),
        ],
        "RunStatus": [
            m.RunStatus(t_s=_T, timestamp=_STAMP, run_id="run-1", source="sim", state="end-of-run",
                        counts={"published": 21000}),
        ],
        "RqpReport": [
            m.RqpReport(t_s=_T, timestamp=_STAMP, filter="radio", params=("sigma_scale.range", "sigma_scale.doppler"),
                        alpha_before=(1.0, 1.0), alpha_after=(1.05, 0.93), nll_before=-518.02, nll_after=-518.27,
                        window=40, iterations=3, evaluations=43, cost=7.0, applied=True, status="converged"),
        ],
    }
