"""The effects a scene may list: one module each, registered in one list.

:data:`REGISTRY` is the one list. The scene schema's ``effects`` section
(:class:`rollsim.scene.effects.Effects`) and the render pipeline
(:mod:`rollsim.render.stages`) are both derived from it, so an effect is
added by writing its module (see :mod:`rollsim.effects.base` and
docs/adding-an-effect.md) and one line here.

The order is the order of work: the per-scene hooks run in it, and stages
that share a slot run in it. ``bayer`` recomputes the electron rates from
spectra, so it comes before the hooks that scale them; the lens effects
(``blur``, ``defocus``) set the footprint that ``led_profile`` and
``glare`` shape, in that order. A test checks that a hook that sets a field without
reading it comes before every hook that reads the field.
"""

from rollsim.effects import (
    ambient,
    bayer,
    blooming,
    blur,
    column_fpn,
    dark_current,
    defocus,
    dsnu,
    flicker,
    frame_jitter,
    glare,
    isp_smoothing,
    jpeg,
    led_profile,
    led_rise_time,
    motion,
    prnu,
    read_noise,
    row_noise,
    sharpening,
    shot_noise,
    tone_curve,
    video_codec,
    vignetting,
)
from rollsim.effects.base import SLOTS, Effect, EffectParams, NoParams, Stage

REGISTRY: tuple[Effect, ...] = (
    ambient.EFFECT,
    shot_noise.EFFECT,
    read_noise.EFFECT,
    row_noise.EFFECT,
    dark_current.EFFECT,
    prnu.EFFECT,
    dsnu.EFFECT,
    column_fpn.EFFECT,
    tone_curve.EFFECT,
    bayer.EFFECT,
    blur.EFFECT,
    defocus.EFFECT,
    led_profile.EFFECT,
    glare.EFFECT,
    vignetting.EFFECT,
    led_rise_time.EFFECT,
    frame_jitter.EFFECT,
    motion.EFFECT,
    flicker.EFFECT,
    blooming.EFFECT,
    isp_smoothing.EFFECT,
    sharpening.EFFECT,
    jpeg.EFFECT,
    video_codec.EFFECT,
)

__all__ = ["Effect", "EffectParams", "NoParams", "REGISTRY", "SLOTS", "Stage"]
