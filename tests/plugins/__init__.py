"""Actuator plugins defined outside maniplab, as a user would (importable as ``plugins.*``)."""
