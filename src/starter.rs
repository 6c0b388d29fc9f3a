//! `fosls scene FILE`: a starter scene (docs/design.md §7) from what the file holds, so that
//! one command takes a user from a solution file to a first estimate.
//!
//! What is guessed, and from what:
//! - fields: the displacement and stress arrays and the stress layout, chosen as `estimate`
//!   would choose them ([`crate::problem::select_fields`]);
//! - boundary parts: one `[[boundary]]` per value of an integer tag array on the line cells,
//!   else one per side of the bounding box that holds boundary edges (a `where` selector);
//! - their kinds: a part on which u_h is constant is Dirichlet with that value; the bottom part
//!   whose deformed nodes are flattened onto one line y = c (at least three nodes within
//!   1e-6·diam of it) is contact with the rigid plane y = c, measured along the obstacle
//!   normal; every other part is left traction-free with a comment saying how to change it;
//! - the material: placeholders (E = 1, ν = 0.3) marked `EDIT`; the estimate's relative error
//!   does not depend on E, its absolute numbers do.
//!
//! The text names every key of docs/design.md §7 in comments.

use std::fmt::Write as _;

use crate::error::Result;
use crate::mesh::{Dataset, NONE};
use crate::problem::{Stress, select_fields};
use crate::read::scene::parse_scene;
use crate::topology::Topology;

/// One boundary part of the starter.
struct Part {
    name: String,
    selector: String,
    /// Mesh nodes on the part.
    nodes: Vec<u32>,
    edges: usize,
}

/// The starter scene text for `data` (read from `file_name`).
pub fn starter_scene(data: &Dataset, topo: &Topology, file_name: &str) -> Result<String> {
    let mesh = &data.mesh;
    let empty = parse_scene(
        std::path::Path::new("starter.toml"),
        "[material]\nyoungs_modulus = 1.0\npoisson_ratio = 0.3\n",
    )?;
    let fields = select_fields(data, &empty)?;
    let bb = mesh.bounding_box();
    let diam = (bb[2] - bb[0]).hypot(bb[3] - bb[1]).max(f64::MIN_POSITIVE);
    let tol = 1e-6 * diam;

    let mut parts: Vec<Part> = Vec::new();
    let tag = data
        .line_data
        .iter()
        .find(|a| a.components == 1 && a.values.iter().all(|v| v.is_finite() && v.fract() == 0.0));
    if let (Some(tag), false) = (tag, mesh.lines.is_empty()) {
        let mut values: Vec<i64> = tag.values.iter().map(|&v| v as i64).collect();
        values.sort_unstable();
        values.dedup();
        for v in values {
            let mut nodes = Vec::new();
            let mut edges = 0;
            for (l, line) in mesh.lines.iter().enumerate() {
                if tag.values[l] as i64 == v && topo.is_boundary(topo.line_edge[l] as usize) {
                    nodes.extend(line.iter().copied().filter(|&n| n != NONE));
                    edges += 1;
                }
            }
            if edges > 0 {
                parts.push(Part {
                    name: format!("tag{v}"),
                    selector: format!("tag = {v}"),
                    nodes,
                    edges,
                });
            }
        }
    } else {
        // Sides of the bounding box: boundary edges with both ends on the side's line.
        let sides = [
            ("bottom", 1, bb[1], "y <"),
            ("top", 1, bb[3], "y >"),
            ("left", 0, bb[0], "x <"),
            ("right", 0, bb[2], "x >"),
        ];
        for (name, axis, value, op) in sides {
            let mut nodes = Vec::new();
            let mut edges = 0;
            for &e in &topo.boundary_edges {
                let [a, b] = topo.edges[e as usize];
                let on = |n: u32| (mesh.points[n as usize][axis] - value).abs() <= tol;
                if on(a) && on(b) {
                    nodes.extend([a, b]);
                    let m = topo.edge_mid[e as usize];
                    if m != NONE {
                        nodes.push(m);
                    }
                    edges += 1;
                }
            }
            if edges > 0 {
                let bound = if op.ends_with('<') {
                    value + 1e-4 * diam
                } else {
                    value - 1e-4 * diam
                };
                parts.push(Part {
                    name: name.into(),
                    selector: format!("where = \"{} {}\"", op, short(bound)),
                    nodes,
                    edges,
                });
            }
        }
    }

    let mut o = String::new();
    let _ = writeln!(
        o,
        "# Starter scene for {file_name}, written by `fosls scene` (docs/design.md §7).\n\
         # Check every line marked EDIT, then run `fosls estimate {file_name}`.\n"
    );
    let bodies = crate::bodies::find(mesh).list;
    if bodies.len() > 1 {
        let _ = writeln!(
            o,
            "# This file holds {} bodies (connected components of the cells); one is audited \
             (docs/design.md §4.2):",
            bodies.len()
        );
        for b in &bodies {
            let [x0, y0, x1, y1] = b.bounding_box;
            let _ = writeln!(
                o,
                "#   body {}: {} cells, {} points, x in [{}, {}], y in [{}, {}]",
                b.index,
                b.cells,
                b.points,
                short(x0),
                short(x1),
                short(y0),
                short(y1)
            );
        }
        let _ = writeln!(
            o,
            "# EDIT: uncomment to choose the body (else the one the dirichlet and contact \
             boundaries touch),\n\
             # by index, by where = \"expression in x, y\" (true at the centroids of its cells) \
             or by\n\
             # cell_data = {{ name = \"array\", value = V }}.\n\
             # [body]\n\
             # index = 0\n"
        );
    }
    let _ = writeln!(
        o,
        "[material]\n\
         youngs_modulus = 1.0                 # EDIT: E of the solution (units of the stress)\n\
         poisson_ratio  = 0.3                 # EDIT: ν; 0.5 is allowed (then norm = \"robust\")\n\
         model = \"plane_strain\"               # or \"plane_stress\"\n"
    );
    let _ = writeln!(o, "[fields]");
    match &fields.displacement_name {
        Some(n) => {
            let _ = writeln!(o, "displacement = {}", field_value(n, &data.point_data));
        }
        None => {
            let _ = writeln!(
                o,
                "# displacement: none found (a pure stress solution: it is reconstructed)"
            );
        }
    }
    match &fields.stress {
        Stress::Nodal { name, layout, .. } | Stress::Cell { name, layout, .. } => {
            let arrays = [&data.point_data[..], &data.cell_data[..]].concat();
            let _ = writeln!(o, "stress = {}", field_value(name, &arrays));
            let _ = writeln!(o, "stress_layout = \"{layout}\"");
        }
        Stress::Absent => {
            let _ = writeln!(o, "# stress: none found (it is reconstructed)");
        }
    }
    o.push('\n');
    let _ = writeln!(
        o,
        "# [loads]\n# body_force = [\"0\", \"0\"]         # expressions in x, y\n\n\
         # [estimate]\n# norm = \"energy\"                   # energy | robust | seed\n\
         # length_scale = 1.0                 # ℓ of the equilibrium weight (default diam/π)\n"
    );
    if let (Some(tag), false) = (tag, mesh.lines.is_empty()) {
        let _ = writeln!(o, "[boundaries]\ntag_array = {:?}\n", tag.name);
    }

    let u = fields.displacement.as_deref();
    let contact = u.and_then(|u| flattened_bottom(data, topo, u, tol));
    let mut any_support = false;
    for p in &parts {
        let _ = writeln!(
            o,
            "[[boundary]]\nname = {:?}\n{}                 # {} edges",
            p.name, p.selector, p.edges
        );
        let constant = u.and_then(|u| constant_on(u, &p.nodes, tol));
        let is_contact = contact
            .as_ref()
            .is_some_and(|c| p.nodes.iter().any(|n| c.1.contains(n)));
        if let Some(d) = constant {
            any_support = true;
            let _ = writeln!(
                o,
                "kind = \"dirichlet\"                   # u_h is constant here\n\
                 displacement = [{}, {}]\n",
                short(d[0]),
                short(d[1])
            );
        } else if let (true, Some((c, _))) = (is_contact, &contact) {
            any_support = true;
            let _ = writeln!(
                o,
                "kind = \"contact\"                     # the deformed nodes lie flat on y = {}\n\
                 obstacle = {{ plane = {{ point = [0.0, {}], normal = [0.0, 1.0] }} }}\n\
                 normal = \"obstacle\"                  # u_n and g along the obstacle normal\n\
                 # friction = 0.0                     # Coulomb coefficient\n",
                short(*c),
                short(*c)
            );
        } else {
            let _ = writeln!(
                o,
                "kind = \"neumann\"                     # EDIT: neumann | dirichlet | contact\n\
                 traction = [0.0, 0.0]\n"
            );
        }
    }
    if let (Some((c, nodes)), false) = (&contact, parts.iter().any(|p| p.name == "bottom")) {
        // The flattened nodes lie on no bounding-box side: a curved body pressed on a plane.
        let ymax = nodes
            .iter()
            .map(|&n| mesh.points[n as usize][1])
            .fold(f64::NEG_INFINITY, f64::max);
        let height = bb[3] - bb[1];
        let cut = ymax + 0.5 * (height - (ymax - bb[1])).max(0.0).min(0.5 * height);
        any_support = true;
        let _ = writeln!(
            o,
            "[[boundary]]\nname = \"contact\"\nwhere = \"y < {}\"                    # EDIT: the \
             part that may touch the plane\nkind = \"contact\"                     # the deformed \
             nodes lie flat on y = {}\nobstacle = {{ plane = {{ point = [0.0, {}], normal = \
             [0.0, 1.0] }} }}\nnormal = \"obstacle\"\n# friction = 0.0\n",
            short(cut),
            short(*c),
            short(*c)
        );
    }
    if !any_support {
        let _ = writeln!(
            o,
            "# No Dirichlet or contact part was recognised: give one [[boundary]] a kind\n\
             # \"dirichlet\" (displacement = [...]) or \"contact\" (obstacle = ...)."
        );
    }
    let _ = writeln!(
        o,
        "# Edges selected by no [[boundary]] are traction-free. Selectors: tag = N (with\n\
         # [boundaries] tag_array) or where = \"expression in x, y\" (tested at edge midpoints)."
    );
    Ok(o)
}

/// The value of `u` when it is the same at every node (within `tol`), if the nodes are many.
fn constant_on(u: &[[f64; 2]], nodes: &[u32], tol: f64) -> Option<[f64; 2]> {
    let first = u[*nodes.first()? as usize];
    let scale = crate::field::max_norm(u);
    let t = tol.max(1e-9 * scale);
    (nodes.len() >= 2
        && nodes.iter().all(|&n| {
            let v = u[n as usize];
            (v[0] - first[0]).abs() <= t && (v[1] - first[1]).abs() <= t
        }))
    .then_some(first)
}

/// The line y = c of the lowest deformed boundary node when at least three boundary nodes,
/// not all on one undeformed horizontal line, lie on it after deformation: a body pressed onto
/// a rigid plane. Returns c and those nodes.
fn flattened_bottom(
    data: &Dataset,
    topo: &Topology,
    u: &[[f64; 2]],
    tol: f64,
) -> Option<(f64, Vec<u32>)> {
    let mesh = &data.mesh;
    let mut boundary_nodes: Vec<u32> = Vec::new();
    for &e in &topo.boundary_edges {
        let [a, b] = topo.edges[e as usize];
        boundary_nodes.extend([a, b]);
        let m = topo.edge_mid[e as usize];
        if m != NONE {
            boundary_nodes.push(m);
        }
    }
    if boundary_nodes.is_empty() {
        return None;
    }
    boundary_nodes.sort_unstable();
    boundary_nodes.dedup();
    let deformed = |n: u32| mesh.points[n as usize][1] + u[n as usize][1];
    let c = boundary_nodes
        .iter()
        .map(|&n| deformed(n))
        .fold(f64::INFINITY, f64::min);
    let scale = u.iter().fold(0.0f64, |m, v| m.max(v[1].abs()));
    // Penalty solutions penetrate by ~1e-3 of the displacement: a loose band.
    let band = tol.max(1e-2 * scale);
    let on: Vec<u32> = boundary_nodes
        .iter()
        .copied()
        .filter(|&n| deformed(n) <= c + band)
        .collect();
    let ys: Vec<f64> = on.iter().map(|&n| mesh.points[n as usize][1]).collect();
    let spread = ys.iter().fold(f64::NEG_INFINITY, |m, &y| m.max(y))
        - ys.iter().fold(f64::INFINITY, |m, &y| m.min(y));
    (on.len() >= 3 && spread > band).then_some((c, on))
}

/// A number as TOML writes it, short: seven decimals at most, trailing zeros dropped.
fn short(v: f64) -> String {
    if v == 0.0 {
        return "0.0".into();
    }
    if (1e-3..1e7).contains(&v.abs()) {
        let s = format!("{v:.7}");
        let s = s.trim_end_matches('0');
        return if s.ends_with('.') {
            format!("{s}0")
        } else {
            s.to_string()
        };
    }
    format!("{v:e}")
}

/// The scene value naming array `name`: the list of its component arrays when it was joined
/// from them (`["u_x", "u_y"]`, [`crate::read::components`]), else the name.
fn field_value(name: &str, arrays: &[crate::read::vtu::DataArray]) -> String {
    match arrays.iter().find(|a| a.name == name) {
        Some(a) if crate::read::components::joined_base(a).is_some() => format!(
            "[{}]",
            a.component_names
                .iter()
                .map(|p| format!("{p:?}"))
                .collect::<Vec<_>>()
                .join(", ")
        ),
        _ => format!("{name:?}"),
    }
}
