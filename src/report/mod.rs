//! The printers of an [`Estimate`] (docs/design.md §8): terminal text ([`text`]), JSON ([`json`])
//! and the output VTU ([`vtu`]), plus Dörfler bulk marking for adaptivity ([`mark`]).
//!
//! As in ripgrep, every output format is a separate printer of the same inputs: the estimate,
//! the mesh it was computed on, and a [`Run`] saying what was read, reconstructed and timed.
//! The estimator itself keeps MFEM's promise (one number per element plus a total); the
//! printers only rank, attribute and format it.
//!
//! Conventions shared by all printers:
//! - Cell indices shown to the user are indices in the VTU file (`Mesh::file_cell`),
//!   never internal triangle numbers; a cell the closure split at hanging nodes is ranked,
//!   marked and summed as one ([`FileCells`]).
//! - The local indicator is η_T = (max(η_T², 0))^½, where
//!   η_T² = F_const,T + F_div,T + Σ_{E ⊂ ∂T ∩ Γ_C} (F_comp,E + F_fric,E). η_T² itself is
//!   reported signed, because a negative value means an inadmissible pair on that cell.
//! - The "worst" cells are the ten largest η_T², ties broken by the lower index.

pub mod json;
pub mod mark;
pub mod text;
pub mod vtu;

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use crate::estimate::CellTerms;
#[cfg(doc)]
use crate::estimate::Estimate;
use crate::mesh::Mesh;

/// How many cells the reports rank.
pub const WORST: usize = 10;

/// Names of the four terms of F, in the order of docs/design.md §3.
pub const TERMS: [&str; 4] = ["constitutive", "equilibrium", "complementarity", "friction"];

/// Where a field came from and why.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct FieldInfo {
    /// "file" or "reconstructed".
    pub source: String,
    /// Array name in the file (empty when reconstructed from nothing).
    pub name: String,
    /// The discrete space, e.g. "P2 nodal (continuous)" or "RT1 row-wise (global)".
    pub space: String,
    /// Why it was taken as is or reconstructed.
    pub reason: String,
}

/// One `[[boundary]]` of the scene as applied to the mesh.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct BoundaryInfo {
    pub name: String,
    /// "dirichlet", "neumann" or "contact".
    pub kind: String,
    /// Line cells (edges) selected.
    pub edges: usize,
    /// Their total length.
    pub length: f64,
}

/// Wall-clock time of one stage of the run.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Stage {
    pub name: String,
    pub seconds: f64,
}

/// Dörfler marking as asked for with `--mark θ`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Marking {
    pub theta: f64,
    /// One flag per file cell ([`FileCells`] order), from [`mark::dorfler`] on the file cells'
    /// η_T².
    pub cells: Vec<bool>,
}

/// What the run read and did, besides the estimate: the inputs of the printers.
#[derive(Clone, Debug, Default)]
pub struct Run {
    /// Admissibility of the file's own fields when the estimate used others (a projection
    /// or a reconstruction): the file's displacement and stress, or the ones used where the
    /// file has none (`displacement_from_file`, `stress_from_file` say which).
    pub file_admissibility: Option<FileAdmissibility>,
    pub solution: PathBuf,
    pub scene: PathBuf,
    /// Tool version (`env!("CARGO_PKG_VERSION")`).
    pub version: &'static str,
    pub displacement: FieldInfo,
    /// Polynomial degree k of the displacement (1 for P1, 2 for P2).
    pub displacement_degree: usize,
    pub stress: FieldInfo,
    /// What was read, merged or ignored, and warnings, one sentence each.
    pub notes: Vec<String>,
    /// Seconds per stage, in the order they ran.
    pub stages: Vec<Stage>,
    pub boundaries: Vec<BoundaryInfo>,
    pub marked: Option<Marking>,
    /// ‖ũ_h − u_h‖_E when the file's displacement was projected onto K_u (docs/design.md §5).
    pub projection_distance: Option<f64>,
    /// The bodies of the file and the one audited (docs/design.md §4.2).
    pub bodies: crate::bodies::Choice,
    /// The file's P2 displacement had zero mid-edge values: audited as P1 (docs/design.md §4.1).
    pub vertices_only: bool,
}

/// The admissibility of the file's fields (docs/design.md §8.1: the "file" column).
#[derive(Clone, Debug)]
pub struct FileAdmissibility {
    pub admissibility: crate::estimate::Admissibility,
    pub displacement_from_file: bool,
    pub stress_from_file: bool,
}

/// The four term values of cell `t`, in the order of [`TERMS`].
pub fn cell_terms(c: &CellTerms, t: usize) -> [f64; 4] {
    [
        c.constitutive[t],
        c.equilibrium[t],
        c.complementarity[t],
        c.friction[t],
    ]
}

/// Number of cells in `c`.
pub fn cell_count(c: &CellTerms) -> usize {
    c.constitutive.len()
}

/// η_T² of every cell (signed).
pub fn eta_squared(c: &CellTerms) -> Vec<f64> {
    (0..cell_count(c)).map(|t| c.eta_squared(t)).collect()
}

/// η_T = (max(η_T², 0))^½.
pub fn cell_eta(c: &CellTerms, t: usize) -> f64 {
    c.eta_squared(t).max(0.0).sqrt()
}

/// The term with the largest value on cell `t`, and that value (first term on ties).
pub fn dominant(c: &CellTerms, t: usize) -> (&'static str, f64) {
    let v = cell_terms(c, t);
    let mut k = 0;
    for j in 1..4 {
        if v[j] > v[k] {
            k = j;
        }
    }
    (TERMS[k], v[k])
}

/// The file's cells: the mesh's triangles grouped by [`Mesh::file_cell`], in file order
/// (docs/design.md §4.2, "Closure"). One triangle per file cell unless the closure split cells
/// at hanging nodes: then a file cell's η_T², bound contribution and mark are those of its
/// children together (the terms are integrals over the cell, so they add).
#[derive(Clone, Debug)]
pub struct FileCells {
    /// The file index of each group.
    pub ids: Vec<usize>,
    /// The group of each triangle (mesh order).
    pub group: Vec<usize>,
}

impl FileCells {
    pub fn of(mesh: &Mesh) -> FileCells {
        let n = mesh.len();
        let file = |t: usize| mesh.file_cell.get(t).map_or(t, |&c| c as usize);
        let mut ids: Vec<usize> = (0..n).map(file).collect();
        ids.sort_unstable();
        ids.dedup();
        let group = (0..n)
            .map(|t| ids.binary_search(&file(t)).unwrap_or(0))
            .collect();
        FileCells { ids, group }
    }

    /// Whether some file cell has more than one triangle.
    pub fn split(&self) -> bool {
        self.ids.len() < self.group.len()
    }

    /// Per-triangle values summed per file cell; values of another length (an estimate
    /// without per-cell terms) are returned as they are.
    pub fn sums(&self, v: &[f64]) -> Vec<f64> {
        if !self.split() || v.len() != self.group.len() {
            return v.to_vec();
        }
        let mut out = vec![0.0; self.ids.len()];
        for (&g, &x) in self.group.iter().zip(v) {
            out[g] += x;
        }
        out
    }

    /// The four terms per file cell.
    pub fn terms(&self, c: &CellTerms) -> CellTerms {
        CellTerms {
            constitutive: self.sums(&c.constitutive),
            equilibrium: self.sums(&c.equilibrium),
            complementarity: self.sums(&c.complementarity),
            friction: self.sums(&c.friction),
        }
    }

    /// The file index of row `g` of [`Self::terms`].
    pub fn id(&self, g: usize) -> usize {
        self.ids.get(g).copied().unwrap_or(g)
    }

    /// Flags per file cell as flags per triangle (each child takes its file cell's).
    pub fn expand(&self, flags: &[bool]) -> Vec<bool> {
        if flags.len() != self.ids.len() {
            return flags.to_vec();
        }
        self.group.iter().map(|&g| flags[g]).collect()
    }
}

/// The up to `k` cells with the largest η_T², largest first, ties broken by the lower index.
/// O(n) selection, then a sort of the `k` selected.
pub fn worst_cells(c: &CellTerms, k: usize) -> Vec<usize> {
    let e = eta_squared(c);
    let cmp = |a: &usize, b: &usize| e[*b].total_cmp(&e[*a]).then(a.cmp(b));
    let mut ix: Vec<usize> = (0..e.len()).collect();
    if k == 0 {
        return Vec::new();
    }
    if ix.len() > k {
        ix.select_nth_unstable_by(k - 1, cmp);
        ix.truncate(k);
    }
    ix.sort_unstable_by(cmp);
    ix
}

/// A number with `sig` significant digits, fixed or scientific like C's `%g` (trailing zeros
/// trimmed): 0.5, 1234.5, 1.235e-05. Non-finite values print as `NaN`, `inf`, `-inf`.
pub fn num(x: f64, sig: usize) -> String {
    if !x.is_finite() {
        return format!("{x}");
    }
    if x == 0.0 {
        return "0".into();
    }
    let sig = sig.max(1);
    // The exponent after rounding to `sig` digits.
    let s = format!("{:.*e}", sig - 1, x);
    let (mantissa, exp) = s.split_once('e').unwrap_or((&s, "0"));
    let exp: i32 = exp.parse().unwrap_or(0);
    if exp < -4 || exp >= sig as i32 {
        let m = trim_zeros(mantissa);
        format!("{m}e{}{:02}", if exp < 0 { '-' } else { '+' }, exp.abs())
    } else {
        let decimals = (sig as i32 - 1 - exp).max(0) as usize;
        trim_zeros(&format!("{x:.decimals$}")).to_string()
    }
}

fn trim_zeros(s: &str) -> &str {
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.')
    } else {
        s
    }
}

#[cfg(test)]
pub(crate) mod fixture {
    //! A small hand-made estimate on a four-triangle mesh, shared by the printer tests.

    use std::path::Path;

    use super::*;
    use crate::estimate::{
        Admissibility, Bound, Contact, ContactInterval, ContactState, Estimate, Terms, Violation,
    };
    use crate::mesh::{Dataset, build};
    use crate::read::decode::Scalar;
    use crate::read::scene::Norm;
    use crate::read::vtu::{DataArray, VtuFile};

    /// The unit square split into four P1 triangles around its centre, with a vertex cell
    /// (dropped by the mesh) first, so that file cell indices differ from triangle indices,
    /// and two boundary lines at the bottom (y = 0) and one at the top.
    pub fn dataset() -> Dataset {
        let points = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.5, 0.5, 0.0],
            [0.5, 0.0, 0.0],
        ];
        let cells = [
            (1u8, vec![4]),
            (5, vec![0, 5, 4]),
            (5, vec![5, 1, 4]),
            (5, vec![1, 2, 4]),
            (5, vec![2, 3, 4]),
            (5, vec![3, 0, 4]),
            (3, vec![0, 5]),
            (3, vec![5, 1]),
            (3, vec![2, 3]),
        ];
        let mut f = VtuFile::from_cells(Path::new("in.vtu"), points, &cells);
        f.point_data.push(DataArray {
            name: "displacement".into(),
            scalar: Scalar::Float64,
            components: 2,
            component_names: vec![],
            values: (0..12).map(|i| i as f64 * 0.25).collect(),
        });
        f.cell_data.push(DataArray {
            name: "boundary_tag".into(),
            scalar: Scalar::Int32,
            components: 1,
            component_names: vec![],
            values: vec![0., 0., 0., 0., 0., 0., 1., 1., 2.],
        });
        build(f).unwrap()
    }

    /// Cell terms chosen so that the ranking is known: η_T² = [1, 4, 0.25, 4, −0.5].
    pub fn estimate() -> Estimate {
        let cells = CellTerms {
            constitutive: vec![0.5, 1.0, 0.25, 3.0, 0.25],
            equilibrium: vec![0.25, 2.5, 0.0, 1.0, 0.0],
            complementarity: vec![0.25, 0.5, 0.0, 0.0, -0.75],
            friction: vec![0.0, 0.0, 0.0, 0.0, 0.0],
        };
        let total = eta_squared(&cells).iter().sum::<f64>();
        assert_eq!(total, 8.75);
        Estimate {
            norm: Norm::Energy,
            functional: Terms {
                total,
                constitutive: 5.0,
                equilibrium: 3.75,
                complementarity: 0.0,
                friction: 0.0,
            },
            eta: Some(total.sqrt()),
            energy: 875.0,
            relative: Some(0.1),
            length_scale: 0.25,
            admissibility: Admissibility {
                penetration: Violation {
                    max: 2.5e-3,
                    l2: 1.25e-3,
                    at: Some([0.25, 0.0]),
                    cell: Some(0),
                },
                complementarity_negative: -0.75,
                ..Default::default()
            },
            contact: Contact {
                active_length: 0.5,
                stick_length: 0.5,
                slip_length: 0.0,
                normal_force: 12.5,
                normal_force_stress: 12.5,
                normal_force_from: crate::estimate::ForceSource::Stress,
                tangential_force: 0.0,
                intervals: vec![
                    ContactInterval {
                        boundary: "bottom".into(),
                        state: ContactState::Stick,
                        start: [0.0, 0.0],
                        end: [0.5, 0.0],
                        length: 0.5,
                    },
                    ContactInterval {
                        boundary: "bottom".into(),
                        state: ContactState::Separated,
                        start: [0.5, 0.0],
                        end: [1.0, 0.0],
                        length: 0.5,
                    },
                ],
                line_state: vec![
                    Some(ContactState::Stick),
                    Some(ContactState::Separated),
                    None,
                ],
            },
            bound: Bound {
                guaranteed: false,
                energy_error: Some(9.5),
                relative: Some(0.5),
                statement: "energy_error: not guaranteed".into(),
                terms: None,
                failed_hypotheses: vec!["u_h penetrates the obstacle".into()],
                cells: vec![0.5, 1.0, 0.25, 2.0, 0.0],
                energy: 361.0,
            },
            cells,
        }
    }

    pub fn run() -> Run {
        Run {
            file_admissibility: None,
            solution: "in.vtu".into(),
            scene: "scene.toml".into(),
            version: "0.1.0",
            displacement: FieldInfo {
                source: "file".into(),
                name: "displacement".into(),
                space: "P1 nodal (continuous)".into(),
                reason: "point data on the mesh".into(),
            },
            displacement_degree: 1,
            stress: FieldInfo {
                source: "reconstructed".into(),
                name: String::new(),
                space: "RT0 row-wise (global)".into(),
                reason: "the file holds no stress".into(),
            },
            notes: vec!["1 vertex cell ignored".into()],
            stages: vec![
                Stage {
                    name: "read".into(),
                    seconds: 0.125,
                },
                Stage {
                    name: "estimate".into(),
                    seconds: 0.5,
                },
            ],
            boundaries: vec![
                BoundaryInfo {
                    name: "bottom".into(),
                    kind: "contact".into(),
                    edges: 2,
                    length: 1.0,
                },
                BoundaryInfo {
                    name: "top".into(),
                    kind: "dirichlet".into(),
                    edges: 1,
                    length: 1.0,
                },
            ],
            marked: None,
            projection_distance: None,
            bodies: crate::bodies::Choice::default(),
            vertices_only: false,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn num_formats_like_percent_g() {
        assert_eq!(num(0.0, 4), "0");
        assert_eq!(num(0.5, 4), "0.5");
        assert_eq!(num(1234.5678, 4), "1235");
        assert_eq!(num(12345.678, 4), "1.235e+04");
        assert_eq!(num(-1.5e-5, 4), "-1.5e-05");
        assert_eq!(num(9.99996, 4), "10");
        assert_eq!(num(0.00012345, 3), "0.000123");
        assert_eq!(num(f64::NAN, 4), "NaN");
    }

    #[test]
    fn worst_cells_rank_by_eta_squared_then_index() {
        let c = fixture::estimate().cells;
        assert_eq!(worst_cells(&c, 10), vec![1, 3, 0, 2, 4]);
        assert_eq!(worst_cells(&c, 2), vec![1, 3]);
        assert_eq!(worst_cells(&c, 0), Vec::<usize>::new());
        assert_eq!(dominant(&c, 1), ("equilibrium", 2.5));
        assert_eq!(dominant(&c, 4), ("constitutive", 0.25));
        assert_eq!(cell_eta(&c, 4), 0.0);
        assert_eq!(cell_eta(&c, 1), 2.0);
    }
}
