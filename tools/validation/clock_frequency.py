"""The validation document's pointer to docs/clock-frequency.md: what one-way data say about the
onboard clock's frequency, derived and measured there (numbers from the runs that page lists)."""

from __future__ import annotations

from tools.validation.section import Section

TEXT = """\
A step of the onboard clock's fractional frequency Δy adds c·Δy to one-way Doppler and
c·Δy·(t − t_step) to one-way range, exactly as a velocity change c·Δy along the line of sight
does. Over the InSight arc what separates the two — the line of sight turning 0.53°/day, the Sun's
gravity gradient, the stations' diurnal motion, the optical angles — leaves the impostor a few
percent of c·Δy to explain over weeks, some 200 times less than one day of the filters' ACS
variation absorbs, so the filters never learn the frequency (its σ stays at the 1e-13 a priori
until Mars' gravity takes over in the last day: fused 6.1e-14 at entry). A step is seen only as
the innovation transient while it is absorbed: an excess chi-square (c·Δy)²/(2σ_p²) in one
gating batch (σ_p = 0.0067 mm/s, the filters' predicted σ of range rate + c·y). The 3-of-5
detector needs it to be about a batch's own chi-square: the derived limit is Δy ≈ 1e-12, and the
runs (seeds 1–4, step on day 20) detect 0/4 at 3e-13, 2/4 at 1e-12, 4/4 at 2e-12 and 3e-12.
Derivation, tables and the σ history: [docs/clock-frequency.md](clock-frequency.md);
`tests/test_clock_frequency_observability.py` holds the findings."""


def clock_frequency_section() -> Section:
    s = Section("Beyond the papers: clock-frequency steps and one-way data")
    s.lines += [TEXT, ""]
    return s
