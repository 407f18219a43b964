"""The papers' published numbers the validation report compares against, verbatim from Lubey & Ely 2022
Tables 3 and 4, Chaer et al. 1997 §V and Chaer et al. 1998 §V / Table I."""

from __future__ import annotations

#: Lubey & Ely 2022 Table 3: average chi-square gating weights over the full arc (radio, optical, fused).
TABLE3_CHI2: dict[str, tuple[float, float, float]] = {
    "no bias": (0.3354, 0.3272, 0.3374),
    "small bias - optical": (0.4186, 0.2923, 0.2891),
    "medium bias - optical": (0.9008, 0.0638, 0.0354),
    "large bias - optical": (0.9679, 0.0316, 0.0004),
    "small bias - radio": (0.3354, 0.3272, 0.3374),
    "medium bias - radio": (0.3350, 0.3280, 0.3370),
    "large bias - radio": (0.3047, 0.3899, 0.3054),
}
TABLE3_FILTERS = ("radio", "optical", "fused")

#: Lubey & Ely 2022 Table 4: average chi-square gating weights of the six-filter banks.
TABLE4_FILTERS = ("radio", "optical", "fused", "radio-Q", "optical-Q", "fused-Q")
TABLE4_CHI2: dict[str, tuple[float, ...]] = {
    "attitude thruster": (0.0844, 0.2510, 0.0815, 0.1658, 0.2520, 0.1653),
    "process noise": (0.0961, 0.1992, 0.0742, 0.1945, 0.2431, 0.1929),
}

#: Chaer et al. 1997 §V: measurement after which the gate / Magill switch at the first Experiment 3 change
#: (the change is after measurement 100), and after which the product form underflows.
CHAER1997_SWITCH = {"gate": 103, "magill": 110}
CHAER1997_UNDERFLOW = 168

#: Chaer et al. 1998 §V: the observations of its hierarchical-bank run.
CHAER1998_OBSERVATIONS = 1230
