"""The scene's sections as validated models: what the physics reads of a scene.

The camera, the LED, the link, the environment, the channel layer and the
render's fidelity, and :class:`SceneSections`: a scene without its
``effects`` section, which :class:`rollsim.scene.model.Scene` adds (derived
from the effects registry, above these layers). The optics, the
transmitter and the effects name :class:`SceneSections` for the scene they
are given, so that no import runs up to :mod:`rollsim.scene`.

File units are in the key names (``exposure_us``, ``distance_cm``,
``ambient_lux``); the properties ending in ``_s``, ``_m`` give SI values for
the numeric code.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Literal, Optional, Protocol

from pydantic import BaseModel, ConfigDict, Field


class _Section(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, strict=True)


class Camera(_Section):
    """The camera: geometry, row timing, exposure, lens and sensor."""

    preset: Optional[str] = None
    width_px: int = Field(ge=1, le=20000)
    height_px: int = Field(ge=1, le=20000)
    # A video camera takes a frame at least every 100 s, and no sensor reads
    # a row in less than a nanosecond: slower or faster is not a link.
    frame_rate_hz: float = Field(ge=0.01, le=10000)
    row_time_us: Optional[float] = Field(None, ge=1e-3, le=1e5)
    ifg_ratio: Optional[float] = Field(None, ge=0, lt=1)
    exposure_us: float = Field(gt=0, le=1e7)
    iso: float = Field(gt=0, le=1e7)
    pixel_pitch_um: float = Field(gt=0, le=100)
    focal_length_mm: float = Field(gt=0, le=2000)
    f_number: float = Field(ge=0.5, le=64)
    lens_transmission: float = Field(0.9, gt=0, le=1)
    qe: float = Field(gt=0, le=1)
    full_well_e: float = Field(gt=0, le=1e7)
    read_noise_e: float = Field(ge=0, le=1e4)
    dark_current_e_per_s: float = Field(ge=0, le=1e7)
    prnu_percent: float = Field(ge=0, le=100)
    dsnu_e: float = Field(ge=0, le=1e4)
    adc_bits: int = Field(ge=1, le=16)
    black_level_dn: int = Field(ge=0, le=65535)
    base_iso: float = Field(gt=0, le=1e7)
    gain_dn_per_e: float = Field(gt=0, le=1e4)
    output: Literal["gray8", "raw16", "rgb8"] = "gray8"
    # The camera's identity: seeds its fixed patterns (PRNU, DSNU, dark-signal
    # map, hot pixels, column pattern); the scene's seed then seeds only the
    # temporal noise. None: the scene's seed seeds both.
    identity_seed: Optional[int] = Field(None, ge=0, le=2**63 - 1)
    # Binned readout: k rows exposed and read as one (their exposure windows
    # start together, a group every k·row_time_us), averaged, and written to
    # all k output rows. row_time_us stays the time per output row.
    binning_rows: int = Field(1, ge=1, le=8)  # must divide height_px (the loader's consistency check)

    @property
    def frame_period_s(self) -> float:
        """T_f, seconds between frame starts."""
        return 1.0 / self.frame_rate_hz

    @property
    def row_time_s(self) -> float:
        """t_row, seconds between the starts of two successive rows."""
        if self.row_time_us is not None:
            return self.row_time_us * 1e-6
        if self.ifg_ratio is None:
            raise ValueError("camera: give row_time_us or ifg_ratio")  # the loader requires one
        return self.frame_period_s * (1.0 - self.ifg_ratio) / self.height_px

    @property
    def readout_s(self) -> float:
        """H·t_row, the time from the first row's start to the last row's start."""
        return self.height_px * self.row_time_s

    @property
    def ifg_ratio_effective(self) -> float:
        """δ_g/δ_f = 1 - H·t_row/T_f, whichever way the row timing was given."""
        return 1.0 - self.readout_s / self.frame_period_s

    @property
    def exposure_s(self) -> float:
        return self.exposure_us * 1e-6

    @property
    def gain_dn_per_e_at_iso(self) -> float:
        """Conversion gain K at the set ISO: gain_dn_per_e · iso / base_iso."""
        return self.gain_dn_per_e * self.iso / self.base_iso


class Led(_Section):
    """The transmitting LED."""

    size_mm: float = Field(4.0, gt=0, le=1e4)
    shape: Literal["disk", "square"] = "disk"
    luminous_intensity_cd: float = Field(2.0, ge=0, le=1e7)
    peak_wavelength_nm: float = Field(630.0, ge=360, le=830)
    off_level: float = Field(0.0, ge=0, le=1)
    face_reflectance: float = Field(0.2, ge=0, le=1)
    position_px: Optional[list[float]] = Field(None, min_length=2, max_length=2)


class Link(_Section):
    """Geometry, PHY-SDU format, strategy and waveform pattern."""

    distance_cm: float = Field(5.0, gt=0, le=1e5)
    clock_hz: float = Field(8000.0, gt=0, le=1e7)
    line_code: Literal["manchester", "4b6b"] = "manchester"
    header_bits: int = Field(5, ge=0, le=32)
    payload_bits: int = Field(19, ge=1, le=4096)
    check: Literal["parity2", "crc8"] = "parity2"
    message_bytes: int = Field(50, ge=1, le=10**7)
    # rp, rs: repetition of the K packets; rlnc: random linear coding over
    # GF(2), every emission a fresh combination whose seed the header carries.
    strategy: Literal["rp", "rs", "rlnc"] = "rp"
    repeats: int = Field(1, ge=1, le=10**6)
    pattern: Literal["data", "square", "on", "off"] = "data"
    start_offset_us: float = Field(0.0, ge=-1e9, le=1e9)

    @property
    def distance_m(self) -> float:
        return self.distance_cm * 1e-2

    @property
    def start_offset_s(self) -> float:
        return self.start_offset_us * 1e-6


class Environment(_Section):
    """Ambient light."""

    ambient_lux: float = Field(650.0, ge=0, le=1e7)
    background_reflectance: float = Field(0.5, ge=0, le=1)
    ambient_illuminant: Literal["FL2", "FL11", "D65", "A"] = "FL2"
    # Any grid frequency in the range: the nominal 50 or 60 Hz, or off-nominal
    # values (the flicker's drift across frames depends on the exact value).
    mains_hz: float = Field(50.0, ge=40, le=70)


class Channel(_Section):
    """The MMBP channel layer's parameters (the pixel layer ignores them)."""

    p_e: float = Field(0.001, ge=0, le=1)
    M: Optional[int] = Field(None, ge=0, le=10**7)
    N: Optional[int] = Field(None, ge=0, le=10**7)
    frame_jitter_us: float = Field(0.0, ge=0, le=1e7)


class Render(_Section):
    """Fidelity settings of the core render (effects carry their own)."""

    footprint_edge: Literal["exact", "supersample1", "supersample4", "supersample16"] = "exact"


class EffectsSection(Protocol):
    """What the layers below the effects registry read of a scene's ``effects`` section
    (:class:`rollsim.scene.effects.EffectsBase`)."""

    def enabled(self) -> tuple[str, ...]: ...

    def listed(self) -> tuple[tuple[Any, Any], ...]: ...

    def errors(self, scene: Any) -> list[str]: ...

    def __contains__(self, name: object) -> bool: ...


class SceneSections(_Section):
    """A scene's sections, without the ``effects`` section (:class:`rollsim.scene.model.Scene` adds it)."""

    name: str = "scene"
    description: str = ""
    seed: int = Field(1, ge=0, le=2**63 - 1)
    frames: int = Field(300, ge=1, le=10**9)
    camera: Camera
    led: Led = Led()
    link: Link = Link()
    environment: Environment = Environment()
    channel: Channel = Channel()
    render: Render = Render()

    if TYPE_CHECKING:
        # A field of Scene, whose model is derived from the effects registry above.
        effects: EffectsSection
