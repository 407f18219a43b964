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
