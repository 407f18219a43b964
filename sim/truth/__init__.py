"""The simulator's own models of time, Earth orientation, stations, Mars and its moons.

Truth is written apart from the onboard models (``fsw/astro``) on purpose: where the two share code
their errors cancel and every accuracy figure is optimistic. Here time scales and Earth orientation
come from ERFA (IAU 2006/2000A, with the IERS EOP 20 C04 pole and UT1 series shipped in
``data/eop_c04.csv``), station positions carry plate motion, and Phobos and Deimos follow JPL's
published precessing mean elements. docs/validation.md lists what separates truth from the
onboard models and by how much.
"""
