"""Saturation avoidance by the projector's maximum input gray level (thesis Ch. 4-6)."""
