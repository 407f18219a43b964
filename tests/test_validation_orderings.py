"""Lubey & Ely's (2022) orderings on reduced versions of the validation campaigns (one seed per case), flown
by `navbank campaign` itself. What is asserted is what docs/validation.md reports: the orderings
that reproduce, and for those that do not, the documented behaviour that replaces them — so a
change that makes a finding (not) reproduce fails here until the report is regenerated."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

from tools.campaign.spec import builtin_dir
from tools.validation.claims import table3_claims, table4_claim
from tools.validation.tables import means, ok_rows, weight_table

pytestmark = pytest.mark.slow


def _reduced(name: str, tmp_path: Path, drop_cases: tuple[str, ...] = ()) -> Path:
    text = builtin_dir().joinpath(f"{name}.yaml").read_text(encoding="utf-8")
    text = re.sub(r"seeds: \{count: \d+, base: 1\}", "seeds: {count: 1, base: 1}", text)
    text = re.sub(r"keep_weights: \[.*\]\n", "", text)
    for case in drop_cases:
        text = "\n".join(line for line in text.splitlines() if f"name: {case}," not in line) + "\n"
    path = tmp_path / f"{name}-reduced.yaml"
    path.write_text(text, encoding="utf-8")
    out = tmp_path / name
    proc = subprocess.run([sys.executable, "-m", "tools.cli", "campaign", str(path), "--out", str(out),
                           "--workers", "2", "--quiet"], capture_output=True, text=True, timeout=1500)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return out


def test_table3_orderings(tmp_path):
    rows = ok_rows(_reduced("lubey-ely-table3", tmp_path))
    assert len(rows) == 7
    chi2 = means(weight_table(rows, "chi2"))
    magill = means(weight_table(rows, "magill"))
    claims = {c.key: c for c in table3_claims(chi2, magill)}
    for key in ("no-bias", "small-radio", "medium-radio", "large-radio"):
        assert claims[key].holds, claims[key]
    # With the optical-navigation camera (varying roll, star-field attitude, asteroid beacons) a
    # camera-frame bias present from day 0 is no longer one inertial rotation the optical-only
    # filter can absorb: its beacon residuals reveal it, the radio-only filter takes the weight and
    # the fused filter is penalised most — the paper's ordering (its "radio > 0.8" threshold is
    # what one seed need not reach; docs/validation.md reports the campaign means).
    for size in ("medium", "large"):
        row = chi2[f"{size} bias - optical"]
        assert min(row, key=row.get) == "fused" and row["fused"] < 0.1, row
        assert max(row, key=row.get) == "radio" and row["radio"] > 0.6, row
    small = chi2["small bias - optical"]
    assert abs(small["radio"] - small["optical"]) < 0.05 and small["fused"] < small["radio"], small
    # Magill prefers fused in all seven cases, as the paper reports (with the old single-roll camera
    # the large optical bias was the exception: the optical-only filter absorbed it)
    assert claims["magill-fused"].holds, claims["magill-fused"]


def test_table4_orderings(tmp_path):
    rows = ok_rows(_reduced("lubey-ely-table4", tmp_path, drop_cases=("no mis-modelling",)))
    assert len(rows) == 2
    row = weight_table(rows, "chi2", scenario="insight-thrusters")["attitude thruster"].mean
    claim = table4_claim("attitude thruster", row)
    assert claim.holds, claim
    # process noise: the low-Q radio and fused filters come last, and the other four are within a few
    # thousandths of each other — which of them is highest is a coin toss over seeds (docs/validation.md
    # reports the 10-seed means, where fused-Q edges out the optical filters by less than that spread)
    row = weight_table(rows, "chi2", scenario="insight-process-noise")["process noise"].mean
    assert set(sorted(row, key=row.get)[:2]) == {"radio", "fused"}, row
    rest = [v for k, v in row.items() if k not in ("radio", "fused")]
    assert max(rest) - min(rest) < 0.003, row
