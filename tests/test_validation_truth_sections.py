"""The validation sections on truth models and filter consistency render their numbers and verdicts."""

import json

import numpy as np

from tools.bench.consistency import Flight
from tools.validation.filter_consistency import summarize
from tools.validation.truth_sections import consistency_section, model_differences_section


def _flight(seed: int, scale: float, rng: np.random.Generator) -> Flight:
    K, M = 200, 300
    cov = np.broadcast_to(np.diag([1.0, 1.0, 1.0, 1e-6, 1e-6, 1e-6]), (1, K, 6, 6)).copy()
    err = rng.standard_normal((1, K, 6)) * np.sqrt(np.diag(cov[0, 0])) * scale
    kinds = np.array(["range", "doppler", "optical"] * (M // 3))
    dims = np.where(kinds == "optical", 2, 1)
    chi2 = np.array([rng.chisquare(d) for d in dims])[None, :] * scale**2
    return Flight(seed=seed, names=("fused",), t=np.arange(K) * 3600.0, t_end=K * 3600.0, err=err, cov=cov,
                  meas_t=np.arange(M, dtype=float), meas_kind=kinds, meas_dim=dims, chi2=chi2,
                  processed=np.ones((1, M), dtype=bool))


def test_consistency_summary_and_section_verdicts(tmp_path):
    rng = np.random.default_rng(3)
    good = summarize([_flight(s, 1.0, rng) for s in range(20)])
    assert abs(good["nees"]["6-dof"]["mean"] - 6.0) < 0.3 and good["nees"]["position"]["dof"] == 3
    assert set(good["nis"]) == {"range", "doppler", "optical"}
    (tmp_path / "good.json").write_text(json.dumps(good))
    sec = consistency_section(tmp_path / "good.json")
    assert [c.holds for c in sec.claims] == [True, True]
    assert any("| 6-dof | 6 |" in line for line in sec.lines)
    # an over-confident filter (errors twice its sigma) fails both checks
    bad = summarize([_flight(s, 2.0, rng) for s in range(20)])
    (tmp_path / "bad.json").write_text(json.dumps(bad))
    assert [c.holds for c in consistency_section(tmp_path / "bad.json").claims] == [False, False]


def test_model_differences_section_tabulates_given_rows():
    sec = model_differences_section([["span", "moons", "phobos position", "0.155 m", "0.152 m"]])
    assert sec.title == "Truth and onboard models"
    assert "| span | moons | phobos position | 0.155 m | 0.152 m |" in sec.lines
