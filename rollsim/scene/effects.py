"""The scene's ``effects`` section, derived from the effects registry.

A scene lists its effects under ``effects``; an effect that is not listed is
not computed. Names come from the closed registry
(:data:`rollsim.effects.REGISTRY`) only: a scene never names code. Each
effect's parameters are its own module's model, with units in the names;
this module only assembles them into the section's model and checks the
effects a scene lists against each other and the scene.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, ClassVar, Optional, Sequence

from pydantic import create_model

from rollsim.effects import REGISTRY
from rollsim.effects.base import Effect, EffectParams
from rollsim.errors import SceneError, short_repr

if TYPE_CHECKING:
    from rollsim.scene.model import Scene


class EffectsBase(EffectParams):
    """Which effects a scene calls for (``None`` = not listed, not computed).

    One optional field per registered effect, in registry order; the
    registry the model was derived from is :attr:`registry`.
    """

    registry: ClassVar[tuple[Effect, ...]] = ()

    def enabled(self) -> tuple[str, ...]:
        """Names of the listed effects, in registry order."""
        return tuple(effect.name for effect in self.registry if getattr(self, effect.name) is not None)

    def listed(self) -> tuple[tuple[Effect, EffectParams], ...]:
        """The listed effects and their parameters, in registry order."""
        return tuple((effect, getattr(self, effect.name)) for effect in self.registry
                     if getattr(self, effect.name) is not None)

    def __contains__(self, name: object) -> bool:
        """Whether the scene lists effect ``name``."""
        return isinstance(name, str) and name in type(self).model_fields and getattr(self, name) is not None

    def errors(self, scene: Scene) -> list[str]:
        """Why ``scene`` cannot have the effects it lists, one line each
        (each effect's check, requirements and exclusions)."""
        names = frozenset(self.enabled())
        return [line for effect, params in self.listed() for line in effect.errors(scene, params, names)]

    if TYPE_CHECKING:
        # The fields are the registry's: a type checker sees each as its params or None.
        def __getattr__(self, name: str) -> Any: ...


def effects_model(registry: Sequence[Effect]) -> type[EffectsBase]:
    """The ``effects`` section's model for ``registry``: one optional field per effect.

    Raises
    ------
    ValueError
        Two effects of the same name.
    """
    registry = tuple(registry)
    names = [effect.name for effect in registry]
    twice = sorted({name for name in names if names.count(name) > 1})
    if twice:
        raise ValueError(f"effects registered twice: {', '.join(twice)}")
    fields: dict[str, Any] = {effect.name: (Optional[effect.params], None) for effect in registry}
    model = create_model("Effects", __base__=EffectsBase, __module__=__name__, **fields)
    model.registry = registry
    return model


if TYPE_CHECKING:
    Effects = EffectsBase
else:
    Effects = effects_model(REGISTRY)

EFFECT_NAMES = tuple(effect.name for effect in REGISTRY)


def normalise_effects(value):
    """Turn the scene's ``effects`` value into ``{name: params}``.

    A bare list of names is accepted; ``name:`` with no value (YAML null) means
    default parameters; ``name: false`` removes an effect a lower layer listed.
    """
    if value is None:
        return {}
    if isinstance(value, (list, tuple)):
        for name in value:
            if not isinstance(name, str):
                raise SceneError(f"effects: {short_repr(name)}: a list of effects holds effect names "
                                 f"({', '.join(EFFECT_NAMES)})")
        return {name: {} for name in value}
    if isinstance(value, dict):
        return {name: ({} if params is None or params is True else params) for name, params in value.items() if params is not False}
    return value
