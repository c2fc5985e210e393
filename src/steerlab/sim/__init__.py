"""A small deterministic driving world: procedural roads, a pinhole camera renderer, a kinematic bicycle
vehicle, an expert driver, a recording writer and closed-loop driving of trained models."""
