"""Model registry: `create_model(name, **cfg)`, `list_models()`."""

from steerlab.models.registry import SteeringModel, create_model, list_models, model_class, register

# Importing the modules registers their models.
from steerlab.models import baselines, motion, multitask, pilotnet, recurrent  # noqa: E402,F401

__all__ = ["SteeringModel", "create_model", "list_models", "model_class", "register"]
