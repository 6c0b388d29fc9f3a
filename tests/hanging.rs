//! Meshes with hanging nodes (non-conforming adaptive refinement): the straight triangles with
//! a hanging edge are split at their hanging vertices (src/closure.rs, docs/design.md §4.2), and
//! the audit runs on the closed mesh.
//!
//! * MFEM's output of a non-conforming mesh (`fixtures/mfem_nonconforming/`: the four triangle
//!   forms, P1/P2 as Lagrange cells or refined linear cells, and the three quadrilateral forms of
//!   Q1 cells, which are first cut into P2 triangle halves) carrying the linear field
//!   u = (1e-3 x + 2e-4 y, 1e-4 x − 3e-4 y): with Dirichlet data u on x = 0 and the tractions
//!   σn of u on the other sides (by hand), u_h is the exact solution, so the bound is round-off
//!   and the energy is the hand value ½ ∫ σ:ε.
//! * The manufactured P2 n08 fixture with one interior cell refined into four P2 triangles that
//!   carry the same polynomial: the same u_h on a non-conforming mesh, so the fixture's true
//!   error (expected.json, from the exact solution) is the true error here too.

mod common;

use std::path::Path;

use common::cli::{estimate, root};
use fosls::read::vtu::{VtuFile, read_vtu};
use fosls::write::{Placement, write_vtu};

/// The Lamé stress of the linear field's strain (plane strain, E = 1, ν = 0.3), by hand.
fn mfem_stress() -> [f64; 3] {
    let (e, nu) = (1.0, 0.3);
    let lam = e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
    let mu = e / (2.0 * (1.0 + nu));
    let (exx, eyy, exy) = (1e-3, -3e-4, 0.5 * (2e-4 + 1e-4));
    let tr = exx + eyy;
    [
        lam * tr + 2.0 * mu * exx,
        lam * tr + 2.0 * mu * eyy,
        2.0 * mu * exy,
    ]
}

#[test]
fn mfem_triangles_with_hanging_nodes_are_audited_exactly() {
    let [sxx, syy, sxy] = mfem_stress();
    let scene = format!(
        "[material]\nyoungs_modulus = 1.0\npoisson_ratio = 0.3\nmodel = \"plane_strain\"\n\n\
         [[boundary]]\nname = \"left\"\nwhere = \"1e-9 - x\"\nkind = \"dirichlet\"\n\
         displacement = [\"2e-4*y\", \"-3e-4*y\"]\n\n\
         [[boundary]]\nname = \"right\"\nwhere = \"x - 2 + 1e-9\"\nkind = \"neumann\"\n\
         traction = [\"{sxx:e}\", \"{sxy:e}\"]\n\n\
         [[boundary]]\nname = \"bottom\"\nwhere = \"1e-9 - y\"\nkind = \"neumann\"\n\
         traction = [\"{:e}\", \"{:e}\"]\n\n\
         [[boundary]]\nname = \"top\"\nwhere = \"y - 1 + 1e-9\"\nkind = \"neumann\"\n\
         traction = [\"{sxy:e}\", \"{syy:e}\"]\n",
        -sxy, -syy
    );
    let dir = tempfile::tempdir().unwrap();
    let scene_path = dir.path().join("scene.toml");
    std::fs::write(&scene_path, scene).unwrap();
    // ½ ∫ σ:ε over the area 2.
    let energy = sxx * 1e-3 + syy * -3e-4 + 2.0 * sxy * 1.5e-4;
    let fixtures = root().join("fixtures/mfem_nonconforming");
    // The triangle forms, and the quadrilateral forms of Q1 cells (MFEM's P2 field written as
    // refined linear cells is one), which are cut into P2 triangle halves first.
    for case in [
        "p1_high_tri",
        "p2_high_tri",
        "p1_low_tri",
        "p2_low_tri",
        "p1_high_quad",
        "p1_low_quad",
        "p2_low_quad",
    ] {
        let file = fixtures.join(case).join(format!("{case}.pvd"));
        let (code, r, err) = estimate(&file, &["--scene", scene_path.to_str().unwrap()]);
        assert_eq!(code, 0, "{case}: {err}");
        let r = r.unwrap();
        assert!(
            (r.energy - energy).abs() < 1e-12 * energy,
            "{case}: {} vs {energy}",
            r.energy
        );
        assert!(
            r.bound.guaranteed,
            "{case}: {:?}",
            r.bound.failed_hypotheses
        );
        let rel = r.bound.relative.unwrap();
        assert!(rel < 1e-10, "{case}: bound.relative {rel}");
        let note = r
            .notes
            .iter()
            .find(|n| n.starts_with("hanging nodes"))
            .unwrap();
        assert!(note.contains("split into"), "{case}: {note}");
        assert_eq!(
            note.starts_with("hanging nodes on quadrilaterals: "),
            case.ends_with("_quad"),
            "{case}: {note}"
        );
        assert!(!note.contains("differs"), "{case}: {note}");
    }
    // The VTU output of the split mesh maps each cell to its file cell: MFEM's 7 Lagrange
    // triangles, the two unrefined ones with a hanging vertex each bisected (9 cells).
    let out = dir.path().join("out.vtu");
    let file = fixtures.join("p2_high_tri/p2_high_tri.pvd");
    let (code, _, err) = estimate(
        &file,
        &[
            "--scene",
            scene_path.to_str().unwrap(),
            "--output",
            out.to_str().unwrap(),
        ],
    );
    assert_eq!(code, 0, "{err}");
    let written = read_vtu(&out).unwrap();
    let map = written
        .cell_data
        .iter()
        .find(|a| a.name == "file_cell")
        .unwrap();
    let mut count = [0usize; 7];
    for &c in &map.values {
        count[c as usize] += 1;
    }
    let mut sorted = count;
    sorted.sort_unstable();
    assert_eq!(sorted, [1, 1, 1, 1, 1, 2, 2], "{count:?}");
}

/// P2 shape functions at barycentric coordinates (VTK order: vertices, mids 01, 12, 20).
fn p2(l: [f64; 3]) -> [f64; 6] {
    [
        l[0] * (2.0 * l[0] - 1.0),
        l[1] * (2.0 * l[1] - 1.0),
        l[2] * (2.0 * l[2] - 1.0),
        4.0 * l[0] * l[1],
        4.0 * l[1] * l[2],
        4.0 * l[2] * l[0],
    ]
}

/// `f` with its cell `t` replaced by `children` (of VTK type `vtk_type`): the first takes its
/// place, the others are appended, each with `t`'s cell data.
fn replace_cell(f: &mut VtuFile, t: usize, children: &[Vec<u32>], vtk_type: u8) {
    let mut connectivity = Vec::new();
    let mut offsets = vec![0];
    for c in 0..f.cell_count() {
        let nodes = if c == t {
            children[0].clone()
        } else {
            f.cell(c).to_vec()
        };
        connectivity.extend(nodes);
        offsets.push(connectivity.len());
    }
    for nodes in &children[1..] {
        connectivity.extend(nodes);
        offsets.push(connectivity.len());
        f.types.push(vtk_type);
    }
    f.connectivity = connectivity;
    f.offsets = offsets;
    for a in &mut f.cell_data {
        let nc = a.components;
        let row = a.values[t * nc..(t + 1) * nc].to_vec();
        for _ in 1..children.len() {
            a.values.extend_from_slice(&row);
        }
    }
}

/// `src` with its 2D cell `t` (a P2 triangle) refined into four P2 triangles whose nodes carry
/// the parent's polynomial: every point array evaluated there, cell arrays copied.
fn refine_one(src: &Path, out: &Path, pick: impl Fn(&[[f64; 3]]) -> bool) -> usize {
    let mut f = read_vtu(src).unwrap();
    let t = (0..f.cell_count())
        .find(|&c| {
            f.types[c] == 22
                && pick(
                    &f.cell(c)
                        .iter()
                        .map(|&n| f.points[n as usize])
                        .collect::<Vec<_>>(),
                )
        })
        .expect("a cell to refine");
    let parent: Vec<u32> = f.cell(t).to_vec();
    // Barycentric coordinates of the parent's nodes and of the children's nodes.
    let node_l: [[f64; 3]; 6] = [
        [1., 0., 0.],
        [0., 1., 0.],
        [0., 0., 1.],
        [0.5, 0.5, 0.],
        [0., 0.5, 0.5],
        [0.5, 0., 0.5],
    ];
    let children: [[usize; 3]; 4] = [[0, 3, 5], [3, 1, 4], [5, 4, 2], [3, 4, 5]];
    let mut new_points: Vec<([f64; 3], u32)> = Vec::new();
    let mut cells: Vec<Vec<u32>> = Vec::new();
    for ch in children {
        let mut nodes: Vec<u32> = ch.iter().map(|&i| parent[i]).collect();
        for k in 0..3 {
            let (a, b) = (node_l[ch[k]], node_l[ch[(k + 1) % 3]]);
            let l = [
                0.5 * (a[0] + b[0]),
                0.5 * (a[1] + b[1]),
                0.5 * (a[2] + b[2]),
            ];
            let id = match new_points.iter().find(|(q, _)| *q == l) {
                Some(&(_, id)) => id,
                None => {
                    let phi = p2(l);
                    let x: [f64; 3] = std::array::from_fn(|c| {
                        (0..6)
                            .map(|i| phi[i] * f.points[parent[i] as usize][c])
                            .sum()
                    });
                    f.points.push(x);
                    for a in &mut f.point_data {
                        let nc = a.components;
                        let v: Vec<f64> = (0..nc)
                            .map(|c| {
                                (0..6)
                                    .map(|i| phi[i] * a.values[parent[i] as usize * nc + c])
                                    .sum()
                            })
                            .collect();
                        a.values.extend(v);
                    }
                    let id = (f.points.len() - 1) as u32;
                    new_points.push((l, id));
                    id
                }
            };
            nodes.push(id);
        }
        cells.push(nodes);
    }
    replace_cell(&mut f, t, &cells, 22);
    write_vtu(out, &f, Placement::AppendedRaw).unwrap();
    t
}

#[test]
fn one_refined_cell_of_the_manufactured_p2_mesh_keeps_the_bound_above_the_true_error() {
    let case = root().join("fixtures/manufactured_frictionless_p2_n08");
    let expected: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(case.join("expected.json")).unwrap())
            .unwrap();
    let truth = expected["errors"]["fe"]["energy"].as_f64().unwrap();
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("solution.vtu");
    std::fs::copy(case.join("scene.toml"), dir.path().join("scene.toml")).unwrap();
    // An interior cell: every node strictly inside the unit square's bounding box.
    let inside = |x: &[[f64; 3]]| {
        x.iter()
            .all(|p| p[0] > 0.2 && p[0] < 0.8 && p[1] > 0.2 && p[1] < 0.8)
    };
    refine_one(&case.join("solution.vtu"), &file, inside);
    let (code, r, err) = estimate(&file, &[]);
    assert!(code == 0 || code == 1, "{err}");
    let r = r.unwrap();
    let note = r
        .notes
        .iter()
        .find(|n| n.starts_with("hanging nodes: "))
        .expect("a closure note");
    // The refined cell's three neighbours each get one hanging vertex (its mid nodes).
    assert!(
        note.starts_with("hanging nodes: 3 cells with 3 hanging vertices"),
        "{note}"
    );
    assert!(!note.contains("differs"), "{note}");
    let (c0, r0, e0) = estimate(&case.join("solution.vtu"), &[]);
    assert!(c0 == 0 || c0 == 1, "{e0}");
    let r0 = r0.unwrap();
    let b0 = r0.bound.energy_error.unwrap();
    // Guaranteed exactly when the conforming file's is (both hang on the uncertified Korn
    // constants of the oscillation term of this non-polynomial body force).
    assert_eq!(
        r.bound.guaranteed, r0.bound.guaranteed,
        "{:?}",
        r.bound.failed_hypotheses
    );
    let b = r.bound.energy_error.unwrap();
    assert!(b >= truth, "bound {b} below the true error {truth}");
    assert!(
        b <= 1.1 * b0,
        "bound {b} against {b0} on the conforming mesh (true {truth})"
    );
    eprintln!(
        "bound {b:.6e} (conforming {b0:.6e}), true {truth:.6e}: index {:.3}",
        b / truth
    );
}

#[test]
fn a_split_file_cell_is_ranked_marked_and_summed_as_one() {
    let case = root().join("fixtures/manufactured_frictionless_p2_n08");
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("solution.vtu");
    std::fs::copy(case.join("scene.toml"), dir.path().join("scene.toml")).unwrap();
    // The refined cell's 3 neighbours are bisected: 3 file cells of 2 triangles each.
    refine_one(&case.join("solution.vtu"), &file, |x| {
        x.iter()
            .all(|p| p[0] > 0.2 && p[0] < 0.8 && p[1] > 0.2 && p[1] < 0.8)
    });
    let input = read_vtu(&file).unwrap();
    let file_triangles = input.types.iter().filter(|&&t| t == 22).count();
    let out = dir.path().join("out.vtu");
    let (code, r, err) = estimate(&file, &["--mark", "0.5", "--output", out.to_str().unwrap()]);
    assert!(code == 0 || code == 1, "{err}");
    let r = r.unwrap();
    // Counted, ranked and summed per file cell, not per triangle of the split.
    assert_eq!(r.cells.count, file_triangles);
    assert_eq!(r.bound.cells.len(), file_triangles);
    let written = read_vtu(&out).unwrap();
    let array = |name: &str| {
        &written
            .cell_data
            .iter()
            .find(|a| a.name == name)
            .unwrap_or_else(|| panic!("{name}"))
            .values
    };
    let (map, eta2, bound, marked) = (
        array("file_cell"),
        array("eta_squared"),
        array("bound_squared"),
        array("marked"),
    );
    let split = written.types.iter().filter(|&&t| t == 22).count();
    assert_eq!(split, file_triangles + 3);
    // Per file cell: the sums over its triangles of the output's per-triangle arrays, and
    // its children's marks.
    // (File indices count the line cells too: the sums are by VTU index, the triangles'
    // kept in file order.)
    let n = input.cell_count();
    let mut e2 = vec![0.0; n];
    let mut b2 = vec![0.0; n];
    let mut flags: Vec<Vec<f64>> = vec![Vec::new(); n];
    for t in 0..split {
        let c = map[t] as usize;
        e2[c] += eta2[t];
        b2[c] += bound[t];
        flags[c].push(marked[t]);
    }
    let triangles: Vec<usize> = (0..n).filter(|&c| !flags[c].is_empty()).collect();
    assert_eq!(triangles.len(), file_triangles);
    for (c, w) in r.bound.cells.iter().zip(triangles.iter().map(|&c| b2[c])) {
        assert!((c - w).abs() <= 1e-12 * w.abs().max(1e-300), "{c} vs {w}");
    }
    let mut seen = std::collections::HashSet::new();
    for w in &r.cells.worst {
        assert!(seen.insert(w.cell), "file cell {} ranked twice", w.cell);
        let sum = e2[w.cell];
        assert!(
            (w.eta_squared - sum).abs() <= 1e-12 * sum.abs(),
            "cell {}: {} vs {sum}",
            w.cell,
            w.eta_squared
        );
    }
    // The worst list is the largest sums, largest first.
    let mut sorted = e2.clone();
    sorted.sort_by(|a, b| b.total_cmp(a));
    assert_eq!(r.cells.worst[0].eta_squared, sorted[0]);
    assert!(flags.iter().all(|f| f.iter().all(|&m| m == f[0])));
    let count = triangles.iter().filter(|&&c| flags[c][0] == 1.0).count();
    assert_eq!(r.marked.unwrap().count, count);
    // Dörfler on the file cells: the marked ones hold at least half of Σ max(η², 0), and
    // dropping the smallest of them falls below (the minimal set).
    let positive: f64 = e2.iter().map(|&x| x.max(0.0)).sum();
    let mut held: Vec<f64> = triangles
        .iter()
        .filter(|&&c| flags[c][0] == 1.0)
        .map(|&c| e2[c].max(0.0))
        .collect();
    held.sort_by(f64::total_cmp);
    let sum: f64 = held.iter().sum();
    assert!(sum >= 0.5 * positive * (1.0 - 1e-12));
    assert!(sum - held[0] < 0.5 * positive);
}

/// `src` with its quadrilateral cell picked by `pick` refined into four quadrilaterals that
/// carry the parent's Q1 field: the new points (edge midpoints and centre) take the means of
/// the parent's corner values along the edge or over the cell, which is the bilinear field
/// there; cell arrays copied.
fn refine_one_quad(src: &Path, out: &Path, pick: impl Fn(&[[f64; 3]]) -> bool) {
    let mut f = read_vtu(src).unwrap();
    let t = (0..f.cell_count())
        .find(|&c| {
            f.types[c] == 9
                && pick(
                    &f.cell(c)
                        .iter()
                        .map(|&n| f.points[n as usize])
                        .collect::<Vec<_>>(),
                )
        })
        .expect("a cell to refine");
    let v: Vec<u32> = f.cell(t).to_vec();
    let mut mean = |of: &[u32]| -> u32 {
        let w = 1.0 / of.len() as f64;
        let x: [f64; 3] =
            std::array::from_fn(|c| of.iter().map(|&n| w * f.points[n as usize][c]).sum());
        f.points.push(x);
        for a in &mut f.point_data {
            let nc = a.components;
            let vals: Vec<f64> = (0..nc)
                .map(|c| of.iter().map(|&n| w * a.values[n as usize * nc + c]).sum())
                .collect();
            a.values.extend(vals);
        }
        (f.points.len() - 1) as u32
    };
    let m: Vec<u32> = (0..4).map(|k| mean(&[v[k], v[(k + 1) % 4]])).collect();
    let c = mean(&v);
    let children = [
        [v[0], m[0], c, m[3]],
        [m[0], v[1], m[1], c],
        [c, m[1], v[2], m[2]],
        [m[3], c, m[2], v[3]],
    ];
    let children: Vec<Vec<u32>> = children.iter().map(|c| c.to_vec()).collect();
    replace_cell(&mut f, t, &children, 9);
    write_vtu(out, &f, Placement::AppendedRaw).unwrap();
}

#[test]
fn one_refined_cell_of_the_manufactured_q1_mesh_keeps_the_bound_above_the_true_error() {
    // The manufactured Q1 n08 fixture (unit-square cells) with one interior cell refined into
    // four: the same u_h on a non-conforming mesh, cut into P2 triangle halves (exact on these
    // parallelograms) and closed, so the fixture's true error (expected.json, from the exact
    // solution) is the true error here too.
    let case = root().join("fixtures/quad_manufactured_q1_n08");
    let expected: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(case.join("expected.json")).unwrap())
            .unwrap();
    let truth = expected["errors"]["fe"]["energy"].as_f64().unwrap();
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("solution.vtu");
    std::fs::copy(case.join("scene.toml"), dir.path().join("scene.toml")).unwrap();
    refine_one_quad(&case.join("solution.vtu"), &file, |x| {
        x.iter()
            .all(|p| p[0] > 0.2 && p[0] < 0.8 && p[1] > 0.2 && p[1] < 0.8)
    });
    let (code, r, err) = estimate(&file, &[]);
    assert!(code == 0 || code == 1, "{err}");
    let r = r.unwrap();
    let note = r
        .notes
        .iter()
        .find(|n| n.starts_with("hanging nodes on quadrilaterals: "))
        .expect("a closure note");
    // 64 + 3 quadrilaterals; the refined cell's 4 neighbours get one hanging vertex each.
    assert!(note.contains("the 67 Q1 parallelograms"), "{note}");
    assert!(
        note.contains("hanging nodes: 4 cells with 4 hanging vertices"),
        "{note}"
    );
    assert!(!note.contains("differs"), "{note}");
    assert_eq!(r.cells.count, 67);
    let b = r.bound.energy_error.unwrap();
    assert!(b >= truth, "bound {b} below the true error {truth}");
    assert!(b <= 2.0 * truth, "bound {b}, true {truth}: index above 2");
    eprintln!("bound {b:.6e}, true {truth:.6e}: index {:.3}", b / truth);
}
