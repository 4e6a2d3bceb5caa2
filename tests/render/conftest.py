import numpy as np
import pytest

from rollsim.scene import scene_from_dict


def make_scene(effects=(), **sections):
    """A small, fast scene: 200 x 160 px, given row time, no effects unless listed."""
    data = {
        "name": "test",
        "seed": 5,
        "camera": {"preset": "nexus5", "width_px": 160, "height_px": 200, "row_time_us": 20.0, "output": "raw16"},
        "led": {"size_mm": 30.0, "luminous_intensity_cd": 0.05},
        "link": {"distance_cm": 5.0},
        "effects": effects if isinstance(effects, dict) else list(effects),
    }
    for section, values in sections.items():
        if isinstance(values, dict):
            data.setdefault(section, {}).update(values)
        else:
            data[section] = values
    return scene_from_dict(data)


@pytest.fixture
def scene_factory():
    return make_scene


class SingleChip:
    """Chip source with one ON chip (index ``on``), OFF elsewhere."""

    def __init__(self, on):
        self.on = on

    def values(self, chip):
        return (np.asarray(chip) == self.on).astype(np.uint8)

    def ones_before(self, chip):
        return (np.asarray(chip, dtype=np.int64) > self.on).astype(np.int64)
