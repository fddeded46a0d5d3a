"""Results files of ``jamflow analyze`` (schema ``jamflow.structure`` v1): g(r), S(k), order parameters and correlation lengths of one packing or an ensemble."""

from __future__ import annotations

import numpy as np

from jamflow import __version__
from jamflow.io.packing_file import hdf5_output


def write_results(path, res: dict, files) -> None:
    """HDF5 layout: see docs/notes/structure.md."""
    rdf, sk, corr = res["rdf"], res["sk"], res["corr"]
    with hdf5_output(path) as f:
        f.attrs.update(schema="jamflow.structure", schema_version=1, jamflow_version=__version__,
                       n_packings=rdf.n_packings, r_min=res["r_min"], G=res["G"].G,
                       xi_g=res["g_fit"].xi, xi_q6=corr.fit.xi, inputs="\n".join(map(str, files)))
        g = f.create_group("rdf")
        for name in ("edges", "r", "g", "counts", "ideal", "species", "partial", "scales"):
            g[name] = getattr(rdf, name)
        s = f.create_group("sk")
        s.attrs["dk"] = sk.dk
        for name in ("k", "s", "n_vectors"):
            s[name] = getattr(sk, name)
        o = f.create_group("order")
        o["label"] = np.array(res["labels"], dtype="S")
        for name, column in res["table"].items():
            o[name] = column
        c = f.create_group("q6_correlation")
        c.attrs.update(baseline=corr.baseline, l=corr.l, r_min=corr.r_min)
        for name in ("edges", "r", "complex_corr", "magnitude_corr", "complex_stderr", "c", "counts"):
            c[name] = getattr(corr, name)
        for key, fit in (("fit_g_envelope", res["g_fit"]), ("fit_q6", corr.fit)):
            grp = f.create_group(key)
            grp.attrs.update(xi=fit.xi, xi_stderr=fit.xi_stderr, amplitude=fit.amplitude, reason=fit.reason)
            grp["r_points"], grp["y_points"] = fit.r_points, fit.y_points
