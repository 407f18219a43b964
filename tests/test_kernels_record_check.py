"""The compiled check of a bank record's numbers against numpy's own tests of the same arrays, and
check_record's answer for arrays the kernel does not take."""

import math

import numpy as np
import pytest

from fsw.filters.record import BankRecord
from fsw.gating.base import GatingInputError, check_record
from fsw.kernels.codes import RECORD_NEGATIVE_CHI2, RECORD_NON_FINITE, RECORD_OK
from fsw.kernels.record_check import record_values_status


def _expected(res, S, chi2):
    if not (np.isfinite(res).all() and np.isfinite(S).all() and np.isfinite(chi2).all()):
        return RECORD_NON_FINITE
    return RECORD_NEGATIVE_CHI2 if (chi2 < 0.0).any() else RECORD_OK


def test_status_is_numpys_verdict_on_random_records():
    rng = np.random.default_rng(11)
    seen = set()
    for _ in range(3000):
        N, m = int(rng.integers(1, 7)), int(rng.integers(1, 4))
        res, S, chi2 = rng.standard_normal((N, m)), rng.standard_normal((N, m, m)), rng.random(N) * 10.0
        for arr in (res, S, chi2):
            if rng.random() < 0.15:
                arr.reshape(-1)[rng.integers(arr.size)] = rng.choice([math.nan, math.inf, -math.inf])
        if rng.random() < 0.2:
            chi2[rng.integers(N)] = rng.choice([-1e-300, -0.0, -3.0])
        got = record_values_status(res, S, chi2)
        assert got == _expected(res, S, chi2)
        seen.add(got)
    assert seen == {RECORD_OK, RECORD_NON_FINITE, RECORD_NEGATIVE_CHI2}


def _record(**change):
    names = ("a", "b", "c")
    fields = dict(t=5.0, seq=1, kind="range", filters=names, residual=np.array([[1e-3], [2e-3], [-1e-3]]),
                  S=np.array([[[1e-6]], [[2e-6]], [[3e-6]]]), chi2=np.array([1.0, 2.0, 0.3]),
                  processed=np.array([True, True, False]), active=np.array([True, True, True]))
    fields.update(change)
    return BankRecord(**fields), names


@pytest.mark.parametrize("convert", [
    lambda a: a.astype(np.float32),
    lambda a: np.asfortranarray(a) if a.ndim > 1 else a[::-1].copy()[::-1],  # not C-ordered
    lambda a: a.tolist(),
])
@pytest.mark.parametrize("field", ["residual", "S", "chi2"])
def test_arrays_the_kernel_does_not_take_get_the_same_answer(convert, field):
    good, names = _record()
    value = getattr(good, field)
    assert check_record(_record(**{field: convert(value)})[0], names).tolist() == [True, True, True]
    bad = value.copy()
    bad.reshape(-1)[-1] = math.nan
    with pytest.raises(GatingInputError, match="non-finite"):
        check_record(_record(**{field: convert(bad)})[0], names)
    if field == "chi2":
        with pytest.raises(GatingInputError, match="negative chi-square"):
            check_record(_record(chi2=convert(np.array([1.0, -2.0, 0.3])))[0], names)


def test_a_read_only_record_is_checked_too():
    rec, names = _record()
    for arr in (rec.residual, rec.S, rec.chi2):
        arr.flags.writeable = False
    assert check_record(rec, names).tolist() == [True, True, True]
    bad = np.array([1.0, math.inf, 0.3])
    bad.flags.writeable = False
    with pytest.raises(GatingInputError, match="non-finite"):
        check_record(_record(chi2=bad)[0], names)
