//! Finite or refused (docs/robustness.md, issue 14): every number that reaches a report is
//! finite, or the run stops with one line naming the quantity, the place and the cause.
//!
//! Two checks. Before any work, the data are bounded: every nodal value of the fields, the
//! material constants, the friction coefficient, ℓ, the obstacle, and every scene expression
//! at the points where it is used (the nodes for the body force; the nodes and edge midpoints
//! of the edges a boundary selects for its data) must be finite and at most
//! [`tolerance::MAX_MAGNITUDE`] in size (E at least its inverse). Squares and products of two
//! such numbers stay finite, which is what the terms of F compute. After the estimate, every
//! total and every per-cell value is checked again, so that nothing non-finite can reach a
//! report whatever the check before missed.

use crate::error::Error;
use crate::estimate::{Estimate, Violation};
use crate::expr::Expr;
use crate::mesh::{Dataset, NONE};
use crate::problem::{BoundaryEdge, Condition, Fields, Stress};
use crate::read::scene::{BoundaryKind, Gap, Scene};
use crate::tolerance::MAX_MAGNITUDE;

fn too_large(v: f64) -> bool {
    v.is_nan() || v.abs() > MAX_MAGNITUDE
}

/// The bounded-data check before any work.
pub fn check_inputs(
    data: &Dataset,
    fields: &Fields,
    scene: &Scene,
    edges: &[BoundaryEdge],
) -> Result<(), Error> {
    let file = &data.path;
    // Fields, nodal values.
    if let Some(u) = &fields.displacement {
        let name = fields
            .displacement_name
            .as_deref()
            .unwrap_or("displacement");
        if let Some((k, v)) = u
            .iter()
            .enumerate()
            .find(|(_, v)| v.iter().any(|&x| too_large(x)))
        {
            return Err(Error::input(
                file,
                format!("point array \"{name}\" (displacement)"),
                format!(
                    "value ({:e}, {:e}) at point {k} is not finite or beyond ±{MAX_MAGNITUDE:e}: \
                     its squares would overflow",
                    v[0], v[1]
                ),
            ));
        }
    }
    if let Stress::Nodal { values, name, .. } | Stress::Cell { values, name, .. } = &fields.stress
        && let Some((k, _)) = values
            .iter()
            .enumerate()
            .find(|(_, v)| v.iter().any(|&x| too_large(x)))
    {
        return Err(Error::input(
            file,
            format!("array \"{name}\" (stress)"),
            format!(
                "a value at tuple {k} is not finite or beyond ±{MAX_MAGNITUDE:e}: its squares \
                 would overflow"
            ),
        ));
    }
    // Material and scalars of the scene.
    let sf = &scene.file;
    let m = &scene.material;
    if too_large(m.youngs_modulus) || m.youngs_modulus < 1.0 / MAX_MAGNITUDE {
        return Err(Error::input(
            sf,
            "material.youngs_modulus",
            format!(
                "{:e} is outside [{:e}, {MAX_MAGNITUDE:e}]: the compliance 1/(2μ) or the \
                 energy would overflow",
                m.youngs_modulus,
                1.0 / MAX_MAGNITUDE
            ),
        ));
    }
    if let Some(l) = scene.estimate.length_scale
        && too_large(l * l)
    {
        return Err(Error::input(
            sf,
            "estimate.length_scale",
            format!("{l:e}: ℓ² in the equilibrium weight ℓ²/(2μ) would overflow"),
        ));
    }
    for b in &scene.boundaries {
        if let BoundaryKind::Contact(c) = &b.kind {
            if too_large(c.friction) {
                return Err(Error::input(
                    sf,
                    b.place("friction"),
                    format!("{:e} is beyond {MAX_MAGNITUDE:e}", c.friction),
                ));
            }
            if let Gap::Plane { point, .. } = &c.gap
                && point.iter().any(|&x| too_large(x))
            {
                return Err(Error::input(
                    sf,
                    b.place("obstacle.plane.point"),
                    format!(
                        "({:e}, {:e}) is beyond ±{MAX_MAGNITUDE:e}: the gap would overflow",
                        point[0], point[1]
                    ),
                ));
            }
        }
    }
    // Expressions where they are evaluated.
    let mesh = &data.mesh;
    if let Some(f) = &scene.body_force {
        for (c, e) in f.iter().enumerate() {
            for p in &mesh.points {
                check_expr(sf, &format!("loads.body_force[{c}]"), e, *p)?;
            }
        }
    }
    for be in edges {
        let b = match be.condition {
            Condition::Dirichlet(b) | Condition::Neumann(b) | Condition::Contact(b) => b,
            Condition::Free => continue,
        };
        let boundary = &scene.boundaries[b];
        let (key, exprs): (&str, Vec<&Expr>) = match &boundary.kind {
            BoundaryKind::Dirichlet { displacement } => {
                ("displacement", displacement.iter().collect())
            }
            BoundaryKind::Neumann { traction } => ("traction", traction.iter().collect()),
            BoundaryKind::Contact(c) => match &c.gap {
                Gap::Expr(g) => ("gap", vec![g]),
                Gap::Plane { .. } => continue,
            },
        };
        let [a, bb, mid] = mesh.edge(be.cell as usize, be.local as usize);
        let pa = mesh.points[a as usize];
        let pb = mesh.points[bb as usize];
        let mut points = vec![pa, pb, [0.5 * (pa[0] + pb[0]), 0.5 * (pa[1] + pb[1])]];
        if mid != NONE {
            points.push(mesh.points[mid as usize]);
        }
        for (c, e) in exprs.iter().enumerate() {
            let place = if exprs.len() > 1 {
                boundary.place(&format!("{key}[{c}]"))
            } else {
                boundary.place(key)
            };
            for &p in &points {
                check_expr(sf, &place, e, p)?;
            }
        }
    }
    Ok(())
}

fn check_expr(file: &std::path::Path, place: &str, e: &Expr, p: [f64; 2]) -> Result<(), Error> {
    match e.eval_finite(p[0], p[1], 0.0) {
        Err(problem) => Err(Error::input(file, place, problem)),
        Ok(v) if too_large(v) => Err(Error::input(
            file,
            place,
            format!(
                "expression {} is {v:e} at (x, y) = ({:?}, {:?}), beyond ±{MAX_MAGNITUDE:e}: its \
                 square would overflow",
                crate::error::quote(e.source()),
                p[0],
                p[1]
            ),
        )),
        Ok(_) => Ok(()),
    }
}

/// The check of everything the estimate computed.
pub fn check_estimate(file: &std::path::Path, est: &Estimate) -> Result<(), Error> {
    let bad = |what: &str, v: f64| -> Result<(), Error> {
        if v.is_finite() {
            Ok(())
        } else {
            Err(Error::input(
                file,
                what,
                format!(
                    "is {} after the evaluation: an overflow of the data's products; nothing is \
                     reported",
                    if v.is_nan() {
                        "not a number"
                    } else {
                        "infinite"
                    }
                ),
            ))
        }
    };
    let f = &est.functional;
    for (what, v) in [
        ("functional.total", f.total),
        ("functional.constitutive", f.constitutive),
        ("functional.equilibrium", f.equilibrium),
        ("functional.complementarity", f.complementarity),
        ("functional.friction", f.friction),
        ("energy", est.energy),
        ("length_scale", est.length_scale),
        ("contact.normal_force", est.contact.normal_force),
        (
            "contact.normal_force_stress",
            est.contact.normal_force_stress,
        ),
        ("contact.tangential_force", est.contact.tangential_force),
        ("contact.active_length", est.contact.active_length),
    ] {
        bad(what, v)?;
    }
    if let Some(e) = est.eta {
        bad("eta", e)?;
    }
    if let Some(r) = est.relative {
        bad("relative", r)?;
    }
    let a = &est.admissibility;
    let vs: [(&str, &Violation); 5] = [
        ("admissibility.penetration", &a.penetration),
        ("admissibility.tension", &a.tension),
        ("admissibility.cone_violation", &a.cone_violation),
        ("admissibility.dirichlet", &a.dirichlet),
        ("admissibility.neumann", &a.neumann),
    ];
    for (what, v) in vs {
        bad(what, v.max)?;
        bad(what, v.l2)?;
    }
    let c = &est.cells;
    for (what, cells) in [
        ("cells.constitutive", &c.constitutive),
        ("cells.equilibrium", &c.equilibrium),
        ("cells.complementarity", &c.complementarity),
        ("cells.friction", &c.friction),
    ] {
        if let Some((t, &v)) = cells.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            bad(&format!("{what} of cell {t}"), v)?;
        }
    }
    if let Some(v) = est.bound.energy_error {
        bad("bound.energy_error", v)?;
    }
    if let Some((t, &v)) = est
        .bound
        .cells
        .iter()
        .enumerate()
        .find(|(_, v)| !v.is_finite())
    {
        bad(&format!("bound.cells of cell {t}"), v)?;
    }
    Ok(())
}
