"""Particle shapes: contact distance of ellipses and spheroids (chapter section 2.3.2)."""

from .contact_distance import (
    APART,
    METHODS,
    OVERLAPPING,
    TOUCHING,
    contact_distance,
    contact_distance_gradient,
    contact_function,
    contact_lambda,
    lambda_polynomial,
    overlap_state,
)
from .ellipse_plot import draw_contact_pair, figure_2_12

__all__ = [
    "APART",
    "METHODS",
    "OVERLAPPING",
    "TOUCHING",
    "contact_distance",
    "contact_distance_gradient",
    "contact_function",
    "contact_lambda",
    "draw_contact_pair",
    "figure_2_12",
    "lambda_polynomial",
    "overlap_state",
]
