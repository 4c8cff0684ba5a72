"""Model families: each one way to model a robot's power from its runs, behind one interface
(`base.ModelFamily`, `base.FittedModel`), listed once (`registry.FAMILIES`). `fit`, `report`
and model.json loop over the registry and name no family.

- `paper`: the paper's phase model (Eq. 1-6 of Zorbas & Razafindralambo), fitted by
  `paper_fit` (least squares over runs).
"""

from wifibot_power.models.base import FitOptions, FittedModel, ModelFamily
from wifibot_power.models.registry import FAMILIES, register

__all__ = ["FAMILIES", "FitOptions", "FittedModel", "ModelFamily", "register"]
