"""Which measurement families each filter of a bank processes, and whether it is a high-Q variant.

The characterization decision tree reasons over filter *families*, never over filter names: the
bank configuration declares, per filter, the measurement families it processes (``radio``,
``optical``; ``fused`` is shorthand for both) and whether it carries inflated dynamic process
noise (the ``-Q`` filters of Lubey & Ely 2022 §4.4).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable, Sequence

from fsw.interface.typed import spec

RADIO = "radio"
OPTICAL = "optical"
FUSED = "fused"


@dataclass(frozen=True)
class FilterFamily:
    """Family tags of one filter of the bank (Lubey & Ely 2022 §4.2 and §4.4)."""

    name: str = spec(doc="Filter name, as the bank and the gating network report it")
    families: tuple[str, ...] = spec(
        doc="Measurement families the filter processes: 'radio', 'optical', or 'fused' (= both)"
    )
    high_q: bool = spec(False, doc="True for the high process-noise (-Q) variant of a filter")

    def __post_init__(self) -> None:
        if not self.name:
            raise ValueError("filter name must not be empty")
        if not self.families:
            raise ValueError(f"filter {self.name!r} declares no measurement family")

    @property
    def processes(self) -> frozenset[str]:
        """The measurement families processed, with ``fused`` expanded to radio + optical."""
        out: set[str] = set()
        for tag in self.families:
            if tag == FUSED:
                out.update((RADIO, OPTICAL))
            else:
                out.add(tag)
        return frozenset(out)

    @property
    def group(self) -> str:
        """``radio`` (radio-only), ``optical`` (optical-only), ``fused`` (both) or ``other``."""
        p = self.processes
        if p == {RADIO}:
            return RADIO
        if p == {OPTICAL}:
            return OPTICAL
        if {RADIO, OPTICAL} <= p:
            return FUSED
        return "other"


def ordered_families(families: Iterable[FilterFamily], names: Sequence[str]) -> tuple[FilterFamily, ...]:
    """``families`` reordered to ``names``; every name needs exactly one entry."""
    by_name: dict[str, FilterFamily] = {}
    for fam in families:
        if fam.name in by_name:
            raise ValueError(f"filter {fam.name!r} declared twice in the family tags")
        by_name[fam.name] = fam
    missing = [n for n in names if n not in by_name]
    extra = sorted(set(by_name) - set(names))
    if missing or extra:
        raise ValueError(f"family tags do not match the bank: missing {missing}, unexpected {extra}")
    return tuple(by_name[n] for n in names)
