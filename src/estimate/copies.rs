//! The distance of a displacement written per cell from its average over the node copies
//! (docs/design.md §4.2, "Discontinuous displacements").
//!
//! An exploded file (every cell with its own node copies) may hold a field that jumps between
//! cells: a discontinuous Galerkin solution, or a continuous one written per cell by a code
//! that lost its continuity. Building the mesh merges the copies and averages their values
//! (mesh.rs), so F and the bound see the continuous average ū_h. The file's u_h differs from it
//! cell by cell, d_T = ū_h − u_h|_T, and its error in the broken energy norm obeys
//! |||u − u_h|||_h ≤ |||u − ū_h||| + |||ū_h − u_h|||_h, the last term computed here.

use rayon::prelude::*;

use crate::geometry::CellValuesCache;
use crate::geometry::MAX_NODES;
use crate::geometry::values::interior_table;
use crate::mesh::CopyRows;
use crate::problem::Context;
use crate::read::scene::Norm;
use crate::read::vtu::DataArray;

/// |||ū_h − u_h|||_h = (Σ_T ∫_T (Cε(d_T), ε(d_T)))^½, d_T the nodal field of minus the cell's
/// copy deviations ([`CopyRows`]), on the interior terms' rule (exact on straight cells, where
/// ε(d_T) is a polynomial of degree p − 1). Summed in cell order, so the bits do not depend on
/// the thread count.
pub fn copies_distance(ctx: &Context, copies: &DataArray) -> f64 {
    let rows = CopyRows::new(copies);
    let mesh = ctx.mesh;
    let per_cell: Vec<f64> = (0..mesh.len())
        .into_par_iter()
        .with_min_len(1024)
        .map_init(CellValuesCache::default, |cache, t| {
            let sh = mesh.shape[t];
            let cv = cache.get(mesh.family[t], sh, |f, sh| {
                interior_table(f, sh, None, true)
            });
            let nodes = mesh.nodes(t);
            let mut d = [[0.0; 2]; MAX_NODES];
            for (k, &p) in nodes.iter().enumerate() {
                let dev = rows.deviation(t, p);
                d[k] = [-dev[0], -dev[1]];
            }
            if d.iter().all(|v| v[0] == 0.0 && v[1] == 0.0) {
                return 0.0;
            }
            let x = mesh.coords(t);
            cv.reinit(&x[..nodes.len()], sh);
            (0..cv.len())
                .map(|q| {
                    let g = cv.gradient2(q, &d);
                    let sym = 0.5 * (g[0][1] + g[1][0]);
                    let eps = [g[0][0], sym, sym, g[1][1]];
                    2.0 * cv.jxw[q] * ctx.elastic.energy_density(Norm::Energy, eps)
                })
                .sum()
        })
        .collect();
    per_cell.iter().sum::<f64>().max(0.0).sqrt()
}
