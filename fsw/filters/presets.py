"""Built-in filter banks of Lubey & Ely 2022.

* ``nominal`` (§4.2): ``radio`` (range + Doppler, clock and range-bias states), ``optical``
  (optical only; no clock or range-bias states — the data-type-specific bias terms are removed,
  §4.1) and ``fused`` (everything), all with the Table 1 setup.
* ``acs-q`` (§4.4, attitude-thruster scenario): the three standard filters, which model a 3 %
  ACS magnitude bias and 5 % daily variation, plus ``radio-Q``, ``optical-Q``, ``fused-Q``
  modelling a 300 % bias and a 1000 % daily variation (``high_q``: the detector's
  high-process-noise family).
* ``process-noise-q`` (§4.4, process-noise scenario): all six filters drop the ACS magnitude
  and direction parameters and the SRP temporal part (SRP bias only) and instead estimate a batched (1-day)
  polynomial acceleration with a-priori 1-sigma 5e-12 km/s² (standard filters) or 5e-11 km/s²
  (the ``-Q`` filters, ``high_q``).
"""

from __future__ import annotations

import dataclasses
from typing import Any

from fsw.fdir import families
from fsw.filters import kinds
from fsw.filters.config import (
    DAY_S,
    AcsConfig,
    BankConfig,
    BatchedParameterConfig,
    ClockConfig,
    FilterConfig,
    PolyAccelConfig,
    SrpConfig,
)

RADIO: tuple[str, ...] = kinds.of_family(families.RADIO)
OPTICAL: tuple[str, ...] = kinds.of_family(families.OPTICAL)
FUSED: tuple[str, ...] = RADIO + OPTICAL


def _family(name: str, processes: tuple[str, ...], **changes: Any) -> FilterConfig:
    base = FilterConfig(name=name, processes=processes)
    if processes == OPTICAL:
        base = dataclasses.replace(base, clock=ClockConfig(phase_sigma_s=0.0), range_bias_sigma_km=0.0)
    return dataclasses.replace(base, **changes)


def nominal_bank() -> BankConfig:
    """radio / optical / fused (Lubey & Ely 2022 §4.2)."""
    return BankConfig(filters=(_family("radio", RADIO), _family("optical", OPTICAL), _family("fused", FUSED)))


def acs_q_bank() -> BankConfig:
    """Six filters of the attitude-thruster mis-modelling case (Lubey & Ely 2022 §4.4)."""
    wide = AcsConfig(magnitude=BatchedParameterConfig(3.0, 10.0, DAY_S, None))
    std = [_family(n, k) for n, k in (("radio", RADIO), ("optical", OPTICAL), ("fused", FUSED))]
    q = [_family(n + "-Q", k, acs=wide, high_q=True) for n, k in (("radio", RADIO), ("optical", OPTICAL), ("fused", FUSED))]
    return BankConfig(filters=tuple(std + q))


def process_noise_q_bank(low_sigma_km_s2: float = 5e-12, high_sigma_km_s2: float = 5e-11) -> BankConfig:
    """Six filters of the process-noise case (Lubey & Ely 2022 §4.4)."""
    no_acs = AcsConfig(magnitude=BatchedParameterConfig(0.0, 0.0, DAY_S, None), direction_sigma_deg=0.0)
    srp_bias_only = SrpConfig(scale=BatchedParameterConfig(0.11, 0.0, DAY_S, None))
    out = []
    for suffix, sigma in (("", low_sigma_km_s2), ("-Q", high_sigma_km_s2)):
        for n, k in (("radio", RADIO), ("optical", OPTICAL), ("fused", FUSED)):
            out.append(_family(n + suffix, k, acs=no_acs, srp=srp_bias_only, high_q=suffix == "-Q",
                               accel=PolyAccelConfig(sigma_km_s2=sigma, degree=1, batch_length_s=DAY_S)))
    order = ["radio", "optical", "fused", "radio-Q", "optical-Q", "fused-Q"]
    return BankConfig(filters=tuple(sorted(out, key=lambda f: order.index(f.name))))


PRESETS = {
    "nominal": nominal_bank,
    "acs-q": acs_q_bank,
    "process-noise-q": process_noise_q_bank,
}


def preset(name: str) -> BankConfig:
    """A built-in bank by name (see :data:`PRESETS`)."""
    try:
        return PRESETS[name]()
    except KeyError:
        raise KeyError(f"unknown bank preset {name!r}; known: {', '.join(PRESETS)}") from None
