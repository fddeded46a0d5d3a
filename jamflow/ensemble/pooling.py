"""Pooled structure of an ensemble from one task per packing (``jamflow analyze`` on Dask).

g(r) and S(k) of jamflow.analysis.structure are sums over packings (pair counts and ideal-gas
counts per bin; S and |k| per shell), so per-packing results on common bins merge exactly:
g = sum counts / sum ideal (partials likewise with their ideal pair numbers), S(k) =
sum (S n_vectors) / sum n_vectors per shell. The per-packing bins are fixed by the client
(r_max = half the shortest box width over the ensemble, dk from the first packing), as the
pooled computation would fix them.
"""

from __future__ import annotations

import math

import numpy as np

from jamflow.analysis.structure import (RDF, RDFResult, StructureFactor, StructureFactorResult, _partial_pair_numbers,
                                  check_r_max, rms_contact_distance)
from jamflow.io.packing_file import load_packing


def pooled_bins(packings, k_max: float) -> tuple[float, float]:
    """(r_max, dk) that the pooled RDF and StructureFactor would choose for these packings."""
    first = packings[0]
    dk = 2 * math.pi * rms_contact_distance(first.diameters) / float(first.box.lengths.max())
    return check_r_max(None, packings), dk


def structure_sums(path, dr: float, r_max: float, partial: bool, k_max: float, dk: float):
    """One packing's g(r) (with its partial ideal pair numbers) and S(k) on the pooled bins."""
    packing = load_packing(path)
    rdf = RDF(dr=dr, r_max=r_max, partial=partial).compute(packing)
    pideal = np.empty((0, 0, len(rdf.g)))
    if partial:
        labels = np.searchsorted(rdf.species, packing.diameters)
        pideal = _partial_pair_numbers(labels, len(rdf.species))[:, :, None] * (
            rdf.ideal / (packing.n * (packing.n - 1) / 2.0))[None, None, :]
    return rdf, pideal, StructureFactor(k_max=k_max, dk=dk).compute(packing)


def merge_rdf(parts) -> RDFResult:
    """Pooled RDFResult from (RDFResult, partial ideal) of each packing on common bins."""
    rdfs = [r for r, _ in parts]
    counts, ideal = sum(r.counts for r in rdfs), sum(r.ideal for r in rdfs)
    pideal = sum(p for _, p in parts)
    pcounts = sum(r.partial * p for r, p in parts)
    with np.errstate(divide="ignore", invalid="ignore"):
        partial = np.where(pideal > 0, pcounts / pideal, 0.0)
    return RDFResult(rdfs[0].edges, counts / ideal, counts, ideal, rdfs[0].species, partial,
                     np.concatenate([r.scales for r in rdfs]), len(rdfs))


def merge_structure_factor(parts) -> StructureFactorResult:
    """Pooled S(k) from per-packing results with the same dk (shells keyed by round(k / dk))."""
    dk = parts[0].dk
    shells = [np.floor(p.k / dk + 0.5).astype(int) for p in parts]
    size = max(int(s.max()) for s in shells) + 1
    ssum, ksum, count = np.zeros(size), np.zeros(size), np.zeros(size)
    for part, shell in zip(parts, shells):
        ssum += np.bincount(shell, part.s * part.n_vectors, size)
        ksum += np.bincount(shell, part.k * part.n_vectors, size)
        count += np.bincount(shell, part.n_vectors, size)
    full = count > 0
    return StructureFactorResult(ksum[full] / count[full], ssum[full] / count[full], count[full].astype(int), dk,
                                 len(parts))
