"""Geometric families from sampled shear paths (chapter section 2.2, Figure 2.7).

Input: the points of ``jamflow.protocols.families.sample`` (every static packing met: strain,
phi_J, mu = Sigma / P, a relabelling-invariant network signature, and its segment, the run of
one path with an unchanged contact network). What identifies a family:

1. along one path the particle labels are fixed, so a segment is one family exactly (the same
   contact pairs at every step), and the forward and backward paths of one sampled packing
   share their first segment;
2. segments of different starts (labels differ) are one family when at some common strain
   (the same point gamma_min + m delta gamma of the lattice all paths step on) they have the
   same signature, phi_J within ``tol_phi``, Sigma / P within ``tol_mu`` and the contact fabric
   anisotropy within TOL_FABRIC. Two packings of one family at one strain differ only by where
   in the window V_tol < V < 2 V_tol they stopped (phi_J to ~1e-9, Sigma / P to ~1e-5 at
   N = 10); distinct families with one signature were measured >= 5e-7 apart in phi_J and
   >= 1e-3 in Sigma / P away from gamma = k / 2 (docs/notes/shear.md). Near integer gamma a family
   and its reflection in the square cell's diagonal touch (same phi_J and Sigma / P at gamma = k,
   separating quadratically): the fabric tells them apart (the reflection flips the sign of
   <n_x^2 - n_y^2>), and the strains k / 2 themselves are left out (``symmetric_strain``).

Families are the connected components (union-find). The mirror check maps every point at
gamma to 1 - gamma (Sigma / P changes sign, Figure 2.4(c)) and asks which families land on
a family by the same rule.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

TOL_PHI = 1e-8
TOL_MU = 1e-4
TOL_FABRIC = 1e-3


class _UnionFind:
    def __init__(self, items):
        self.parent = {x: x for x in items}

    def find(self, x):
        root = x
        while self.parent[root] != root:
            root = self.parent[root]
        while self.parent[x] != root:
            self.parent[x], x = root, self.parent[x]
        return root

    def union(self, a, b):
        ra, rb = self.find(a), self.find(b)
        if ra != rb:
            self.parent[max(ra, rb)] = min(ra, rb)


def _text(values) -> np.ndarray:
    return np.array([v.decode() if isinstance(v, bytes) else str(v) for v in values])


def symmetric_strain(gamma) -> np.ndarray:
    """True at gamma = k / 2, where the square Lees-Edwards cell has symmetries beyond the
    inversion (at integer gamma the diagonal reflection keeps phi_J and Sigma / P: a packing and
    its reflection lie on two different families there; at half-integer gamma the mirror maps
    the cell onto itself). Points there are not used to join families."""
    twice = 2.0 * np.asarray(gamma, float)
    return np.abs(twice - np.round(twice)) < 1e-9


def same_fabric(a: dict, b: dict, p: int, q: int, tol: float = TOL_FABRIC) -> bool:
    """Fabric anisotropies within ``tol`` (True for points sampled without them)."""
    if "fabric_a" not in a or "fabric_a" not in b:
        return True
    return abs(a["fabric_a"][p] - b["fabric_a"][q]) <= tol and abs(a["fabric_b"][p] - b["fabric_b"][q]) <= tol


def matching_pairs(a: dict, b: dict, tol_phi: float = TOL_PHI, tol_mu: float = TOL_MU,
                   tol_fabric: float = TOL_FABRIC):
    """Index pairs (p, q) of points of ``a`` and ``b`` at the same strain index with the same
    signature, |phi_J difference| <= tol_phi, |mu difference| <= tol_mu and fabric anisotropies
    within tol_fabric, away from the symmetric strains (``symmetric_strain``)."""
    sig_a, sig_b = _text(a["signature"]), _text(b["signature"])
    key_a = np.char.add(np.char.add(a["strain_index"].astype(str), "|"), sig_a)
    key_b = np.char.add(np.char.add(b["strain_index"].astype(str), "|"), sig_b)
    order = np.argsort(b["phi_j"], kind="stable")
    groups: dict = {}
    for q in order:
        groups.setdefault(key_b[q], []).append(q)
    out = []
    for p in np.flatnonzero(~symmetric_strain(a["gamma"])):
        for q in groups.get(key_a[p], ()):
            if abs(a["phi_j"][p] - b["phi_j"][q]) <= tol_phi and abs(a["mu"][p] - b["mu"][q]) <= tol_mu \
                    and same_fabric(a, b, p, q, tol_fabric):
                out.append((int(p), int(q)))
    return out


@dataclass(frozen=True)
class Families:
    """Families of the sampled points: ``family`` (one id per point, 0.. in order of first
    strain), and the table rows from ``table()``."""

    points: dict  #: the sampled points, columns by name (``protocols.families.sample``)
    family: np.ndarray  #: (P,) the family of each point, 0.. in order of first strain
    step: float  #: delta gamma of the lattice
    gamma_min: float  #: the strain of lattice point 0

    @property
    def count(self) -> int:
        """Distinct families."""
        return int(self.family.max()) + 1 if len(self.family) else 0

    def members(self, f: int) -> np.ndarray:
        """Indices of the points of family ``f``."""
        return np.flatnonzero(self.family == f)

    def curve(self, f: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(gamma, mean phi_J, spread of phi_J) of family f at each strain it was met."""
        m = self.members(f)
        idx = self.points["strain_index"][m]
        keys = np.unique(idx)
        phi = self.points["phi_j"][m]
        mean = np.array([phi[idx == k].mean() for k in keys])
        spread = np.array([np.ptp(phi[idx == k]) for k in keys])
        return self.gamma_min + keys * self.step, mean, spread

    def table(self) -> list[dict]:
        """One row per family: id, signature, gamma range, strains met, starts that found it,
        segments joined, phi_J at both ends, largest phi_J spread at one strain."""
        rows = []
        sig = _text(self.points["signature"])
        for f in range(self.count):
            m = self.members(f)
            gamma, phi, spread = self.curve(f)
            rows.append(dict(family=f, signature=sig[m[0]], gamma_min=float(gamma[0]), gamma_max=float(gamma[-1]),
                             strains=len(gamma), starts=len(np.unique(self.points["start"][m])),
                             segments=len(np.unique(self.points["segment"][m])), phi_j_min_gamma=float(phi[0]),
                             phi_j_max_gamma=float(phi[-1]), max_spread=float(spread.max())))
        return rows

    def met_in(self, lo: float, hi: float, min_strains: int = 1) -> list[int]:
        """Families met at some strain in [lo, hi], at >= ``min_strains`` strains in all."""
        return [row["family"] for row in self.table() if row["gamma_max"] >= lo - 1e-12
                and row["gamma_min"] <= hi + 1e-12 and row["strains"] >= min_strains]

    def count_in(self, lo: float, hi: float, min_strains: int = 1) -> int:
        """How many families ``met_in(lo, hi, min_strains)``."""
        return len(self.met_in(lo, hi, min_strains))

    def sightings(self) -> np.ndarray:
        """Per family, how many sampled packings' paths (distinct start and grid point) met it."""
        pts = self.points
        seen = np.unique(np.column_stack([self.family, pts["start"], pts["grid"]]), axis=0)
        return np.bincount(seen[:, 0], minlength=self.count)


def join(points: dict, step: float, gamma_min: float = 0.0, tol_phi: float = TOL_PHI, tol_mu: float = TOL_MU,
         starts: int | None = None, tol_fabric: float = TOL_FABRIC) -> Families:
    """Families of ``points`` (only starts < ``starts`` if given); the joining tolerances as in
    ``matching_pairs``."""
    if starts is not None:
        keep = points["start"] < starts
        points = {k: v[keep] for k, v in points.items()}
    segments = points["segment"]
    uf = _UnionFind(np.unique(segments).tolist())
    for p, q in matching_pairs(points, points, tol_phi, tol_mu, tol_fabric):
        if p < q:
            uf.union(int(segments[p]), int(segments[q]))
    roots = np.array([uf.find(int(s)) for s in segments], dtype=np.int64)
    first = {}
    for r, j in sorted(zip(roots.tolist(), points["strain_index"].tolist()), key=lambda x: (x[1], x[0])):
        first.setdefault(r, len(first))
    family = np.array([first[r] for r in roots.tolist()], dtype=np.int64)
    return Families(points, family, float(step), float(gamma_min))


def mirrored(points: dict, step: float, gamma_min: float = 0.0, center: float = 0.5) -> dict:
    """The points mapped by the inversion gamma -> 2 center - gamma, center a multiple of 1/2
    (1 - gamma for center 1/2, -gamma for 0: one map, as gamma and gamma + 1 are one cell);
    Sigma / P and the fabric's <2 n_x n_y> change sign."""
    if abs(2 * center - round(2 * center)) > 1e-12:
        raise ValueError(f"the mirror centre {center} must be a multiple of 1/2 (gamma -> 1 - gamma, -gamma, ...)")
    shift = (2 * center - 2 * gamma_min) / step  # gamma_min + m step -> 2 center - gamma_min - m step
    if abs(shift - round(shift)) > 1e-6:
        raise ValueError(f"the strain lattice (gamma_min {gamma_min}, step {step}) is not symmetric about {center:g}")
    out = dict(points)
    out["strain_index"] = round(shift) - points["strain_index"]
    out["gamma"] = 2 * center - points["gamma"]
    out["mu"] = -points["mu"]
    if "fabric_b" in points:
        out["fabric_b"] = -points["fabric_b"]
    return out


@dataclass(frozen=True)
class MirrorCheck:
    """Which families map onto a family under gamma -> 1 - gamma."""

    partner: dict  #: family -> set of families its mirror image lands on
    worst_phi: float  #: largest |phi_J(gamma) - phi_J'(1 - gamma)| over all matched points
    worst_mu: float  #: largest |mu(gamma) + mu'(1 - gamma)| over all matched points

    def matched(self, among=None) -> int:
        """Families (of ``among``, default all) whose mirror image lands on a family."""
        keys = self.partner if among is None else among
        return sum(1 for f in keys if self.partner[f])

    @property
    def unpaired(self) -> list[int]:
        """Matched families that do not pair up one to one: two or more partners, or a partner
        whose mirror image lands elsewhere as well (pieces of one family the sampling did not
        join yet)."""
        return [f for f, v in self.partner.items() if v and (len(v) > 1 or self.partner[next(iter(v))] != {f})]


def mirror_by_sightings(families: Families, check: MirrorCheck, among, bins=((1, 1), (2, 2), (3, 4), (5, None))):
    """[(bin label, families of ``among`` in it, of them whose mirror image was found)]: a family
    met by few paths is a rare one, whose mirror is rarely sampled too; for well-sampled families
    the fraction should approach 1 if the families are symmetric about gamma = 1/2."""
    seen = families.sightings()
    out = []
    for lo, hi in bins:
        chosen = [f for f in among if seen[f] >= lo and (hi is None or seen[f] <= hi)]
        label = f"{lo}" if lo == hi else (f">= {lo}" if hi is None else f"{lo}-{hi}")
        out.append((label, len(chosen), check.matched(chosen)))
    return out


def mirror_check(families: Families, tol_phi: float = TOL_PHI, tol_mu: float = TOL_MU,
                 center: float = 0.5) -> MirrorCheck:
    """Map every family's points to 2 center - gamma (``mirrored``) and match them against all
    points by the family rule (same strain, signature, phi_J within tol_phi, Sigma / P within tol_mu)."""
    pts = families.points
    mirror = mirrored(pts, families.step, families.gamma_min, center)
    partner = {f: set() for f in range(families.count)}
    worst_phi = worst_mu = 0.0
    for p, q in matching_pairs(mirror, pts, tol_phi, tol_mu):
        partner[int(families.family[p])].add(int(families.family[q]))
        worst_phi = max(worst_phi, abs(mirror["phi_j"][p] - pts["phi_j"][q]))
        worst_mu = max(worst_mu, abs(mirror["mu"][p] - pts["mu"][q]))
    return MirrorCheck(partner, worst_phi, worst_mu)

def convergence(points: dict, step: float, gamma_min: float = 0.0, counts=None, lo: float = 0.0, hi: float = 0.5,
                tol_phi: float = TOL_PHI, tol_mu: float = TOL_MU) -> list[tuple[int, int, int]]:
    """(K, families met in [lo, hi], families met anywhere) using the first K starts per grid
    point, K in ``counts`` (default ~12 values from 1 to all)."""
    return [(row["starts"], row["half"], row["total"])
            for row in by_starts(points, step, gamma_min, counts, lo, hi, tol_phi, tol_mu, estimate=False)]


def by_starts(points: dict, step: float, gamma_min: float = 0.0, counts=None, lo: float = 0.0, hi: float = 0.5,
              tol_phi: float = TOL_PHI, tol_mu: float = TOL_MU, estimate: bool = True) -> list[dict]:
    """One row per K in ``counts`` (default ~12 values from 1 to all), the families of the first
    K starts per grid point: ``starts`` K, ``half`` met in [lo, hi], ``total`` met anywhere, and
    with ``estimate`` the ``richness`` entries."""
    total = int(points["start"].max()) + 1 if len(points["start"]) else 0
    counts = counts or sorted({int(k) for k in np.unique(np.geomspace(1, max(total, 1), 12).round())} | {total})
    rows = []
    for k in counts:
        fam = join(points, step, gamma_min, tol_phi, tol_mu, starts=k)
        rows.append(dict(starts=k, half=fam.count_in(lo, hi), total=fam.count, **(richness(fam) if estimate else {})))
    return rows


def richness(families: Families) -> dict:
    """How complete the sampling is, from the sampled packings (the jammed random starts,
    step 0 of each path; n of them): families they fell into (S_obs), how many were found once
    (f1) and twice (f2), and estimates of the families a sampler of this kind would find with
    unlimited starts. All assume every family has a fixed chance per start, which strains and
    basin sizes make only roughly true; their errors are sampling errors under that assumption.

    * ``chao1``: bias-corrected Chao1, S_obs + f1 (f1 - 1) / (2 (f2 + 1)) (Chao, Biometrics 43,
      783 (1987)); ``chao1_se`` from the variance f1 (f1 - 1) / (2 (f2 + 1)) + f1 (2 f1 - 1)^2 /
      (4 (f2 + 1)^2) + f1^2 f2 (f1 - 1)^2 / (4 (f2 + 1)^4) (Chao, in Encyclopedia of Statistical
      Sciences, 2nd ed., Wiley (2005); the form EstimateS uses).
    * ``jack1``, ``jack2``: first- and second-order jackknife (``jackknife``).
    * ``coverage``: Good-Turing sample coverage 1 - f1 / n, the chance that one more sampled
      packing falls into a family already found (Good, Biometrika 40, 237 (1953))."""
    sampled = families.points["step"] == 0
    counts = np.bincount(families.family[sampled])
    counts = counts[counts > 0]
    f1, f2 = int(np.sum(counts == 1)), int(np.sum(counts == 2))
    g = f2 + 1.0
    variance = f1 * (f1 - 1) / (2 * g) + f1 * (2 * f1 - 1) ** 2 / (4 * g**2) + f1**2 * f2 * (f1 - 1) ** 2 / (4 * g**4)
    n = int(sampled.sum())
    jack1, jack1_se = jackknife(counts, 1)
    jack2, jack2_se = jackknife(counts, 2)
    return dict(sampled=n, observed=len(counts), singletons=f1, doubletons=f2,
                chao1=float(len(counts) + f1 * (f1 - 1) / (2 * g)), chao1_se=float(np.sqrt(variance)),
                jack1=jack1, jack1_se=jack1_se, jack2=jack2, jack2_se=jack2_se,
                coverage=1.0 - f1 / n if n else float("nan"))  # n = 0: every start failed


def jackknife(counts, order: int) -> tuple[float, float]:
    """(estimate, standard error) of the richness by the first- or second-order jackknife of
    Burnham & Overton (Biometrika 65, 625 (1978)), written for n sampled individuals (counts:
    how many of them fell into each class found): S = sum_j a_j f_j with f_j the classes found
    j times, a_j = 1 but a_1 = 1 + (n - 1) / n (order 1); a_1 = 1 + (2 n - 3) / n and
    a_2 = 1 - (n - 2)^2 / (n (n - 1)) (order 2); variance sum_j a_j^2 f_j - S (ibid.)."""
    counts = np.asarray(counts, dtype=np.int64)
    n = int(counts.sum())
    f = np.bincount(counts, minlength=3)[1:]  # f[j - 1] = f_j
    a = np.ones(len(f))
    if order not in (1, 2):
        raise ValueError(f"jackknife order must be 1 or 2, got {order!r}")
    if n < 2:
        return float(len(counts)), float("nan")
    if order == 1:
        a[0] = 1 + (n - 1) / n
    elif order == 2:
        a[0] = 1 + (2 * n - 3) / n
        a[1] = 1 - (n - 2) ** 2 / (n * (n - 1))
    estimate = float(np.sum(a * f))
    return estimate, float(np.sqrt(max(np.sum(a * a * f) - estimate, 0.0)))


def more_samples_needed(rich: dict, fraction: float) -> float:
    """Further sampled packings m after which the expected number of families found reaches
    ``fraction`` of the Chao1 estimate S: the extrapolation S_obs + f0 (1 - (1 - f1 / (n f0 +
    f1))^m), f0 = S - S_obs (Shen, Chao & Lin, Ecology 84, 798 (2003); Chao et al., Ecology 90,
    1125 (2009)), solved for m; 0 if already reached, inf if f1 = 0 leaves nothing to extrapolate."""
    s_obs, f1, n = rich["observed"], rich["singletons"], rich["sampled"]
    f0 = rich["chao1"] - s_obs
    short = fraction * rich["chao1"] - s_obs
    if short <= 0:
        return 0.0
    if f1 == 0 or f0 <= short:
        return float("inf")
    return float(np.log(1 - short / f0) / np.log(1 - f1 / (n * f0 + f1)))
