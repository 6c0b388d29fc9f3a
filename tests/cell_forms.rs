//! Cells written under other VTK types: VTK_PIXEL (8, vtkImageData's axis-aligned rectangle,
//! corners in x-then-y order) and VTK_POLYGON (7) of three or four vertices. Independent
//! source: the same solution written as VTK_QUAD (9) and VTK_TRIANGLE (5), whose report every
//! number must equal bit for bit.

mod common;

use std::path::Path;

use common::cli::{estimate, root};
use fosls::read::vtu::read_vtu;
use fosls::report::json::Report;
use fosls::write::{Placement, write_vtu};

/// `case`'s solution with every 2D cell of type `from` rewritten as type `to`, its nodes
/// reordered by `order`, beside the fixture's scene in a temporary folder.
fn rewritten(
    case: &str,
    from: u8,
    to: u8,
    order: impl Fn(&[[f64; 3]], &[u32]) -> Vec<u32>,
) -> (tempfile::TempDir, std::path::PathBuf) {
    let src = root().join("fixtures").join(case);
    let mut f = read_vtu(&src.join("solution.vtu")).unwrap();
    let mut connectivity = Vec::new();
    let mut changed = 0;
    for c in 0..f.cell_count() {
        let nodes = f.cell(c).to_vec();
        if f.types[c] == from {
            connectivity.extend(order(&f.points, &nodes));
            f.types[c] = to;
            changed += 1;
        } else {
            connectivity.extend(nodes);
        }
    }
    assert!(changed > 0, "{case}: no cell of type {from}");
    f.connectivity = connectivity;
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("solution.vtu");
    write_vtu(&file, &f, Placement::AppendedRaw).unwrap();
    std::fs::copy(src.join("scene.toml"), dir.path().join("scene.toml")).unwrap();
    (dir, file)
}

fn report(file: &Path) -> Report {
    let (code, r, err) = estimate(file, &[]);
    assert!(code == 0 || code == 1, "{}: {err}", file.display());
    r.unwrap()
}

/// The numbers of two reports of one solution, bit for bit.
fn same(a: &Report, b: &Report) {
    assert_eq!(a.functional.total.to_bits(), b.functional.total.to_bits());
    assert_eq!(a.energy.to_bits(), b.energy.to_bits());
    assert_eq!(a.relative.map(f64::to_bits), b.relative.map(f64::to_bits));
    assert_eq!(
        a.bound.energy_error.map(f64::to_bits),
        b.bound.energy_error.map(f64::to_bits)
    );
    assert_eq!(a.bound.guaranteed, b.bound.guaranteed);
    assert_eq!(a.cells.count, b.cells.count);
}

#[test]
fn pixels_are_the_quadrilaterals_of_the_same_solution() {
    let case = "quad_manufactured_q1_n04";
    let quads = report(&root().join("fixtures").join(case).join("solution.vtu"));
    // Corners sorted by y, then x: (xmin, ymin), (xmax, ymin), (xmin, ymax), (xmax, ymax).
    let (_dir, file) = rewritten(case, 9, 8, |p, n| {
        let mut v = n.to_vec();
        v.sort_by(|&a, &b| {
            let (pa, pb) = (p[a as usize], p[b as usize]);
            pa[1].total_cmp(&pb[1]).then(pa[0].total_cmp(&pb[0]))
        });
        v
    });
    same(&quads, &report(&file));
}

#[test]
fn polygons_of_three_and_four_vertices_are_triangles_and_quadrilaterals() {
    for (case, from) in [("quad_manufactured_q1_n04", 9), ("hertz_skfem_p1", 5)] {
        let plain = report(&root().join("fixtures").join(case).join("solution.vtu"));
        let (_dir, file) = rewritten(case, from, 7, |_, n| n.to_vec());
        same(&plain, &report(&file));
    }
}
