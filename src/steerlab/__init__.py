"""steerlab: end-to-end driving models, camera video in, steering angle and speed out."""

__version__ = "0.1.0"
