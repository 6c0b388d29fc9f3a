//! The JSON printer (`--json FILE`): the minimum contract of docs/design.md §8, key for key, plus
//! the extra keys it welcomes.
//!
//! ```text
//! norm, functional {total, constitutive, equilibrium, complementarity, friction}, eta, energy,
//! relative, stress {source, space, reason}, displacement {source, degree},
//! admissibility {penetration_max, tension_max, cone_violation_max, dirichlet_max, neumann_max},
//! contact {active_length, stick_length, slip_length, normal_force},
//! bound {guaranteed, energy_error, relative, statement, terms, failed_hypotheses, cells}, cells {count, worst: [{cell, eta}]}
//! ```
//!
//! Extra keys: `version`, `solution`, `scene`, `length_scale`, the field names and spaces,
//! the L² size, place and file cell of every violation (`<kind>_l2`, `<kind>_at`,
//! `<kind>_cell`), the negative parts of the boundary terms, the tangential force and the
//! contact intervals, η_T² and the dominant term of the worst cells, the boundaries, `marked`
//! (only when marking was asked for), `stages` and `notes`.
//!
//! `eta` and `relative` are `null` when F < 0 (an inadmissible pair); `bound.energy_error` is `null`
//! when no bound was computed. Cell indices are indices in the VTU file. [`Report`] also
//! derives `Deserialize`, so that tests and scripts can read the output back into typed
//! structs.

use serde::{Deserialize, Serialize};

use super::{BoundaryInfo, FileCells, Run, Stage, WORST, cell_eta, dominant, mark, worst_cells};
use crate::estimate::{Estimate, Violation};
use crate::mesh::Mesh;

/// The JSON document.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Report {
    pub version: String,
    pub solution: String,
    pub scene: String,
    /// "energy", "robust" or "seed".
    pub norm: String,
    pub length_scale: f64,
    pub functional: Functional,
    pub eta: Option<f64>,
    pub energy: f64,
    pub relative: Option<f64>,
    pub stress: Field,
    pub displacement: Displacement,
    /// Of the fields used in F.
    pub admissibility: Admissibility,
    /// Of the file's own fields, when the estimate used others (projection, reconstruction).
    pub admissibility_file: Option<Admissibility>,
    pub contact: Contact,
    pub bound: Bound,
    pub cells: Cells,
    pub boundaries: Vec<BoundaryInfo>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub marked: Option<Marked>,
    pub stages: Vec<Stage>,
    pub notes: Vec<String>,
    /// The bodies (connected components of the cells) of the file and the audited one.
    #[serde(default)]
    pub bodies: Option<crate::bodies::Choice>,
}

/// F and its terms.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Functional {
    pub total: f64,
    pub constitutive: f64,
    pub equilibrium: f64,
    pub complementarity: f64,
    pub friction: f64,
}

/// Where the stress came from.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Field {
    /// "file" or "reconstructed".
    pub source: String,
    pub name: String,
    pub space: String,
    pub reason: String,
}

/// Where the displacement came from, and its degree.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Displacement {
    /// "file" or "reconstructed".
    pub source: String,
    pub degree: usize,
    pub name: String,
    pub space: String,
    pub reason: String,
    /// ‖ũ_h − u_h‖_E when the file's field was projected onto K_u: the part of the error
    /// caused by the inadmissibility, added to the bound (triangle inequality).
    #[serde(default)]
    pub projection_distance: Option<f64>,
    /// The file's P2 displacement was given at the vertices only (zero mid-edge values) and
    /// audited as P1 (docs/design.md §4.1).
    #[serde(default)]
    pub vertices_only: bool,
}

/// Admissibility findings: for each kind the largest pointwise value (`_max`, the contract),
/// the L² size, the point of the maximum and the file cell owning it (null when admissible).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Admissibility {
    pub penetration_max: f64,
    pub tension_max: f64,
    pub cone_violation_max: f64,
    pub dirichlet_max: f64,
    pub neumann_max: f64,
    pub penetration_l2: f64,
    pub tension_l2: f64,
    pub cone_violation_l2: f64,
    pub dirichlet_l2: f64,
    pub neumann_l2: f64,
    pub penetration_at: Option<[f64; 2]>,
    pub tension_at: Option<[f64; 2]>,
    pub cone_violation_at: Option<[f64; 2]>,
    pub dirichlet_at: Option<[f64; 2]>,
    pub neumann_at: Option<[f64; 2]>,
    pub penetration_cell: Option<usize>,
    pub tension_cell: Option<usize>,
    pub cone_violation_cell: Option<usize>,
    pub dirichlet_cell: Option<usize>,
    pub neumann_cell: Option<usize>,
    /// ∫ min(integrand, 0) ds of the complementarity term (≤ 0).
    pub complementarity_negative: f64,
    /// ∫ min(integrand, 0) ds of the friction term (≤ 0).
    pub friction_negative: f64,
}

/// One interval of the contact zone.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Interval {
    pub boundary: String,
    /// "separated", "stick" or "slip".
    pub state: String,
    pub start: [f64; 2],
    pub end: [f64; 2],
    pub length: f64,
}

/// The contact zone.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Contact {
    pub active_length: f64,
    pub stick_length: f64,
    pub slip_length: f64,
    /// The force to compare with the solver's reaction: the consistent reaction of the file's
    /// displacement where available, else `normal_force_stress` (docs/design.md §5.8).
    pub normal_force: f64,
    /// ∫_{Γ_C} −σ_n ds of the stress used.
    pub normal_force_stress: f64,
    /// "displacement" or "stress": where `normal_force` comes from.
    pub normal_force_from: String,
    /// ∫_{Γ_C} σ_t ds.
    pub tangential_force: f64,
    pub intervals: Vec<Interval>,
}

/// The bound of docs/design.md §6.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Bound {
    pub guaranteed: bool,
    /// Upper bound of (½(Cε(u − u_h), ε(u − u_h)))^½ (units of η); `null` when no bound.
    pub energy_error: Option<f64>,
    /// energy_error / (½(Cε(u_h), ε(u_h)))^½.
    pub relative: Option<f64>,
    /// What the number bounds, in words.
    pub statement: String,
    pub terms: Option<crate::estimate::BoundTerms>,
    pub failed_hypotheses: Vec<String>,
    /// Per cell (file order): (η_PS,T + |||z|||_T + (osc_T + as_T + tr_T)/√c_min)², summed
    /// over the triangles of a cell split at hanging nodes.
    pub cells: Vec<f64>,
}

/// One of the worst cells.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct WorstCell {
    /// Index in the VTU file.
    pub cell: usize,
    /// η_T = (max(η_T², 0))^½.
    pub eta: f64,
    /// η_T², signed.
    pub eta_squared: f64,
    /// The largest of the four terms on the cell.
    pub dominant: String,
}

/// Cell count and ranking.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Cells {
    /// Number of the file's cells audited (a cell split at hanging nodes counts once).
    pub count: usize,
    /// The ten largest η_T², largest first.
    pub worst: Vec<WorstCell>,
}

/// Dörfler marking summary.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Marked {
    pub theta: f64,
    /// Number of marked cells.
    pub count: usize,
    /// Fraction of Σ max(η_T², 0) they hold.
    pub share: f64,
}

fn file_cell(mesh: &Mesh, t: usize) -> usize {
    mesh.file_cell.get(t).map_or(t, |&c| c as usize)
}

/// The JSON admissibility of one pair of fields.
fn admissibility(a: &crate::estimate::Admissibility, mesh: &Mesh) -> Admissibility {
    let cell = |v: &Violation| v.cell.map(|t| file_cell(mesh, t));
    Admissibility {
        penetration_max: a.penetration.max,
        tension_max: a.tension.max,
        cone_violation_max: a.cone_violation.max,
        dirichlet_max: a.dirichlet.max,
        neumann_max: a.neumann.max,
        penetration_l2: a.penetration.l2,
        tension_l2: a.tension.l2,
        cone_violation_l2: a.cone_violation.l2,
        dirichlet_l2: a.dirichlet.l2,
        neumann_l2: a.neumann.l2,
        penetration_at: a.penetration.at,
        tension_at: a.tension.at,
        cone_violation_at: a.cone_violation.at,
        dirichlet_at: a.dirichlet.at,
        neumann_at: a.neumann.at,
        penetration_cell: cell(&a.penetration),
        tension_cell: cell(&a.tension),
        cone_violation_cell: cell(&a.cone_violation),
        dirichlet_cell: cell(&a.dirichlet),
        neumann_cell: cell(&a.neumann),
        complementarity_negative: a.complementarity_negative,
        friction_negative: a.friction_negative,
    }
}

/// Builds the JSON document of a run.
pub fn report(run: &Run, est: &Estimate, mesh: &Mesh) -> Report {
    let a = &est.admissibility;
    let files = FileCells::of(mesh);
    let c = &files.terms(&est.cells);
    let f = &est.functional;
    Report {
        version: run.version.to_string(),
        solution: run.solution.display().to_string(),
        scene: run.scene.display().to_string(),
        norm: est.norm.as_str().to_string(),
        length_scale: est.length_scale,
        functional: Functional {
            total: f.total,
            constitutive: f.constitutive,
            equilibrium: f.equilibrium,
            complementarity: f.complementarity,
            friction: f.friction,
        },
        eta: est.eta,
        energy: est.energy,
        relative: est.relative,
        stress: Field {
            source: run.stress.source.clone(),
            name: run.stress.name.clone(),
            space: run.stress.space.clone(),
            reason: run.stress.reason.clone(),
        },
        displacement: Displacement {
            source: run.displacement.source.clone(),
            degree: run.displacement_degree,
            name: run.displacement.name.clone(),
            space: run.displacement.space.clone(),
            reason: run.displacement.reason.clone(),
            projection_distance: run.projection_distance,
            vertices_only: run.vertices_only,
        },
        admissibility: admissibility(a, mesh),
        admissibility_file: run
            .file_admissibility
            .as_ref()
            .map(|f| admissibility(&f.admissibility, mesh)),
        contact: Contact {
            active_length: est.contact.active_length,
            stick_length: est.contact.stick_length,
            slip_length: est.contact.slip_length,
            normal_force: est.contact.normal_force,
            normal_force_stress: est.contact.normal_force_stress,
            normal_force_from: match est.contact.normal_force_from {
                crate::estimate::ForceSource::Displacement => "displacement",
                crate::estimate::ForceSource::Stress => "stress",
            }
            .into(),
            tangential_force: est.contact.tangential_force,
            intervals: est
                .contact
                .intervals
                .iter()
                .map(|i| Interval {
                    boundary: i.boundary.clone(),
                    state: state_name(i.state).to_string(),
                    start: i.start,
                    end: i.end,
                    length: i.length,
                })
                .collect(),
        },
        bound: Bound {
            guaranteed: est.bound.guaranteed,
            energy_error: est.bound.energy_error,
            relative: est.bound.relative,
            statement: est.bound.statement.clone(),
            terms: est.bound.terms.clone(),
            failed_hypotheses: est.bound.failed_hypotheses.clone(),
            cells: files.sums(&est.bound.cells),
        },
        cells: Cells {
            count: files.ids.len(),
            worst: worst_cells(c, WORST)
                .into_iter()
                .map(|t| WorstCell {
                    cell: files.id(t),
                    eta: cell_eta(c, t),
                    eta_squared: c.eta_squared(t),
                    dominant: dominant(c, t).0.to_string(),
                })
                .collect(),
        },
        boundaries: run.boundaries.clone(),
        marked: run.marked.as_ref().map(|m| Marked {
            theta: m.theta,
            count: m.cells.iter().filter(|&&b| b).count(),
            share: mark::share(&super::eta_squared(c), &m.cells),
        }),
        stages: run.stages.clone(),
        notes: run.notes.clone(),
        bodies: Some(run.bodies.clone()),
    }
}

/// The name of a contact state, as serde writes it.
pub fn state_name(s: crate::estimate::ContactState) -> &'static str {
    use crate::estimate::ContactState::*;
    match s {
        Separated => "separated",
        Contact => "contact",
        Stick => "stick",
        Slip => "slip",
    }
}

/// Pretty-printed JSON, ending in a newline. Non-finite numbers become `null`.
pub fn to_string(report: &Report) -> String {
    // Serialising plain structs of numbers and strings into a String cannot fail.
    let mut s = serde_json::to_string_pretty(report).unwrap_or_default();
    s.push('\n');
    s
}

#[cfg(test)]
mod tests {
    use serde_json::{Value, json};

    use super::*;
    use crate::report::{Marking, fixture};

    #[test]
    fn contract_keys_and_values() {
        let data = fixture::dataset();
        let est = fixture::estimate();
        let mut run = fixture::run();
        run.marked = Some(Marking {
            theta: 0.5,
            cells: mark::dorfler(&super::super::eta_squared(&est.cells), 0.5),
        });
        let text = to_string(&report(&run, &est, &data.mesh));
        let v: Value = serde_json::from_str(&text).unwrap();

        // The §8 minimum contract, key for key.
        assert_eq!(v["norm"], "energy");
        assert_eq!(
            v["functional"],
            json!({"total": 8.75, "constitutive": 5.0, "equilibrium": 3.75,
                   "complementarity": 0.0, "friction": 0.0})
        );
        assert_eq!(v["eta"], json!(8.75f64.sqrt()));
        assert_eq!(v["energy"], json!(875.0));
        assert_eq!(v["relative"], json!(0.1));
        assert_eq!(v["stress"]["source"], "reconstructed");
        assert_eq!(v["stress"]["space"], "RT0 row-wise (global)");
        assert_eq!(v["stress"]["reason"], "the file holds no stress");
        assert_eq!(v["displacement"]["source"], "file");
        assert_eq!(v["displacement"]["degree"], 1);
        let a = &v["admissibility"];
        assert_eq!(a["penetration_max"], json!(2.5e-3));
        for k in ["tension", "cone_violation", "dirichlet", "neumann"] {
            assert_eq!(a[format!("{k}_max")], json!(0.0), "{k}");
            assert_eq!(a[format!("{k}_at")], Value::Null, "{k}");
        }
        let c = &v["contact"];
        assert_eq!(c["active_length"], json!(0.5));
        assert_eq!(c["stick_length"], json!(0.5));
        assert_eq!(c["slip_length"], json!(0.0));
        assert_eq!(c["normal_force"], json!(12.5));
        assert_eq!(
            v["bound"],
            json!({"guaranteed": false, "energy_error": 9.5, "relative": 0.5,
                   "statement": "energy_error: not guaranteed", "terms": null,
                   "failed_hypotheses": ["u_h penetrates the obstacle"],
                   "cells": [0.5, 1.0, 0.25, 2.0, 0.0]})
        );
        assert_eq!(v["cells"]["count"], 5);
        let worst = v["cells"]["worst"].as_array().unwrap();
        // η_T² = [1, 4, 0.25, 4, −0.5] on triangles 0..5 = file cells 1..6.
        let cells: Vec<u64> = worst.iter().map(|w| w["cell"].as_u64().unwrap()).collect();
        assert_eq!(cells, vec![2, 4, 1, 3, 5]);
        let etas: Vec<f64> = worst.iter().map(|w| w["eta"].as_f64().unwrap()).collect();
        assert_eq!(etas, vec![2.0, 2.0, 1.0, 0.5, 0.0]);

        // Extra keys.
        assert_eq!(v["version"], "0.1.0");
        assert_eq!(v["solution"], "in.vtu");
        assert_eq!(v["scene"], "scene.toml");
        assert_eq!(v["length_scale"], json!(0.25));
        assert_eq!(v["stress"]["name"], "");
        assert_eq!(v["displacement"]["name"], "displacement");
        assert_eq!(a["penetration_l2"], json!(1.25e-3));
        assert_eq!(a["penetration_at"], json!([0.25, 0.0]));
        assert_eq!(a["penetration_cell"], 1);
        assert_eq!(a["complementarity_negative"], json!(-0.75));
        assert_eq!(worst[4]["eta_squared"], json!(-0.5));
        assert_eq!(worst[0]["dominant"], "equilibrium");
        assert_eq!(worst[1]["dominant"], "constitutive");
        assert_eq!(c["intervals"][0]["state"], "stick");
        assert_eq!(c["intervals"][1]["start"], json!([0.5, 0.0]));
        // Σ⁺ = 9.25; θ = 0.5 marks the two cells with η_T² = 4 (8 ≥ 4.625).
        assert_eq!(v["marked"]["theta"], json!(0.5));
        assert_eq!(v["marked"]["count"], 2);
        assert_eq!(v["marked"]["share"], json!(8.0 / 9.25));
        assert_eq!(v["stages"][1], json!({"name": "estimate", "seconds": 0.5}));
        assert_eq!(v["notes"], json!(["1 vertex cell ignored"]));
        assert_eq!(v["boundaries"][0]["kind"], "contact");

        // Typed round trip.
        let back: Report = serde_json::from_str(&text).unwrap();
        assert_eq!(back, report(&run, &est, &data.mesh));
    }

    #[test]
    fn inadmissible_pair_gives_null_eta_and_no_marked_key() {
        let data = fixture::dataset();
        let mut est = fixture::estimate();
        est.functional.total = -0.25;
        est.eta = None;
        est.relative = None;
        est.bound.energy_error = None;
        let v: Value =
            serde_json::from_str(&to_string(&report(&fixture::run(), &est, &data.mesh))).unwrap();
        assert_eq!(v["eta"], Value::Null);
        assert_eq!(v["relative"], Value::Null);
        assert_eq!(v["bound"]["energy_error"], Value::Null);
        assert!(v.get("marked").is_none());
        assert_eq!(v["functional"]["total"], json!(-0.25));
    }
}
