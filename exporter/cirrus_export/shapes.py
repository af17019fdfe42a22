"""UsdGeom implicit gprims (Sphere, Cube, Cylinder, Cone, Capsule, Plane, and Cylinder_1 and
Capsule_1 with their two radii) tessellated to triangles.

Round shapes are a lathe of a (radius, height) profile about the prim's axis with a
multiple of 4 segments, so the tessellation touches the authored extent on every axis.
Spheres and capsules carry smooth per-point normals (the exact surface's); cubes,
cylinders and cones keep flat facets, since their edges are creases. A plane is two
triangles, `width` by `length` about the origin, facing +`axis` (UsdGeomPlane's table:
axis X spans z by y, Y spans x by z, Z spans x by y).
"""

import numpy as np
from pxr import Usd, UsdGeom

from .meshes import MeshGeometry

SEGMENTS = 32
RINGS = 16

# Cube: 6 faces of the unit cube, each as 4 corners CCW seen from outside.
_CUBE_POINTS = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=np.float64)
_CUBE_QUADS = np.array([[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1],
                        [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]])
# Plane: per axis, the axes its width and length run along (UsdGeomPlane's table).
_PLANE_SPANS = {"X": (2, 1), "Y": (0, 2), "Z": (0, 1)}


def _quads_to_triangles(quads: np.ndarray) -> np.ndarray:
    """(q, 4) CCW quads as (2q, 3) triangles."""
    return np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])


def _lathe(radius: np.ndarray, height: np.ndarray, axis: str) -> tuple[np.ndarray, np.ndarray]:
    """Revolves a profile (bottom to top) about `axis`; returns points and CCW triangles."""
    angle = np.linspace(0.0, 2.0 * np.pi, SEGMENTS, endpoint=False)
    x = radius[:, None] * np.cos(angle)[None, :]
    y = radius[:, None] * np.sin(angle)[None, :]
    z = np.broadcast_to(height[:, None], x.shape)
    local = np.stack([x, y, z], axis=-1).reshape(-1, 3)
    order = {"X": [1, 2, 0], "Y": [2, 0, 1], "Z": [0, 1, 2]}[axis]
    points = np.empty_like(local)
    points[:, order] = local
    ring = np.arange(radius.size - 1)[:, None] * SEGMENTS
    seg = np.arange(SEGMENTS)[None, :]
    nxt = (seg + 1) % SEGMENTS
    quads = np.stack([ring + seg, ring + nxt, ring + SEGMENTS + nxt, ring + SEGMENTS + seg], axis=-1)
    return points, _quads_to_triangles(quads.reshape(-1, 4))


def _plane(width: float, length: float, axis: str) -> tuple[np.ndarray, np.ndarray]:
    """A `width` x `length` rectangle about the origin, spanning UsdGeomPlane's axes for
    `axis`, as two triangles CCW seen from +`axis`."""
    u, v = _PLANE_SPANS[axis]
    points = np.zeros((4, 3))
    points[:, u] = 0.5 * width * np.array([-1.0, 1.0, 1.0, -1.0])
    points[:, v] = 0.5 * length * np.array([-1.0, -1.0, 1.0, 1.0])
    # (u, v, axis) right-handed: CCW in (u, v) faces +axis; otherwise the order reverses.
    right_handed = np.cross(np.eye(3)[u], np.eye(3)[v])["XYZ".index(axis)] > 0
    quad = np.array([[0, 1, 2, 3]] if right_handed else [[0, 3, 2, 1]])
    return points, _quads_to_triangles(quad)


def _sphere_profile(radius: float, half_height: float) -> tuple[np.ndarray, np.ndarray]:
    """Hemispheres of `radius` capping a cylinder of half height `half_height` (0: a sphere)."""
    theta = np.linspace(-0.5 * np.pi, 0.5 * np.pi, RINGS + 1)
    r = radius * np.cos(theta)
    z = radius * np.sin(theta) + np.where(theta < 0, -half_height, half_height)
    r[[0, -1]] = 0.0
    if half_height > 0:
        middle = RINGS // 2
        r = np.insert(r, middle + 1, r[middle])
        z = np.insert(z, middle + 1, half_height)
        z[middle] = -half_height
    return r, z


def _capsule_1_profile(bottom: float, top: float, half_height: float) -> tuple[np.ndarray, ...]:
    """Capsule_1's profile and its unit normals (radius, height, normal r, normal z): spheres
    of radius `bottom` and `top` at -/+`half_height` joined by the cone tangent to both, the
    cap heights set by the radii so that the tangents meet C1 (the schema's doc). The
    tangent ring's normal leans by phi, sin(phi) = (bottom - top) / (2 half_height)."""
    spine = 2.0 * half_height
    phi = np.arcsin(np.clip((bottom - top) / spine, -1.0, 1.0)) if spine > 0 else 0.0
    below = np.linspace(-0.5 * np.pi, phi, RINGS // 2 + 1)
    above = np.linspace(phi, 0.5 * np.pi, RINGS // 2 + 1)
    theta = np.concatenate([below, above])
    radius = np.repeat([bottom, top], RINGS // 2 + 1)
    centre = np.repeat([-half_height, half_height], RINGS // 2 + 1)
    normal_r, normal_z = np.cos(theta), np.sin(theta)
    normal_r[[0, -1]] = 0.0
    return radius * normal_r, centre + radius * normal_z, normal_r, normal_z


def _round_normals(points: np.ndarray, half_height: float, axis: str) -> np.ndarray:
    """Smooth normals of a sphere or capsule: from the nearest point of its axis segment."""
    k = "XYZ".index(axis)
    centre = np.zeros_like(points)
    centre[:, k] = np.clip(points[:, k], -half_height, half_height)
    n = points - centre
    return n / np.linalg.norm(n, axis=1, keepdims=True)


def _attr(prim: Usd.Prim, name: str, time: Usd.TimeCode):
    """An attribute's value at `time`, schema fallback included."""
    return prim.GetAttribute(name).Get(time)


def tessellate(prim: Usd.Prim, time: Usd.TimeCode) -> MeshGeometry | None:
    """The gprim as triangles in object space, or None when the type is not an implicit shape."""
    kind = prim.GetTypeName()
    normals = None
    if kind == "Cube":
        half = 0.5 * _attr(prim, "size", time)
        points, triangles = _CUBE_POINTS * half, _quads_to_triangles(_CUBE_QUADS)
    elif kind in ("Sphere", "Capsule"):
        half = 0.5 * _attr(prim, "height", time) if kind == "Capsule" else 0.0
        axis = _attr(prim, "axis", time) if kind == "Capsule" else "Z"
        points, triangles = _lathe(*_sphere_profile(_attr(prim, "radius", time), half), axis)
        normals = _round_normals(points, half, axis)
    elif kind == "Capsule_1":
        r, z, normal_r, normal_z = _capsule_1_profile(_attr(prim, "radiusBottom", time),
                                                      _attr(prim, "radiusTop", time),
                                                      0.5 * _attr(prim, "height", time))
        axis = _attr(prim, "axis", time)
        points, triangles = _lathe(r, z, axis)
        normals, _ = _lathe(normal_r, normal_z, axis)
    elif kind in ("Cylinder", "Cone", "Cylinder_1"):
        h = 0.5 * _attr(prim, "height", time)
        if kind == "Cylinder_1":
            bottom, top = _attr(prim, "radiusBottom", time), _attr(prim, "radiusTop", time)
        else:
            bottom = _attr(prim, "radius", time)
            top = 0.0 if kind == "Cone" else bottom
        points, triangles = _lathe(np.array([0.0, bottom, top, 0.0]), np.array([-h, -h, h, h]),
                                   _attr(prim, "axis", time))
    elif kind == "Plane":
        points, triangles = _plane(_attr(prim, "width", time), _attr(prim, "length", time),
                                   _attr(prim, "axis", time))
    else:
        return None
    return MeshGeometry(points, triangles, normals, None, np.zeros(len(triangles), dtype=np.int64))
