"""The helpers every gating network shares (fsw/gating/base.py)."""

from __future__ import annotations

import numpy as np

from fsw.gating.base import log_normalize


def test_log_normalize_of_a_fully_enabled_bank_is_the_masked_form_to_the_bit():
    """The shortcut for a bank with every filter enabled (the largest term found in Python, up to
    three terms added in Python) gives the masked numpy form's bits — the sum written out left
    to right as numpy adds a few numbers, not Python's sum(), which compensates from 3.12 on."""
    rng = np.random.default_rng(8)
    for n in (1, 2, 3, 4, 6):
        for _ in range(3000):
            log_w = rng.normal(0.0, 10.0 ** rng.uniform(-3, 2), n) + rng.uniform(-50, 50)
            fast = log_normalize(log_w, np.ones(n, dtype=bool))
            masked = log_normalize(np.append(log_w, 0.0), np.append(np.ones(n, dtype=bool), False))[:n]
            assert np.array_equal(fast, masked), (n, log_w)
            top = log_w.max()
            assert np.array_equal(fast, log_w - (top + np.log(np.sum(np.exp(log_w - top)))))


def test_check_record_refuses_every_non_finite_number_and_negative_chi_square():
    """One pass over the residuals, S and the chi-squares: a NaN or an infinity in any of them, in
    any place, or something that is not a number, is refused; a chi-square below zero is refused,
    a signed zero is not; the record's active mask comes back."""
    import math

    import pytest

    from fsw.filters.record import BankRecord
    from fsw.gating.base import GatingInputError, check_record

    names = ("a", "b", "c")

    def record(**change):
        fields = dict(t=5.0, seq=1, kind="doppler", filters=names, residual=np.array([[1e-3], [2e-3], [-1e-3]]),
                      S=np.array([[[1e-6]], [[2e-6]], [[3e-6]]]), chi2=np.array([1.0, 2.0, 0.3]),
                      processed=np.array([True, True, False]), active=np.array([True, False, True]))
        fields.update(change)
        return BankRecord(**fields)

    assert check_record(record(), names).tolist() == [True, False, True]
    assert check_record(record(chi2=np.array([-0.0, 1e300, 0.0])), names).tolist() == [True, False, True]
    good = record()
    for field in ("residual", "S", "chi2"):
        for place in range(3):
            for bad in (math.nan, math.inf, -math.inf):
                values = getattr(good, field).copy()
                values.reshape(-1)[place] = bad
                with pytest.raises(GatingInputError, match="non-finite"):
                    check_record(record(**{field: values}), names)
        values = getattr(good, field).astype(object)
        values.reshape(-1)[1] = "x"
        with pytest.raises(GatingInputError, match="non-finite"):
            check_record(record(**{field: values}), names)
    with pytest.raises(GatingInputError, match="negative chi-square"):
        check_record(record(chi2=np.array([1.0, -1e-300, 0.3])), names)
    with pytest.raises(GatingInputError, match="non-finite time tag"):
        check_record(record(t=math.nan), names)
