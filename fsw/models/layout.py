"""The state vector of the onboard filters, assembled from blocks.

Order (a block is present only if some filter of the bank estimates it):

====================  ======  ==========================================================
block                 size    meaning, unit
====================  ======  ==========================================================
position              3       Mars-centred ICRF position, km
velocity              3       Mars-centred ICRF velocity, km/s
srp_bias, srp_stoch   1 + 1   SRP scale factor = 1 + bias + batched Gauss–Markov part, 1
acs_bias, acs_stoch   1 + 1   ACS acceleration = nominal × (1 + bias + daily part), 1
acs_tilt              2       ACS thrust-direction error, small rotation about two axes
                              across the nominal direction (Lubey & Ely 2022 Table 1), rad
accel                 3(d+1)  batched polynomial acceleration, coefficient k of axis j:
                              a_j(t) = Σ_k c_kj ((t − t_batch)/T_batch)^k, km/s²
clock                 ≤ 3     onboard clock phase (s), fractional frequency (1), drift (1/s)
range_bias            1       range bias, km
====================  ======  ==========================================================

A bank runs every filter on the union layout of its filters; a block a filter does not
estimate keeps zero state, zero covariance and zero process noise, which is exactly a filter
without that block (it never receives gain), and lets the bank keep all filters in one stack.

The dynamic parameters act on the acceleration through q = [srp scale, acs magnitude, acs
tilt 1, acs tilt 2, polynomial coefficients]; :attr:`StateLayout.q_columns` maps each state column to its q index.
"""

from __future__ import annotations

from dataclasses import dataclass, field

AXES = ("x", "y", "z")
CLOCK_NAMES = ("clock_phase", "clock_frequency", "clock_drift")
#: Acceleration drivers before the polynomial coefficients: srp scale, acs magnitude, 2 acs tilts.
N_Q_FIXED = 4


@dataclass(frozen=True)
class StateLayout:
    """Union state layout of a bank; build with :meth:`build`."""

    srp: bool
    acs: bool
    poly_degree: int | None
    clock: int
    range_bias: bool
    acs_tilt: bool = False
    names: tuple[str, ...] = field(init=False)
    slices: dict[str, slice] = field(init=False)

    def __post_init__(self) -> None:
        names: list[str] = ["rx", "ry", "rz", "vx", "vy", "vz"]
        slices = {"position": slice(0, 3), "velocity": slice(3, 6)}

        def add(block: str, items: list[str]) -> None:
            slices[block] = slice(len(names), len(names) + len(items))
            names.extend(items)

        if self.srp:
            add("srp_bias", ["srp_bias"])
            add("srp_stoch", ["srp_stoch"])
        if self.acs:
            add("acs_bias", ["acs_bias"])
            add("acs_stoch", ["acs_stoch"])
        if self.acs_tilt:
            add("acs_tilt", ["acs_tilt_1", "acs_tilt_2"])
        if self.poly_degree is not None:
            add("accel", [f"accel_{a}{k}" for k in range(self.poly_degree + 1) for a in AXES])
        if not 0 <= self.clock <= 3:
            raise ValueError("clock must have 0 to 3 components")
        if self.clock:
            add("clock", list(CLOCK_NAMES[: self.clock]))
        if self.range_bias:
            add("range_bias", ["range_bias"])
        object.__setattr__(self, "names", tuple(names))
        object.__setattr__(self, "slices", slices)

    @classmethod
    def build(cls, srp: bool = False, acs: bool = False, poly_degree: int | None = None, clock: int = 0,
              range_bias: bool = False, acs_tilt: bool = False) -> "StateLayout":
        return cls(srp=srp, acs=acs, poly_degree=poly_degree, clock=clock, range_bias=range_bias, acs_tilt=acs_tilt)

    @property
    def n(self) -> int:
        return len(self.names)

    def has(self, block: str) -> bool:
        return block in self.slices

    def index(self, name: str) -> int:
        return self.names.index(name)

    @property
    def n_q(self) -> int:
        """Number of acceleration drivers q: srp scale, acs magnitude, 2 acs tilts, polynomial coefficients."""
        return N_Q_FIXED + (0 if self.poly_degree is None else 3 * (self.poly_degree + 1))

    @property
    def q_columns(self) -> tuple[tuple[int, int], ...]:
        """(state column, q index) pairs: ∂a/∂x_column = ∂a/∂q_index."""
        pairs: list[tuple[int, int]] = []
        for block, q in (("srp_bias", 0), ("srp_stoch", 0), ("acs_bias", 1), ("acs_stoch", 1)):
            if self.has(block):
                pairs.append((self.slices[block].start, q))
        if self.has("acs_tilt"):
            s = self.slices["acs_tilt"]
            pairs.extend(((s.start, 2), (s.start + 1, 3)))
        if self.has("accel"):
            s = self.slices["accel"]
            pairs.extend((s.start + i, N_Q_FIXED + i) for i in range(s.stop - s.start))
        return tuple(pairs)
