"""Particle shapes (chapter section 2.3): disks/spheres, ellipses/spheroids with the exact
contact distance, rigid bodies of fused spherical sites; orientations; contact distances."""

from jamflow.model.shapes.contact_distance import (APART, METHODS, OVERLAPPING, TOUCHING, contact_distance,
                                                   contact_distance_gradient, contact_function, contact_lambda,
                                                   lambda_polynomial, overlap_state, truncation_fallbacks)
from jamflow.model.shapes.shape import SHAPES, SPHERE, Ellipsoid, RigidBody, Sphere, shape_from_attrs
from jamflow.model.shapes.parse import parse_shape

__all__ = [
    "APART",
    "METHODS",
    "OVERLAPPING",
    "SHAPES",
    "SPHERE",
    "TOUCHING",
    "Ellipsoid",
    "RigidBody",
    "Sphere",
    "contact_distance",
    "contact_distance_gradient",
    "contact_function",
    "contact_lambda",
    "lambda_polynomial",
    "overlap_state",
    "parse_shape",
    "shape_from_attrs",
    "truncation_fallbacks",
]
