"""The chi-square network's batch sums (Lubey & Ely 2022 eq. 6 with the §3.2 substitution), added
by the compiled kernel, against the same sums added in Python in arrival order."""

import numpy as np

from fsw.filters.record import BankRecord
from fsw.gating.base import check_record
from fsw.gating.chi2 import Chi2Network, Chi2Params
from fsw.kernels.chi2_batch import chi2_batch_sums

NAMES = ("radio", "optical", "fused", "radio-Q")


def _records(rng, count):
    for j in range(count):
        n = int(rng.integers(1, 3))
        chi2 = rng.chisquare(n, len(NAMES)) * 10.0 ** rng.uniform(-3, 3)
        yield BankRecord(float(j), j, "range", NAMES, rng.standard_normal((len(NAMES), n)),
                         np.tile(np.eye(n), (len(NAMES), 1, 1)), chi2, rng.random(len(NAMES)) < 0.6,
                         np.ones(len(NAMES), dtype=bool))


def _python_sums(records):
    sums = [[0.0] * len(NAMES) for _ in range(4)]
    for rec in records:
        n = float(rec.residual.shape[1])
        for i, (done, c) in enumerate(zip(rec.processed.tolist(), rec.chi2.tolist())):
            sums[0 if done else 2][i] += c
            sums[1 if done else 3][i] += n
    return np.array(sums)


def test_kernel_sums_are_the_python_sums_to_the_bit():
    rng = np.random.default_rng(4)
    records = list(_records(rng, 500))
    sums = np.zeros((4, len(NAMES)))
    for rec in records:
        chi2_batch_sums(rec.chi2, rec.processed, float(rec.residual.shape[1]), sums)
    assert sums.tobytes() == _python_sums(records).tobytes()


def test_network_statistic_is_the_substituted_sum_whatever_the_arrays():
    """G_k,i = Σ chi-squares of the processed measurements + Σ n_j of the others (§3.2); records
    whose arrays the kernel does not take (integer flags, a chi-square list) add the same."""
    rng = np.random.default_rng(9)
    records = list(_records(rng, 300))
    fast = Chi2Network(NAMES, Chi2Params(batch_size=10_000))
    slow = Chi2Network(NAMES, Chi2Params(batch_size=10_000))
    for rec in records:
        fast.update_checked(rec, check_record(rec, NAMES))
        odd = BankRecord(rec.t, rec.seq, rec.kind, rec.filters, rec.residual, rec.S, rec.chi2.tolist(),
                         rec.processed.astype(np.int8), rec.active)
        slow.update(odd)
    ref = _python_sums(records)
    assert fast.batch_statistic().tobytes() == (ref[0] + ref[3]).tobytes()
    assert slow.batch_statistic().tobytes() == fast.batch_statistic().tobytes()
