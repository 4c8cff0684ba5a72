"""The model families: the only list of them (`FAMILIES`, in the order `fit --json` and
model.json show them). Adding a family is one module with a `ModelFamily` subclass and one
line here."""

from __future__ import annotations

from wifibot_power.models.base import ModelFamily
from wifibot_power.models.drive import DriveFamily
from wifibot_power.models.paper import PaperFamily

#: name -> family; the paper's phase model first (its section is model.json's top level)
FAMILIES: dict[str, ModelFamily] = {
    family.name: family for family in (PaperFamily(), DriveFamily())
}


def register(family: ModelFamily) -> ModelFamily:
    """Add `family` to `FAMILIES` (a plugin outside this package; tests' toy family)."""
    FAMILIES[family.name] = family
    return family
