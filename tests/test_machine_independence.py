"""Results do not depend on the eigen-solver's choice of eigenvector sign, nor on its order of
tied eigenpairs: the rigid bodies' principal frames (``jamflow.model.frames.principal_frame``),
whole jams, normal modes and the nematic director are bit-identical when numpy's and scipy's
``eigh`` and scipy's ``eigsh`` return every eigenvector negated and tied pairs reversed
(``conftest.flipped_eigen_solvers``), as LAPACK or ARPACK on another machine may (modes: signs
only, a degenerate eigenspace has no canonical basis)."""

import numpy as np
import pytest
from conftest import flipped_eigen_solvers

from jamflow.model.frames import canonical_signs, principal_frame
from jamflow.model.shapes import RigidBody, parse_shape
from jamflow.model.shapes.nmers import trimer_max_bend
from jamflow.model.shapes.rotations import rotation_matrices

EQUILATERAL = f"trimer:2:{trimer_max_bend(2.0)!r}"  # three touching sites: isotropic in 2D, I_x = I_y in 3D
TETRAHEDRON = 0.3 * np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], float)  # isotropic: 3 tied moments


def _bent(dim):  # three sites of different diameters, no symmetry, no tied moments
    return RigidBody([[0.0] * dim, [0.6] + [0.0] * (dim - 1), [0.3, 0.45] + [0.0] * (dim - 2)], [1.0, 0.9, 0.8])


BODIES = [(spec, dim) for spec in ("nmer:2:1.5", "dimer:1.5:0.5", "nmer:3:2.5", "trimer:2:0.2", EQUILATERAL)
          for dim in (2, 3)] + [(_bent, 2), (_bent, 3)]


def _body(spec, dim):
    return parse_shape(spec, dim) if isinstance(spec, str) else spec(dim)


def _unit(q):
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def _on_another_machine(make, permute=True):
    with pytest.MonkeyPatch.context() as mp:
        flipped_eigen_solvers(mp.setattr, permute)
        return make()


@pytest.mark.parametrize("spec,dim", BODIES)
def test_body_frames_do_not_depend_on_the_eigen_solver(spec, dim):
    body = _body(spec, dim)
    other = _on_another_machine(lambda: _body(spec, dim))
    assert np.array_equal(other.sites, body.sites)
    assert np.array_equal(other.rotational_lengths(np.ones(1), dim), body.rotational_lengths(np.ones(1), dim))


def _turn(dim, seed=7):
    rng = np.random.default_rng(seed)
    return rotation_matrices(rng.uniform(-np.pi, np.pi, 1) if dim == 2 else _unit(rng.normal(size=(1, 4))), dim)[0]


@pytest.mark.parametrize("spec", [spec for spec, dim in BODIES if dim == 2])
def test_body_frames_are_fixed_by_the_sites(spec):
    """The same sites turned and moved give the same body-frame sites: the frame belongs to the
    body, not to the frame its sites were given in (2D: the union's moments are cheap)."""
    body = _body(spec, 2)
    moved = RigidBody(body.sites @ _turn(2).T + [1.7, -2.9], body.site_diameters, body.label)
    assert np.allclose(moved.sites, body.sites, rtol=0, atol=1e-12)


def _inertia(body):
    from jamflow.model.shapes.union import union_moments

    volume, first, second = union_moments(body.sites, body.site_diameters)
    assert np.abs(first).max() < 1e-12
    return np.trace(second) * np.eye(3) - second if body.dim == 3 else -second


@pytest.mark.parametrize("spec", [spec for spec, dim in BODIES if dim == 3] + ["tetrahedron"])
def test_3d_principal_frames_turn_with_the_sites(spec):
    """3D (tensor and sites turned together; tied moments included): the frame turns with them,
    but for the two tied axes across a linear body, which no site fixes (they come from the
    coordinate axes): there the body-frame sites agree."""
    tensor, sites = (0.7 * np.eye(3), TETRAHEDRON) if spec == "tetrahedron" else (
        _inertia(_body(spec, 3)), _body(spec, 3).sites)
    turn = _turn(3)
    frame, turned = principal_frame(tensor, sites), principal_frame(turn @ tensor @ turn.T, sites @ turn.T)
    assert np.allclose(sites @ turn.T @ turned, sites @ frame, rtol=0, atol=1e-12)
    linear = np.all(sites[:, 1:] == 0)
    assert np.allclose(turned[:, :1] if linear else turned, (turn @ frame)[:, :1] if linear else turn @ frame,
                       rtol=0, atol=1e-12)
    assert np.array_equal(_on_another_machine(lambda: principal_frame(tensor, sites)), frame)


@pytest.mark.parametrize("spec,dim", BODIES)
def test_the_principal_frame_is_proper_principal_and_ascending(spec, dim):
    body = _body(spec, dim)
    tensor = _inertia(body)
    frame = principal_frame(tensor, body.sites)
    assert np.allclose(frame, np.eye(dim), atol=1e-9)  # the body frame is its own principal frame
    assert abs(np.linalg.det(frame) - 1.0) < 1e-14
    moments = np.diag(tensor)
    assert np.all(np.diff(moments) >= -1e-12 * np.abs(moments).max())
    assert np.abs(tensor - np.diag(moments)).max() < 1e-9 * np.abs(moments).max()


def test_the_listed_direction_of_the_sites_is_kept():
    """The axes' sign rule: the first site off the plane perpendicular to an axis lies on its
    negative side, so n-mers keep the direction their sites are listed in (large site of a
    dimer at -x, the middle site of a bent trimer at +y), in 2D as in 3D."""
    for dim in (2, 3):
        assert parse_shape("dimer:1.5:0.5", dim).sites[0, 0] < 0 < parse_shape("dimer:1.5:0.5", dim).sites[1, 0]
        assert np.all(np.diff(parse_shape("nmer:3:2.5", dim).sites[:, 0]) > 0)
        trimer = parse_shape("trimer:2:0.2", dim).sites
        assert trimer[0, 0] < 0 < trimer[2, 0] and trimer[1, 1] > 0 > trimer[0, 1]


def test_canonical_signs():
    v = np.array([[0.1, -0.6, 0.0], [-0.7, 0.6, 0.0], [0.7, 0.1, 0.0]])
    s = canonical_signs(v)
    assert np.array_equal(s, v * [-1, -1, 1]) and np.array_equal(canonical_signs(-v), s)
    assert np.array_equal(canonical_signs(v[:, 0]), -v[:, 0])


JAMS = [("dimer:1.5:0.5", 2, 16), ("trimer:2:0.2", 2, 12), (EQUILATERAL, 2, 12), ("ellipse:1.5", 2, 16),
        pytest.param("spheroid:1.2", 3, 16, marks=pytest.mark.slow),
        pytest.param("dimer:1.2:0.5", 3, 32, marks=pytest.mark.slow)]


@pytest.mark.parametrize("shape,dim,n", JAMS)
def test_jams_do_not_depend_on_the_eigen_solver(shape, dim, n):
    """Bodies' frames (eigh), the ellipses' soft-mode step (dense eigh at N = 16) and the
    spheroids' (eigsh): the same jam bit for bit."""
    from jamflow.protocols.compression import jam

    def run():
        return jam(n=n, dim=dim, seed=3, shape=shape, sizes="mono")

    here, other = run(), _on_another_machine(run)
    assert other.phi_j == here.phi_j
    assert np.array_equal(other.packing.positions, here.packing.positions)
    assert np.array_equal(other.packing.orientations, here.packing.orientations)


def test_modes_and_director_do_not_depend_on_the_eigen_solver():
    """Eigenvectors, the profiled modes and their energy profiles (+delta and -delta swap with
    the mode's sign), dense and sparse, and the nematic director."""
    from pathlib import Path

    from jamflow.analysis.modes import Spectrum, Stability
    from jamflow.io.packing_file import load_packing
    from jamflow.model.nematic import Nematic

    p = load_packing(Path(__file__).parent / "data" / "ellipse1.5_n16_s0.h5")

    def measure():
        dense = Spectrum(method="dense").compute(p)
        sparse = Spectrum(method="sparse", n_modes=8).compute(p)
        return dense, sparse, Stability(spectrum=Spectrum(method="dense")).compute(p, dense), Nematic().compute(p)

    here, other = measure(), _on_another_machine(measure, permute=False)  # tied modes: any basis, not fixed
    for a, b in zip(here[:2], other[:2]):
        assert np.array_equal(a.eigenvalues, b.eigenvalues) and np.array_equal(a.eigenvectors, b.eigenvectors)
    for a, b in zip(here[2].profiles, other[2].profiles):
        assert np.array_equal(a.mode, b.mode) and np.array_equal(a.delta_v_plus, b.delta_v_plus)
    assert np.array_equal(here[3].director, other[3].director)
