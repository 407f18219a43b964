"""Configuration of the onboard filters and of a filter bank (frozen, validated dataclasses).

Defaults are Lubey & Ely 2022 Table 1 (the nominal InSight approach filter): position 100 km and
velocity 0.1 m/s a priori (diagonal); SRP scale factor 0.11 bias + 0.03 temporal (1-day
batches, 7-day correlation); ACS acceleration magnitude 3 % bias + 5 % temporal (1-day batches,
uncorrelated); ACS thrust orientation 3° (constant random bias). The spacecraft constants (SRP area, mass, Cr; ACS nominal magnitude and thrust
direction) and the camera are those of the InSight-like scenario; a filter's knowledge of them
is part of its model and can differ from the truth.
"""

from __future__ import annotations

from dataclasses import dataclass

from fsw.filters.adaptive_q import AdaptiveQConfig
from fsw.filters.kinds import FILTER_KINDS
from fsw.interface.typed import spec
from fsw.models.clock import DEFAULT_Q_RANDOM_RUN_PER_S3, DEFAULT_Q_RANDOM_WALK_FM_PER_S, DEFAULT_Q_WHITE_FM_S

DAY_S = 86400.0


@dataclass(frozen=True, slots=True)
class BatchedParameterConfig:
    """A parameter = constant bias + a stochastic part estimated in discrete batches (Lubey & Ely 2022
    Table 1), the batches forming an ECRV (Chaer et al. 1998 eqs. 25–26). Sigmas of 0 drop the part."""

    bias_sigma: float = spec(doc="1-sigma of the constant bias", unit="1", ge=0.0)
    temporal_sigma: float = spec(doc="steady-state 1-sigma of the batched stochastic part", unit="1", ge=0.0)
    batch_length_s: float = spec(DAY_S, doc="length of one batch", unit="s", gt=0.0)
    correlation_time_s: float | None = spec(
        None, doc="ECRV correlation time between batches; null: uncorrelated batches", unit="s", gt=0.0
    )


@dataclass(frozen=True, slots=True)
class SrpConfig:
    """Cannonball solar radiation pressure with an estimated scale factor."""

    area_m2: float = spec(8.0, doc="area presented to the Sun", unit="m^2", gt=0.0)
    mass_kg: float = spec(694.0, doc="spacecraft mass", unit="kg", gt=0.0)
    cr: float = spec(1.3, doc="reflectivity coefficient", unit="1", ge=0.0, le=2.0)
    scale: BatchedParameterConfig = spec(
        BatchedParameterConfig(0.11, 0.03, DAY_S, 7.0 * DAY_S), doc="scale factor bias and temporal part"
    )


@dataclass(frozen=True, slots=True)
class AcsConfig:
    """Attitude-control thruster small force: nominal magnitude along a cruise-frame direction."""

    nominal_km_s2: float = spec(5e-12, doc="nominal net acceleration magnitude", unit="km/s^2", ge=0.0)
    direction_body: tuple[float, ...] = spec(
        (0.6, 0.0, 0.8), doc="net thrust direction, cruise body frame (z Sun, x towards Earth)", shape=(3,)
    )
    magnitude: BatchedParameterConfig = spec(
        BatchedParameterConfig(0.03, 0.05, DAY_S, None), doc="magnitude bias and daily part, fractions of nominal"
    )
    direction_sigma_deg: float = spec(
        3.0, doc="1-sigma constant thrust-direction error per axis across the direction; 0 drops the two tilt states",
        unit="deg", ge=0.0, le=20.0,
    )

    def __post_init__(self) -> None:
        if sum(c * c for c in self.direction_body) <= 0.0:
            raise ValueError("direction_body must be non-zero")


@dataclass(frozen=True, slots=True)
class PolyAccelConfig:
    """Batched polynomial acceleration on the inertial axes (Lubey & Ely 2022 §4.4 process-noise model).

    Without ``correlation_time_s`` the coefficients are re-initialised each batch (independent
    batches). With it each coefficient is an ECRV stepping at the batch edges by Chaer et al. 1998 eqs.
    25–26 (x ← m x, P ← m² P + σ² (1 − m²), m = exp(−T_b/τ)): degree 0 with hour batches is
    Chaer et al. 1998's non-gravitational acceleration model."""

    sigma_km_s2: float = spec(
        0.0, doc="a-priori (and steady-state) 1-sigma of every coefficient; 0 disables the block", unit="km/s^2", ge=0.0
    )
    degree: int = spec(1, doc="polynomial degree in normalised batch time", ge=0, le=3)
    batch_length_s: float = spec(
        DAY_S, doc="batch length; coefficients are re-initialised (or step as ECRVs) each batch", unit="s", gt=0.0
    )
    correlation_time_s: float | None = spec(
        None, doc="ECRV correlation time of the coefficients between batches; null: independent batches",
        unit="s", gt=0.0,
    )


@dataclass(frozen=True, slots=True)
class ClockConfig:
    """Onboard clock error states (phase, frequency, drift) and their process noise."""

    # a priori = the dispersion after the last ground synchronisation (0.1 us, 30 m of range),
    # which is what the simulated clock draws; 1 us made the fused filter conservative
    phase_sigma_s: float = spec(1e-7, doc="a-priori phase 1-sigma", unit="s", ge=0.0)
    frequency_sigma: float = spec(1e-13, doc="a-priori fractional frequency 1-sigma; 0 drops frequency and drift", unit="1", ge=0.0)
    drift_sigma_per_s: float = spec(
        1.0e-16 / DAY_S, doc="a-priori drift 1-sigma (the simulated clock's dispersion); 0 drops the drift state",
        unit="1/s", ge=0.0
    )
    drift_per_s: float = spec(3.0e-16 / DAY_S, doc="a-priori mean drift", unit="1/s")
    q_white_fm_s: float = spec(DEFAULT_Q_WHITE_FM_S, doc="white-FM spectral density q1", unit="s", ge=0.0)
    q_random_walk_fm_per_s: float = spec(DEFAULT_Q_RANDOM_WALK_FM_PER_S, doc="random-walk-FM density q2", unit="1/s", ge=0.0)
    q_random_run_per_s3: float = spec(DEFAULT_Q_RANDOM_RUN_PER_S3, doc="random-run-FM density q3", unit="1/s^3", ge=0.0)

    @property
    def components(self) -> int:
        if self.phase_sigma_s == 0.0:
            return 0
        if self.frequency_sigma == 0.0:
            return 1
        return 2 if self.drift_sigma_per_s == 0.0 else 3


@dataclass(frozen=True, slots=True)
class CameraConfig:
    """Pinhole navigation camera (must match the camera that takes the images)."""

    focal_length_mm: float = spec(500.0, doc="focal length", unit="mm", gt=0.0)
    pixel_pitch_um: float = spec(12.0, doc="pixel pitch", unit="um", gt=0.0)
    principal_point_px: tuple[float, ...] = spec((512.5, 512.5), doc="principal point [sample, line]", unit="px", shape=(2,))
    light_time: bool = spec(True, doc="correct the target position for light time")
    aberration: bool = spec(False, doc="apply first-order stellar aberration")

    @property
    def focal_px(self) -> float:
        return self.focal_length_mm * 1e3 / self.pixel_pitch_um


@dataclass(frozen=True, slots=True)
class ManeuverModelConfig:
    """An impulsive manoeuvre as the filter models it: planned Δv plus execution uncertainty."""

    epoch_tdb_s: float = spec(doc="burn epoch, TDB seconds past J2000", unit="s")
    dv_km_s: tuple[float, ...] = spec(doc="planned velocity change, Mars-centred ICRF", unit="km/s", shape=(3,))
    sigma_rel: float = spec(0.0, doc="1-sigma per axis as a fraction of |dv|", unit="1", ge=0.0)
    sigma_km_s: float = spec(0.0, doc="1-sigma per axis, fixed part", unit="km/s", ge=0.0)


@dataclass(frozen=True, slots=True)
class FilterConfig:
    """One EKF of the bank: its state blocks, a-priori sigmas, process noise and data."""

    name: str = spec(doc="filter name, unique in the bank")
    processes: tuple[str, ...] = spec(FILTER_KINDS, doc="measurement kinds this filter updates with")
    position_sigma_km: float = spec(100.0, doc="a-priori position 1-sigma per axis", unit="km", gt=0.0)
    velocity_sigma_km_s: float = spec(1e-4, doc="a-priori velocity 1-sigma per axis", unit="km/s", gt=0.0)
    srp: SrpConfig = spec(SrpConfig(), doc="solar radiation pressure model")
    acs: AcsConfig = spec(AcsConfig(), doc="attitude-thruster small-force model")
    accel: PolyAccelConfig = spec(PolyAccelConfig(), doc="batched polynomial acceleration")
    clock: ClockConfig = spec(ClockConfig(), doc="clock states (phase sigma 0: no clock states)")
    range_bias_sigma_km: float = spec(0.002, doc="a-priori range bias 1-sigma; 0: no range bias state", unit="km", ge=0.0)
    velocity_noise_psd_km2_s3: float = spec(0.0, doc="white acceleration noise on velocity (SNC)", unit="km^2/s^3", ge=0.0)
    sigma_scale: dict[str, float] = spec(default_factory=dict, doc="multiplier on the reported sigma, per kind")
    camera: CameraConfig = spec(CameraConfig(), doc="camera model")
    gate_chi2: float | None = spec(None, doc="edit (do not process) a measurement with chi-square above this", gt=0.0)
    high_q: bool = spec(False, doc="carries inflated dynamic process noise (a -Q filter of Lubey & Ely 2022 §4.4)")
    process_noise: AdaptiveQConfig = spec(
        AdaptiveQConfig(), doc="adaptive state-residual process noise (Garhwal, Halder & Sinha eq. 1); fixed: none"
    )

    def __post_init__(self) -> None:
        bad = [k for k in self.processes if k not in FILTER_KINDS]
        if bad:
            raise ValueError(f"unknown measurement kinds {bad}; known: {FILTER_KINDS}")
        for kind, scale in self.sigma_scale.items():
            if kind not in FILTER_KINDS or not scale > 0.0:
                raise ValueError(f"sigma_scale needs known kinds and positive values, got {kind}={scale}")


@dataclass(frozen=True, slots=True)
class BankConfig:
    """A bank of EKFs advanced together."""

    filters: tuple[FilterConfig, ...] = spec(doc="the filters, in bank order")
    maneuvers: tuple[ManeuverModelConfig, ...] = spec((), doc="modelled impulsive manoeuvres")
    step_fraction: float = spec(0.02, doc="integration step as a fraction of the local dynamical time", unit="1", gt=0.0, le=0.2)
    max_step_s: float = spec(600.0, doc="largest integration step", unit="s", gt=0.0)
    batch_origin_tdb_s: float | None = spec(
        None, doc="epoch from which batch boundaries are counted; null: the bank's initial epoch (the start of "
        "the arc, from which the spacecraft's own daily ACS activity is scheduled)", unit="s"
    )

    def __post_init__(self) -> None:
        names = [f.name for f in self.filters]
        if not names:
            raise ValueError("a bank needs at least one filter")
        if len(set(names)) != len(names):
            raise ValueError(f"filter names must be unique, got {names}")
        degrees = {f.accel.degree for f in self.filters if f.accel.sigma_km_s2 > 0.0}
        if len(degrees) > 1:
            raise ValueError("all filters with a polynomial acceleration must use the same degree")
