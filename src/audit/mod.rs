//! The audit pipeline of `fosls estimate` (docs/design.md §10), as the algorithm reads:
//!
//! 1. load: the solution (mesh and fields) and the scene, every option validated first;
//! 2. choose the sources: the file's displacement, its projection onto K_u or a rebuilt one;
//!    the file's stress or a reconstruction ([`DisplacementReason`], [`StressReason`]);
//! 3. reconstruct what was chosen (docs/design.md §5);
//! 4. estimate: the functional, admissibility, the contact zone (§3, §5);
//! 5. report data: notes, stages, boundaries, marking ([`crate::report::Run`]).
//!
//! [`run`] returns an [`Audit`]; [`output_files`] builds the `--output` files. `main` only
//! parses the command line, calls these, prints and maps exit codes.

mod finite;
pub mod halves;

use std::path::{Path, PathBuf};
use std::time::Instant;

use crate::element::rt::RtOrder;
use crate::estimate::{self, Estimate, StressField};
use crate::problem::{self, Stress};
use crate::read::scene::{self, Norm, Scene};
use crate::{Error, mesh, read, reconstruct, report, topology};

/// Where a field comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Source {
    /// The file's field when it is conforming and admissible, a reconstruction otherwise.
    Auto,
    /// The file's field as it is.
    File,
    /// Rebuild the field from the other one (the stress: the global minimiser).
    Reconstruct,
    /// The stress rebuilt by patch equilibration (docs/design.md §5.10).
    Patch,
    /// The stress rebuilt as the global minimiser of F (docs/design.md §5.3).
    Global,
}

impl Source {
    /// Whether this asks for a stress reconstruction.
    fn rebuilds(self) -> bool {
        matches!(self, Source::Reconstruct | Source::Patch | Source::Global)
    }
}

/// A warning when the scene's Dirichlet data put nodes it shares with a contact boundary inside
/// the obstacle (beyond the round-off level of the displacement checks): then K_u is empty,
/// no displacement is admissible and no bound can be guaranteed.
fn dirichlet_inside_obstacle(ctx: &problem::Context, u: &[[f64; 2]]) -> Option<String> {
    let tol = estimate::displacement_tolerance(
        crate::field::max_norm(u),
        crate::field::max_norm(&ctx.mesh.points),
    );
    let found = reconstruct::nodal::dirichlet_inside_obstacle(ctx, tol);
    let &(p, excess) = found.iter().max_by(|a, b| a.1.total_cmp(&b.1))?;
    let x = ctx.mesh.points[p];
    Some(format!(
        "warning: the Dirichlet data put {} node{} that {} on a contact boundary inside the \
         obstacle (the deepest at ({}, {}), by {:.3e}): no displacement meets both \
         conditions (K_u is empty), so no bound can be guaranteed; check the scene's boundaries",
        found.len(),
        if found.len() == 1 { "" } else { "s" },
        if found.len() == 1 { "lies" } else { "lie" },
        x[0],
        x[1],
        excess
    ))
}

/// Why the displacement was rebuilt from the stress.
#[derive(Clone, Debug, PartialEq)]
pub enum DisplacementReason {
    /// The file holds none (a pure stress method).
    Absent,
    /// `--displacement reconstruct`.
    Asked,
}

impl std::fmt::Display for DisplacementReason {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            DisplacementReason::Absent => "the file holds no displacement",
            DisplacementReason::Asked => "asked for with --displacement reconstruct",
        })
    }
}

/// Why the stress was reconstructed.
#[derive(Clone, Debug, PartialEq)]
pub enum StressReason {
    /// `--stress reconstruct`, `patch` or `global` (the option's value).
    Asked(&'static str),
    /// The file's nodal stress is not in K_σ (the failed checks).
    Inadmissible { name: String, failures: Vec<String> },
    /// A cell-data stress: piecewise constant, not H(div)-conforming.
    CellData { name: String },
    /// The file holds none.
    Absent,
}

impl std::fmt::Display for StressReason {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            StressReason::Asked(option) => write!(f, "asked for with --stress {option}"),
            StressReason::Inadmissible { name, failures } => write!(
                f,
                "the file's stress \"{name}\" is not in K_σ: {}",
                failures.join("; ")
            ),
            StressReason::CellData { name } => write!(
                f,
                "\"{name}\" is cell data (piecewise constant), not H(div)-conforming"
            ),
            StressReason::Absent => f.write_str("the file holds no stress"),
        }
    }
}

/// The validated options of one audit.
#[derive(Clone, Debug)]
pub struct Options {
    pub file: PathBuf,
    pub scene: Option<PathBuf>,
    pub norm: Option<Norm>,
    pub stress: Source,
    pub displacement: Source,
    /// RT degree k of the reconstruction (0 or 1); default: displacement degree − 1.
    pub degree: Option<usize>,
    /// Improvement sweeps of the patch stress (default `sweep::DEFAULT_SWEEPS`).
    pub sweeps: Option<usize>,
    /// Dörfler parameter θ.
    pub mark: Option<f64>,
    /// The time step of a `.pvd` or XDMF collection (default: the last).
    pub step: Option<read::container::StepChoice>,
}

impl Options {
    /// Checks every option before any work.
    pub fn validate(&self) -> Result<(), Error> {
        match (self.stress, self.degree) {
            (Source::Patch, Some(k)) if !(1..=2).contains(&k) => {
                return Err(Error::Usage(format!(
                    "--degree {k} with --stress patch: RT_1 and RT_2 are available (default: \
                     RT_2)"
                )));
            }
            (Source::Patch, _) => {}
            (_, Some(k)) if k > 1 => {
                return Err(Error::Usage(format!(
                    "--degree {k}: RT_0 and RT_1 are available"
                )));
            }
            _ => {}
        }
        if self.sweeps.is_some() && !matches!(self.stress, Source::Patch | Source::Auto) {
            return Err(Error::Usage(
                "--sweeps improves the patch reconstruction: use it with --stress patch or auto"
                    .into(),
            ));
        }
        if let Some(theta) = self.mark {
            report::mark::check_theta(theta)?;
        }
        if matches!(self.displacement, Source::Patch | Source::Global) {
            return Err(Error::Usage(
                "--displacement patch|global: these name stress reconstructions; use \
                 --displacement auto|file|reconstruct"
                    .into(),
            ));
        }
        if self.displacement == Source::Reconstruct && self.stress.rebuilds() {
            return Err(Error::Usage(
                "--stress reconstruct: the displacement is reconstructed from the file's \
                 stress, so the stress cannot be reconstructed too"
                    .into(),
            ));
        }
        Ok(())
    }
}

/// Progress of the stages (a spinner in the command line, nothing in tests and benches).
pub trait Progress {
    fn stage(&self, what: &str);
    fn done(&self);
}

/// No progress display.
pub struct Silent;

impl Progress for Silent {
    fn stage(&self, what: &str) {
        crate::limits::set_stage(what);
    }
    fn done(&self) {}
}

/// Everything one audit produced.
pub struct Audit {
    pub data: mesh::Dataset,
    pub estimate: Estimate,
    pub run: report::Run,
    /// Checks that failed on the fields used (`--strict`).
    pub failed: Vec<String>,
    pub stress_reconstruction: Option<reconstruct::stress::Reconstruction>,
    pub displacement_reconstruction: Option<reconstruct::displacement::Reconstruction>,
    pub projection: Option<reconstruct::projection::Projection>,
    /// The displacement the estimate used.
    pub u: Vec<[f64; 2]>,
    /// The file's nodal stress, when it was used.
    nodal_stress: Option<Vec<[f64; 4]>>,
}

impl Audit {
    /// The stress the estimate used.
    pub fn sigma(&self) -> StressField<'_> {
        match (&self.stress_reconstruction, &self.nodal_stress) {
            (Some(r), _) => StressField::Rt(&r.stress),
            (None, Some(v)) => StressField::Nodal(v),
            (None, None) => unreachable!("a stress that is not nodal is reconstructed"),
        }
    }
}

/// The scene for `file`: `--scene`, else `<stem>.toml` beside it, else `scene.toml` there.
pub fn find_scene(file: &Path, given: Option<&Path>) -> Result<PathBuf, Error> {
    if let Some(s) = given {
        return Ok(s.to_path_buf());
    }
    let dir = file.parent().unwrap_or(Path::new("."));
    let stem = file.with_extension("toml");
    let shared = dir.join("scene.toml");
    for c in [&stem, &shared] {
        if c.is_file() {
            return Ok(c.clone());
        }
    }
    Err(Error::input(
        file,
        "scene",
        format!(
            "no scene file: neither {} nor {} exists; pass --scene FILE (a TOML file with \
             [material] youngs_modulus, poisson_ratio and one [[boundary]] per boundary part, \
             see README \"Scene file\"; `fosls inspect` lists the boundary tags)",
            stem.display(),
            shared.display()
        ),
    ))
}

/// projected displacement as point data.
fn add_reconstructed(
    file: &mut crate::read::vtu::VtuFile,
    data: &mesh::Dataset,
    stress: Option<&reconstruct::stress::Reconstruction>,
    displacement: Option<(&str, &[[f64; 2]])>,
) {
    use crate::read::{decode::Scalar, vtu::DataArray};
    let ncells = file.cell_count();
    if let Some(r) = stress {
        let mut values = vec![0.0; 9 * ncells];
        for t in 0..data.mesh.cells.len() {
            let fam = data.mesh.family[t];
            let x = data.mesh.coords(t);
            // The mean of the sub-triangles' centroid values: the cell average for the affine
            // part of the field on affine cells.
            let subs = r.stress.subs(&data.mesh, t);
            let mut s = [0.0; 4];
            for k in 0..subs {
                let c = [1.0 / 3.0, 1.0 / 3.0];
                let js = crate::geometry::values::sub_point(
                    fam,
                    &x[..fam.nodes()],
                    data.mesh.shape[t],
                    k,
                    c,
                )
                .jac;
                let (v, _) = r.stress.at(r.stress.first[t] as usize + k, &js, c);
                for m in 0..4 {
                    s[m] += v[m] / subs as f64;
                }
            }
            values[9 * t..9 * t + 9].copy_from_slice(&report::vtu::tensor9(s));
        }
        file.cell_data
            .push(report::vtu::tensor_array("stress_reconstructed", values));
    }
    if let Some((name, u)) = displacement {
        file.point_data.push(DataArray {
            name: name.into(),
            scalar: Scalar::Float64,
            components: 2,
            component_names: vec!["x".into(), "y".into()],
            values: u.iter().flatten().copied().collect(),
        });
    }
}

/// The likely cause when the patch stress of a curved contact boundary against a plane is not
/// admissible under `normal = "body"` (the default), as a clause to append to the note: a
/// solver that constrained u along the plane's normal solved another problem, whose nodal
/// forces lie outside the cones of the tilted body normals (docs/design.md §2.4, §6.4).
fn body_normal_hint(ctx: &problem::Context) -> Option<String> {
    use crate::problem::Condition;
    use crate::read::scene::{BoundaryKind, ContactNormal, Gap};
    let mut names: Vec<&str> = Vec::new();
    for (b, boundary) in ctx.scene.boundaries.iter().enumerate() {
        let BoundaryKind::Contact(spec) = &boundary.kind else {
            continue;
        };
        if spec.normal != ContactNormal::Body || !matches!(spec.gap, Gap::Plane { .. }) {
            continue;
        }
        // Curved: the outward normals of its edges (at their midpoints) are not all one.
        let mut first: Option<[f64; 2]> = None;
        let curved = ctx
            .edges
            .iter()
            .filter(|be| be.condition == Condition::Contact(b))
            .any(|be| {
                let t = be.cell as usize;
                let fam = ctx.mesh.family[t];
                let x = ctx.mesh.coords(t);
                let (_, n, _, _) = crate::geometry::values::sub_edge_point(
                    fam,
                    &x[..fam.nodes()],
                    ctx.mesh.shape[t],
                    0,
                    be.local as usize,
                    0.5,
                );
                let n0 = *first.get_or_insert(n);
                (n0[0] * n[1] - n0[1] * n[0]).abs() > crate::tolerance::CURVED_RELATIVE
            });
        if curved {
            names.push(&boundary.name);
        }
    }
    (!names.is_empty()).then(|| {
        format!(
            "; the contact boundary {} is curved and the scene measures u_n and g along the \
             body's normal (normal = \"body\", the default): if the solver constrained u along \
             the plane's normal, normal = \"obstacle\" states its problem (docs/design.md §2.4)",
            names
                .iter()
                .map(|n| format!("\"{n}\""))
                .collect::<Vec<_>>()
                .join(", ")
        )
    })
}

/// Why a patch stress with unmet patches cannot stand in for the file's under `auto`: the
/// tension and cone checks it fails on Γ_C, or `None` when every patch was met or the sum
/// stays admissible (docs/design.md §5.2). Unmet patches make the sum inadmissible only
/// sometimes: a relative defect of 1.4e-9 with 𝔉 = 1e6 is harmless, CalculiX's float32 CPE6
/// Hertz file with `normal = "body"` had 4.8e-8 and σ_t ≈ 2e5 (η = 2.1e5 against 0.057 with
/// the global minimiser). The traction data are not checked: Π_k t − t is missed anyway when
/// t is not a polynomial (a data term of the bound, not a defect).
fn unusable_patch_stress(
    ctx: &crate::problem::Context,
    u: &[[f64; 2]],
    r: &reconstruct::patch::Reconstruction,
) -> Option<String> {
    if r.info.incompatible == 0 {
        return None;
    }
    let frictional = ctx
        .scene
        .boundaries
        .iter()
        .any(|b| b.contact().is_some_and(|c| c.friction > 0.0));
    let field = StressField::Rt(&r.stress);
    let check = estimate::boundary::boundary(ctx, u, field);
    let failures: Vec<String> = estimate::failed_checks(&check.admissibility, frictional)
        .into_iter()
        .filter(|f| f.starts_with("σ_h") && !f.contains("traction data"))
        .collect();
    (!failures.is_empty()).then(|| failures.join("; "))
}

/// The node-copy jump of point array `name`, when the file wrote it per cell (an exploded
/// file) and the copies disagree: None otherwise.
fn copy_jump<'a>(data: &'a mesh::Dataset, name: &str) -> Option<&'a mesh::Jump> {
    data.report
        .merge
        .as_ref()?
        .jumps
        .iter()
        .find(|j| j.array == name && j.max > 0.0)
}

/// The displacement array's node-copy jump and its cells' own copies, when the file wrote it
/// per cell and the copies disagree (mesh.rs keeps them then): None otherwise.
fn discontinuous_displacement<'a>(
    data: &'a mesh::Dataset,
    name: Option<&str>,
) -> Option<(&'a mesh::Jump, &'a crate::read::vtu::DataArray)> {
    let name = name?;
    let copies = data.copies.iter().find(|a| a.name == name)?;
    Some((copy_jump(data, name)?, copies))
}

/// The warning for the report when `info.condition_estimate` exceeds [`crate::solve::condition::WARN_ABOVE`].
fn condition_warning(info: &crate::solve::SolveInfo, what: &str) -> Option<String> {
    let kappa = info.condition_estimate;
    (kappa > crate::solve::condition::WARN_ABOVE).then(|| {
        format!(
            "warning: {what}: condition estimate {kappa:.1e} > 1e8; the reconstructed field (and \
             F) may have lost more than half of their 16 digits (about {:.0} lost)",
            kappa.log10().min(16.0)
        )
    })
}

/// The body to audit and the dataset and topology cut down to it (docs/design.md §4.2): a
/// one-body file without `[body]` is returned as it is.
fn choose_body(
    data: mesh::Dataset,
    topo: topology::Topology,
    scene: &Scene,
    found: crate::bodies::Bodies,
) -> Result<(mesh::Dataset, topology::Topology, crate::bodies::Choice), Error> {
    let full = if found.list.len() > 1 && scene.body.is_none() {
        Some(problem::classify(&data, &topo, scene)?)
    } else {
        None
    };
    let (b, by) = crate::bodies::choose(&data, &found, scene, full.as_ref())?;
    let choice = crate::bodies::Choice {
        list: found.list.clone(),
        audited: b,
        selected_by: by.to_string(),
    };
    if found.list.len() == 1 {
        return Ok((data, topo, choice));
    }
    let data = crate::bodies::restrict(&data, &found, b);
    let topo = topology::build(&data)?;
    Ok((data, topo, choice))
}

/// A solver failure with the hint that fits the material: a free constant pressure is named
/// only near the incompressible limit (ν ≥ [`crate::tolerance::NEAR_INCOMPRESSIBLE_NU`]).
fn with_hint(problem: String, scene: &Scene) -> String {
    let nu = scene.material.poisson_ratio;
    if !problem.contains("not positive definite") {
        problem
    } else if nu >= 0.5 {
        format!(
            "{problem} (at ν = 0.5 a constant pressure is free unless a traction boundary fixes it)"
        )
    } else if nu >= crate::tolerance::NEAR_INCOMPRESSIBLE_NU {
        format!(
            "{problem} (at ν = {nu}, near the incompressible limit, a constant pressure is \
             nearly free unless a traction boundary fixes it)"
        )
    } else {
        format!(
            "{problem} (ν = {nu}: check that the Dirichlet and contact boundaries hold the body)"
        )
    }
}

/// Runs the audit (steps 1–5 of the module doc).
pub fn run(opts: &Options, progress: &dyn Progress) -> Result<Audit, Error> {
    opts.validate()?;
    let mut stages: Vec<(String, f64)> = Vec::new();
    let mut clock = Instant::now();
    let mut lap = |name: &str, stages: &mut Vec<(String, f64)>| {
        stages.push((name.to_string(), clock.elapsed().as_secs_f64()));
        clock = Instant::now();
    };

    progress.stage("reading the solution");
    let mut vtu = read::container::read_solution(
        &opts.file,
        &read::container::ReadOptions { step: opts.step },
    )?;
    read::vtu::check_coordinates(&vtu)?;
    // The scene is read before the mesh is built, since fields written one array per component
    // are joined first (read::components); its errors still come after the file's.
    crate::limits::set_stage("reading the scene");
    let scene =
        find_scene(&opts.file, opts.scene.as_deref()).and_then(|path| scene::load_scene(&path));
    crate::limits::set_stage("reading the solution");
    let joined = match &scene {
        Ok(scene) => read::components::join(&mut vtu, scene)?,
        Err(_) => read::components::Joined::default(),
    };
    // Straight triangles with hanging edges are split first (closure.rs).
    let (data, topo) = crate::closure::close(mesh::build(vtu)?)?;
    progress.done();
    lap("read", &mut stages);

    crate::limits::set_stage("reading the scene");
    let scene: Scene = scene?;
    let scene_path = scene.file.clone();
    // Tags as `inspect` reads them: NaN or fractional tag values are refused, not ignored.
    read::vtu::check_tags(&opts.file, &data.line_data, scene.tag_array_name(), |l| {
        data.mesh.line_cell[l] as usize
    })?;
    let norm = match opts.norm {
        None => scene.effective_norm(),
        Some(Norm::Energy) if scene.material.is_incompressible() => {
            return Err(Error::Usage(
                "--norm energy: ν = 0.5 needs --norm robust or seed (docs/design.md §3)".into(),
            ));
        }
        Some(n) => n,
    };
    // Several bodies: choose one and cut the mesh down to it, so that every later stage sees
    // one body (docs/design.md §4.2 "Bodies").
    let found = crate::bodies::find(&data.mesh);
    let (data, topo, body) = choose_body(data, topo, &scene, found)?;
    let mut fields = problem::select_fields(&data, &scene)?;
    fields.notes.splice(0..0, joined.notes);
    // A P2 displacement written at the vertices only (zero mid-edge values) is audited as the
    // P1 interpolant of its vertex values (docs/design.md §4.1).
    let mid_edge = match fields.displacement.as_mut() {
        Some(u) => problem::fields::mid_edge_values(&data.mesh, &topo, u),
        None => problem::fields::MidEdge::Field,
    };
    match mid_edge {
        problem::fields::MidEdge::VerticesOnly => fields.notes.push(
            "warning: displacement given at the vertices only (every mid-edge value is zero): \
             audited as P1 (mid-edge values interpolated linearly)"
                .into(),
        ),
        problem::fields::MidEdge::LinearOnEdges => fields.notes.push(
            "displacement linear along every edge (each mid-edge value is the mean of its \
             ends): a P1 field in P2 form, evaluated as given"
                .into(),
        ),
        problem::fields::MidEdge::Field => {}
    }
    // A cell stress that is not the cell mean of Cε(u_h): the two fields do not belong
    // together. On a P1 mesh the likely cause is a higher-order solution written at its
    // vertices only (docs/design.md §4.1).
    if let (problem::Stress::Cell { values, name, .. }, Some(u)) =
        (&fields.stress, fields.displacement.as_deref())
    {
        let elastic = crate::material::Elastic::new(&scene.material);
        if let Some(r) = problem::fields::cell_stress_mismatch(&data.mesh, u, values, &elastic)
            && r > crate::tolerance::CELL_STRESS_MISMATCH
        {
            let why = if data.mesh.degree == 1 {
                "the displacement is not the field the stress came from; a higher-order \
                 solution written at its vertices only (as sfepy's default output does) is \
                 audited as P1"
            } else {
                "the stress and the displacement do not belong together (or the scene's \
                 material is not the solver's)"
            };
            fields.notes.push(format!(
                "warning: cell stress \"{name}\" differs from the cell means of Cε(u_h) by \
                 {:.1} % (area-weighted RMS): {why}",
                100.0 * r
            ));
        }
    }
    let boundaries = problem::classify(&data, &topo, &scene)?;
    crate::bodies::check_supported(&data, &body.list[body.audited], &scene, &boundaries)?;
    lap("scene and fields", &mut stages);

    finite::check_inputs(&data, &fields, &scene, &boundaries.edges)?;
    let ctx = problem::Context::new(&data.mesh, &topo, &scene, &boundaries.edges, norm);
    // The displacement: the file's, projected onto K_u in the energy norm when it penetrates
    // or misses the Dirichlet data at the nodes (docs/design.md §5) unless --displacement file; or
    // rebuilt from the file's nodal stress when the file holds none or it is asked for.
    let file_u: Option<&[[f64; 2]]> = fields.displacement.as_deref();
    let rebuild_reason = match (file_u, opts.displacement) {
        (None, Source::File) => {
            return Err(Error::input(
                &opts.file,
                "displacement",
                "--displacement file: the file holds no displacement",
            ));
        }
        (None, _) => Some(DisplacementReason::Absent),
        (Some(_), Source::Reconstruct) => Some(DisplacementReason::Asked),
        (Some(_), _) => None,
    };
    let rebuilt = match &rebuild_reason {
        None => None,
        Some(_) => {
            if opts.stress.rebuilds() {
                return Err(Error::Usage(
                    "--stress reconstruct: the displacement is reconstructed from the file's \
                     stress, so the stress cannot be reconstructed too"
                        .into(),
                ));
            }
            let Stress::Nodal { values, .. } = &fields.stress else {
                return Err(Error::input(
                    &opts.file,
                    "stress",
                    "--displacement reconstruct: the displacement is rebuilt from the stress, \
                     which must be a nodal (point-data) stress; this file has none",
                ));
            };
            progress.stage("reconstructing the displacement");
            let r = reconstruct::displacement::reconstruct(&ctx, StressField::Nodal(values))
                .map_err(|problem| {
                    Error::input(
                        &opts.file,
                        "displacement reconstruction",
                        with_hint(problem, &scene),
                    )
                })?;
            progress.done();
            lap("reconstruct displacement", &mut stages);
            Some(r)
        }
    };
    let violations = file_u.map_or(0, |fu| reconstruct::projection::nodal_violations(&ctx, fu));
    let projection = match file_u {
        Some(fu) if rebuilt.is_none() && violations > 0 && opts.displacement == Source::Auto => {
            progress.stage("projecting the displacement onto K_u");
            let p = reconstruct::projection::project(&ctx, fu).map_err(|problem| {
                Error::input(
                    &opts.file,
                    "displacement projection",
                    with_hint(problem, &scene),
                )
            })?;
            progress.done();
            lap("project displacement", &mut stages);
            Some(p)
        }
        _ => None,
    };
    let u: &[[f64; 2]] = match (&rebuilt, &projection, file_u) {
        (Some(r), _, _) => &r.displacement,
        (None, Some(p), _) => &p.displacement,
        (None, None, Some(fu)) => fu,
        (None, None, None) => unreachable!("an absent displacement is reconstructed"),
    };

    let degree = opts.degree.unwrap_or(data.mesh.degree - 1);
    let order = if degree == 0 {
        RtOrder::Rt0
    } else {
        RtOrder::Rt1
    };
    let frictional = scene
        .boundaries
        .iter()
        .any(|b| b.contact().is_some_and(|c| c.friction > 0.0));
    let reconstruct_reason = match (&fields.stress, opts.stress) {
        (_, Source::Reconstruct) => Some(StressReason::Asked("reconstruct")),
        (_, Source::Patch) => Some(StressReason::Asked("patch")),
        (_, Source::Global) => Some(StressReason::Asked("global")),
        // A conforming but inadmissible stress (tension, traction outside the cone, wrong
        // traction data) is rebuilt in K_σ under `auto` (docs/design.md §5).
        (Stress::Nodal { values, name, .. }, Source::Auto) => {
            let field = StressField::Nodal(values);
            let check = estimate::boundary::boundary(&ctx, u, field);
            let failures: Vec<String> = estimate::failed_checks(&check.admissibility, frictional)
                .into_iter()
                .filter(|f| f.starts_with("σ_h"))
                .collect();
            (!failures.is_empty()).then(|| StressReason::Inadmissible {
                name: name.clone(),
                failures,
            })
        }
        (Stress::Nodal { .. }, Source::File) => None,
        (Stress::Cell { name, .. }, Source::Auto) => {
            Some(StressReason::CellData { name: name.clone() })
        }
        (Stress::Cell { name, .. }, Source::File) => {
            return Err(Error::input(
                &opts.file,
                format!("cell array \"{name}\""),
                "--stress file: a cell-data stress is not H(div)-conforming and cannot be \
                 evaluated as is (use --stress auto or reconstruct)",
            ));
        }
        (Stress::Absent, Source::File) => {
            return Err(Error::input(
                &opts.file,
                "stress",
                "--stress file: the file holds no stress field",
            ));
        }
        (Stress::Absent, Source::Auto) => Some(StressReason::Absent),
    };
    // Patch equilibration (triangles, λ < ∞, k ≥ 1) when asked for: the stress the bound
    // needs; the global minimiser otherwise. On quadrilaterals the patch stress lives on the
    // triangle halves and serves the bound only (`estimate::halves`, design §6.3).
    let quads = data.mesh.has_quads();
    let use_patch = match opts.stress {
        Source::Patch => !quads,
        Source::Auto => !quads && ctx.elastic.lambda.is_finite(),
        _ => false,
    };
    let patch_order = opts.degree.map_or_else(
        || reconstruct::patch::default_order(data.mesh.degree),
        reconstruct::patch::order_for_degree,
    );
    let mut patch_info = None;
    let (patch, patch_fallback) = match &reconstruct_reason {
        Some(_) if use_patch => {
            progress.stage("reconstructing the stress on vertex patches");
            let r = reconstruct::patch::reconstruct(&ctx, u, patch_order);
            progress.done();
            lap("reconstruct stress (patches)", &mut stages);
            match r {
                Ok(r) if opts.stress == Source::Auto => match unusable_patch_stress(&ctx, u, &r) {
                    Some(why) => {
                        let note = format!(
                            "the patch reconstruction could not meet the constraints on {} \
                             patches (largest relative defect {:.1e}) and its stress is not \
                             admissible ({why}): the global minimiser was used instead, which \
                             gives no bound{}",
                            r.info.incompatible,
                            r.info.max_defect,
                            body_normal_hint(&ctx).unwrap_or_default()
                        );
                        (None, Some(note))
                    }
                    None => (Some(r), None),
                },
                Ok(r) => (Some(r), None),
                Err(problem) if opts.stress == Source::Auto => (
                    None,
                    Some(format!(
                        "the patch reconstruction failed ({problem}): the global minimiser was \
                         used instead, which gives no bound"
                    )),
                ),
                Err(problem) => {
                    return Err(Error::input(&opts.file, "patch reconstruction", problem));
                }
            }
        }
        Some(_) if quads && opts.stress == Source::Patch => (
            None,
            Some(
                "quadrilateral cells: the patch stress is built on the triangle halves, for the \
                 bound (design §6.3); F uses the global minimiser on the quadrilaterals"
                    .to_string(),
            ),
        ),
        _ => (None, None),
    };
    // Improvement sweeps of the patch stress (design §5.10, "Sweeps"): the same constraints,
    // a smaller Prager–Synge term.
    let mut patch = patch;
    if let Some(r) = patch.as_mut() {
        let sweeps = opts.sweeps.unwrap_or(reconstruct::sweep::DEFAULT_SWEEPS);
        if sweeps > 0 {
            progress.stage("improving the patch stress");
            r.info.sweeps =
                reconstruct::sweep::sweep(&ctx, u, &mut r.stress, r.info.weak_symmetry, sweeps);
            progress.done();
            lap("improve stress (sweeps)", &mut stages);
        }
    }
    let reconstruction = match (&reconstruct_reason, patch) {
        (None, _) => None,
        (Some(_), Some(r)) => {
            patch_info = Some(r.info);
            Some(reconstruct::stress::Reconstruction {
                stress: r.stress,
                info: crate::solve::SolveInfo::default(),
            })
        }
        (Some(_), None) => {
            progress.stage("reconstructing the stress");
            let r = reconstruct::stress::reconstruct(&ctx, u, order).map_err(|problem| {
                Error::input(
                    &opts.file,
                    "stress reconstruction",
                    with_hint(problem, &scene),
                )
            })?;
            progress.done();
            lap("reconstruct stress", &mut stages);
            Some(r)
        }
    };
    let (sigma, stress_info) = match (&fields.stress, &reconstruction) {
        (_, Some(r)) => (
            StressField::Rt(&r.stress),
            report::FieldInfo {
                source: "reconstructed".into(),
                name: String::new(),
                space: match &patch_info {
                    Some(p) => format!(
                        "RT_{} row-wise, equilibrated on vertex patches{}",
                        r.stress.order.k(),
                        if p.weak_symmetry {
                            ", weakly symmetric per cell"
                        } else {
                            ""
                        }
                    ),
                    None => format!("RT_{degree} row-wise (global minimiser of F)"),
                },
                reason: reconstruct_reason
                    .as_ref()
                    .map(|r| r.to_string())
                    .unwrap_or_default(),
            },
        ),
        (
            Stress::Nodal {
                values,
                name,
                layout,
            },
            None,
        ) => (
            StressField::Nodal(values),
            report::FieldInfo {
                source: "file".into(),
                name: name.clone(),
                space: format!(
                    "P{} nodal, continuous (H(div)-conforming), layout {layout}",
                    data.mesh.degree
                ),
                // Copies that disagree were averaged when the mesh was built: F then uses
                // that average, not the file's (discontinuous) stress (design §4.2).
                reason: match copy_jump(&data, name) {
                    Some(j) => format!(
                        "discontinuous across cells: its node copies disagree by up to {:.3e} \
                         ({:.3e} of its largest value), so F uses their average, which is \
                         continuous",
                        j.max, j.relative
                    ),
                    None => "conforming nodal stress, used as is".into(),
                },
            },
        ),
        _ => unreachable!("a stress that is not nodal is reconstructed"),
    };

    // The bound on quadrilaterals: on the triangle halves (design §6.3).
    let halves_bound = (quads
        && matches!(opts.stress, Source::Auto | Source::Patch)
        && ctx.elastic.lambda.is_finite())
    .then(|| {
        progress.stage("bounding the error on the triangle halves");
        let b = halves::on_halves(
            &ctx,
            &data,
            u,
            patch_order,
            opts.sweeps.unwrap_or(reconstruct::sweep::DEFAULT_SWEEPS),
        );
        progress.done();
        lap("bound (triangle halves)", &mut stages);
        b
    });
    progress.stage("evaluating the functional");
    let mut notes_extra: Vec<String> = Vec::new();
    let mut est: Estimate = estimate::run(&ctx, u, sigma);
    if let Some(b) = halves_bound {
        est.bound = b;
    }
    // The file's stress, used as is for F, gives no bound when it is not equilibrated (no
    // solver's stress is exactly): under `auto` the bound then takes the patch equilibration of
    // u_h as its stress (design §5.2, step 4), and F keeps the file's stress.
    if reconstruction.is_none()
        && opts.stress == Source::Auto
        && !quads
        && ctx.elastic.lambda.is_finite()
        && est.bound.energy_error.is_none()
    {
        let sweeps = opts.sweeps.unwrap_or(reconstruct::sweep::DEFAULT_SWEEPS);
        let mut b = halves::patch_bound(&ctx, u, patch_order, sweeps);
        if b.energy_error.is_some() {
            b.statement = format!(
                "{} (the bound's stress is the patch equilibration of u_h: the file's stress, \
                 which F uses, is not equilibrated)",
                b.statement
            );
            est.bound = b;
        }
    }
    if let Some(p) = &projection {
        est.bound.add_projection(p.distance);
    }
    // A displacement written per cell whose node copies disagree: F and the bound are those of
    // its average ū_h (mesh.rs); the broken-norm distance makes the bound one for the file's
    // u_h (design §4.2, "Discontinuous displacements").
    let discontinuous = rebuilt
        .is_none()
        .then(|| discontinuous_displacement(&data, fields.displacement_name.as_deref()))
        .flatten();
    if let Some((jump, copies)) = discontinuous {
        let distance = estimate::copies::copies_distance(&ctx, copies);
        est.bound.add_copies(distance);
        if est.bound.energy_error.is_some() {
            est.bound.statement = format!(
                "{} (u_h is discontinuous across cells: the bound is for the broken energy \
                 norm, that of the copies' average ū_h plus |||ū_h − u_h|||_h = {distance:.6e})",
                est.bound.statement
            );
        }
        notes_extra.push(format!(
            "displacement \"{}\" discontinuous across cells: its node copies disagree by up to \
             {:.3e} ({:.3e} of its largest value); F and the bound use their average ū_h, \
             and a bound adds |||ū_h − u_h|||_h = {distance:.6e} (broken energy norm)",
            jump.array, jump.max, jump.relative
        ));
    }
    // The contact zone is the file's displacement's (the projection lifts the zone by up to
    // ~1e-5 and would reopen it, issue 12; the traction is the stress used's). A patch stress
    // of a displacement far from any Galerkin solution carries the load defects on the nearly
    // closed contact edges beyond the zone (sfepy's vertex-only P2 Hertz file: 2a + 11.6 %), so
    // its zone also needs the gap of u_h closed (docs/design.md §5.8).
    let zone_gap = patch_info
        .as_ref()
        .is_some_and(|p| p.load_defect > crate::tolerance::GALERKIN_DEFECT_RELATIVE)
        .then_some(crate::tolerance::ZONE_GAP_RELATIVE);
    if projection.is_some() || zone_gap.is_some() {
        let zone_u = file_u.filter(|_| projection.is_some()).unwrap_or(u);
        est.contact = estimate::boundary::boundary_with(&ctx, zone_u, sigma, zone_gap).contact;
    }
    // The force to compare with the solver's: the residual reaction of the file's own
    // displacement (docs/design.md §5.8); the stress used's force stays beside it.
    if let Some(force) = file_u.and_then(|fu| estimate::reaction::contact_normal_force(&ctx, fu)) {
        est.contact.normal_force = force;
        est.contact.normal_force_from = estimate::ForceSource::Displacement;
    }
    // The file's own fields, when the estimate used others: the "file" column.
    let file_admissibility = (projection.is_some()
        || rebuilt.is_some()
        || reconstruction.is_some())
    .then(|| {
        let file_sigma = match &fields.stress {
            Stress::Nodal { values, .. } => Some(StressField::Nodal(values)),
            _ => None,
        };
        let adm =
            estimate::boundary::boundary(&ctx, file_u.unwrap_or(u), file_sigma.unwrap_or(sigma))
                .admissibility;
        report::FileAdmissibility {
            admissibility: adm,
            displacement_from_file: file_u.is_some(),
            stress_from_file: file_sigma.is_some(),
        }
    });
    finite::check_estimate(&opts.file, &est)?;
    progress.done();
    lap("evaluate", &mut stages);

    // Marked per file cell: a cell split at hanging nodes is refined as one.
    let marked = opts.mark.map(|theta| report::Marking {
        theta,
        cells: report::mark::dorfler(
            &report::eta_squared(&report::FileCells::of(&data.mesh).terms(&est.cells)),
            theta,
        ),
    });
    let mut notes = fields.notes.clone();
    notes.append(&mut notes_extra);
    if body.list.len() > 1 {
        notes.push(format!(
            "the file holds {} bodies (connected components of the cells); audited {}, chosen \
             by {}; the others are not part of the audit",
            body.list.len(),
            body.list[body.audited].describe(),
            body.selected_by
        ));
    }
    notes.extend(boundaries.notes.iter().cloned());
    notes.extend(problem::free_rigid_motions(&ctx));
    notes.extend(dirichlet_inside_obstacle(&ctx, u));
    if let Some(c) = &data.report.closure {
        notes.push(c.note());
    }
    if let Some(m) = &data.report.merge {
        notes.push(format!(
            "{}: {} node copies merged into {} nodes",
            if m.exploded {
                "exploded mesh"
            } else {
                "pieces"
            },
            m.points_in_file,
            m.points_merged
        ));
    }
    // `--strict` judges the file's own fields where the estimate used others.
    let judged = file_admissibility
        .as_ref()
        .map_or(&est.admissibility, |f| &f.admissibility);
    let failed = estimate::failed_checks(judged, frictional);
    if let Some(p) = &projection {
        notes.push(format!(
            "displacement projected onto K_u: {} inadmissible nodes; {} active contact \
             constraints, {} iterations, KKT residual {:.2e}; ‖ũ_h − u_h‖_E = {:.6e}",
            p.violations, p.info.active, p.info.iterations, p.info.kkt_residual, p.distance
        ));
        notes.extend(condition_warning(&p.info, "displacement projection"));
    }
    if let Some(r) = &rebuilt {
        notes.push(format!(
            "displacement reconstruction: {} unknowns, {} active-set iterations, {} active \
             contact constraints, KKT residual {:.2e}{}",
            r.info.unknowns,
            r.info.iterations,
            r.info.active,
            r.info.kkt_residual,
            if r.stick + r.slip > 0 {
                format!(
                    "; friction (v_t split into a − b ≥ 0): {} QP solves{}, {} stick and {} slip \
                     nodes, {} held at v_t = 0 by the remedy (sign change of v_t inside an edge)",
                    r.friction_iterations,
                    if r.friction_converged {
                        ""
                    } else {
                        " (NOT settled: cap on the remedy rounds)"
                    },
                    r.stick,
                    r.slip,
                    r.remedied
                )
            } else {
                String::new()
            }
        ));
        notes.extend(condition_warning(&r.info, "displacement reconstruction"));
    }
    notes.extend(patch_fallback);
    if let Some(p) = &patch_info {
        notes.push(format!(
            "patch reconstruction: {} vertex patches (up to {} unknowns), {} active contact \
             constraints{}{}{}{}{}",
            p.patches,
            p.max_unknowns,
            p.active,
            if p.sweeps.sweeps > 0 {
                format!(
                    ", {} improvement sweep{} over {} colours ({} patch solve{} left the stress \
                     unchanged; docs/design.md §5.10)",
                    p.sweeps.sweeps,
                    if p.sweeps.sweeps == 1 { "" } else { "s" },
                    p.sweeps.colours,
                    p.sweeps.skipped,
                    if p.sweeps.skipped == 1 { "" } else { "s" }
                )
            } else {
                String::new()
            },
            if p.p1_symmetry_dropped > 0 {
                format!(
                    ", {} solved without the P_1 weak-symmetry rows (infeasible there; \
                     docs/design.md §5.10)",
                    if p.p1_symmetry_dropped == 1 {
                        "1 patch".to_string()
                    } else {
                        format!("{} patches", p.p1_symmetry_dropped)
                    }
                )
            } else {
                String::new()
            },
            if p.balanced {
                format!(
                    ", loads rebalanced between patches (largest force defect of a closed patch \
                     {:.1e} of its loads{}; docs/design.md §5.10)",
                    p.load_defect,
                    if p.load_defect > crate::tolerance::GALERKIN_DEFECT_RELATIVE {
                        ": u_h is far from a Galerkin solution of this discrete problem, the \
                         contact zone also needs its gap closed"
                    } else {
                        ""
                    }
                )
            } else {
                String::new()
            },
            if p.unsettled > 0 {
                format!(", {} patches whose active set did NOT settle", p.unsettled)
            } else {
                String::new()
            },
            if p.incompatible > 0 {
                format!(
                    "; WARNING: on {} patches the constraints could not be met (largest \
                     relative defect {:.1e}): σ_h is not exactly equilibrated there",
                    p.incompatible, p.max_defect
                )
            } else {
                format!(
                    ", equilibrated (largest relative defect {:.1e})",
                    p.max_defect
                )
            }
        ));
    }
    if let (Some(r), None) = (&reconstruction, &patch_info) {
        notes.push(format!(
            "stress reconstruction: {} unknowns{}, {} nonzeros, {} active-set iterations{}, {} \
             active contact constraints, KKT residual {:.2e}",
            r.info.unknowns,
            if r.info.condensed > 0 {
                format!(
                    " (+ {} interior ones condensed cell by cell)",
                    r.info.condensed
                )
            } else {
                String::new()
            },
            r.info.nonzeros,
            r.info.iterations,
            if r.info.converged {
                ""
            } else {
                " (NOT converged: iteration cap)"
            },
            r.info.active,
            r.info.kkt_residual
        ));
        notes.extend(condition_warning(&r.info, "stress reconstruction"));
    }
    let run = report::Run {
        file_admissibility,
        solution: opts.file.clone(),
        scene: scene_path,
        version: env!("CARGO_PKG_VERSION"),
        displacement: report::FieldInfo {
            source: if projection.is_some() || rebuilt.is_some() {
                "reconstructed"
            } else {
                "file"
            }
            .into(),
            name: fields.displacement_name.clone().unwrap_or_default(),
            space: if rebuilt.is_some() {
                format!(
                    "P{} nodal (minimiser of F(·, σ_h) on K_u)",
                    data.mesh.degree
                )
            } else {
                format!("P{} nodal", data.mesh.degree)
            },
            reason: match (&rebuild_reason, &projection) {
                (Some(why), _) => why.to_string(),
                (None, Some(p)) => format!(
                    "projected onto K_u in the energy norm: {} nodes penetrate the obstacle or \
                     miss the Dirichlet data",
                    p.violations
                ),
                (None, None) if violations > 0 => format!(
                    "used as is (--displacement file) although {violations} nodes are \
                     inadmissible"
                ),
                (None, None) if discontinuous.is_some() => "discontinuous across cells: \
                                                            averaged over its node copies \
                                                            (admissible at the nodes)"
                    .into(),
                (None, None) => "conforming and admissible at the nodes, used as is".into(),
            },
        },
        displacement_degree: data.mesh.degree,
        stress: stress_info,
        notes,
        stages: stages
            .iter()
            .map(|(name, seconds)| report::Stage {
                name: name.clone(),
                seconds: *seconds,
            })
            .collect(),
        boundaries: boundaries
            .per_boundary
            .iter()
            .zip(&scene.boundaries)
            .map(|(s, b)| report::BoundaryInfo {
                name: s.name.clone(),
                kind: b.kind.as_str().to_string(),
                edges: s.edges,
                length: s.length,
            })
            .collect(),
        marked,
        projection_distance: projection.as_ref().map(|p| p.distance),
        bodies: body,
        vertices_only: mid_edge == problem::fields::MidEdge::VerticesOnly,
    };

    let nodal_stress = match (&fields.stress, &reconstruction) {
        (Stress::Nodal { values, .. }, None) => Some(values.clone()),
        _ => None,
    };
    let u = u.to_vec();
    Ok(Audit {
        data,
        estimate: est,
        run,
        failed,
        stress_reconstruction: reconstruction,
        displacement_reconstruction: rebuilt,
        projection,
        u,
        nodal_stress,
    })
}

/// The `--output` VTU for `out` and, when a field was rebuilt, its discontinuous copy
/// (docs/design.md §8.3), for the caller to write (the output plan of [`crate::write`]
/// publishes them only when the run succeeds).
pub fn output_files(
    audit: &Audit,
    out: &Path,
) -> (crate::read::vtu::VtuFile, Option<crate::read::vtu::VtuFile>) {
    let (data, est, run) = (&audit.data, &audit.estimate, &audit.run);
    let (reconstruction, rebuilt, projection) = (
        &audit.stress_reconstruction,
        &audit.displacement_reconstruction,
        &audit.projection,
    );
    let (sigma, u) = (audit.sigma(), audit.u.as_slice());
    let cells = run
        .marked
        .as_ref()
        .map(|m| report::FileCells::of(&data.mesh).expand(&m.cells));
    let mut file = report::vtu::output_file(out, data, est, cells.as_deref());
    let displacement = match (&rebuilt, &projection) {
        (Some(r), _) => Some(("displacement_reconstructed", r.displacement.as_slice())),
        (None, Some(p)) => Some(("displacement_projected", p.displacement.as_slice())),
        _ => None,
    };
    add_reconstructed(&mut file, data, reconstruction.as_ref(), displacement);
    let copy = (reconstruction.is_some() || rebuilt.is_some() || projection.is_some()).then(|| {
        let path = report::vtu::discontinuous_path(out);
        report::vtu::discontinuous_file(&path, &data.mesh, sigma, u, est)
    });
    (file, copy)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn incompressibility_hint_only_near_nu_one_half() {
        let text = |nu: f64| {
            format!(
                "[material]\nyoungs_modulus = 1.0\npoisson_ratio = {nu}\n\
                 [estimate]\nnorm = \"robust\"\n"
            )
        };
        let scene = |nu: f64| scene::parse_scene(Path::new("s.toml"), &text(nu)).unwrap();
        let failed = "the reconstruction matrix is not positive definite (x)".to_string();
        assert_eq!(
            with_hint(failed.clone(), &scene(0.28)),
            "the reconstruction matrix is not positive definite (x) (ν = 0.28: check that the \
             Dirichlet and contact boundaries hold the body)"
        );
        assert_eq!(
            with_hint(failed.clone(), &scene(0.5)),
            "the reconstruction matrix is not positive definite (x) (at ν = 0.5 a constant \
             pressure is free unless a traction boundary fixes it)"
        );
        assert_eq!(
            with_hint(failed, &scene(0.4999)),
            "the reconstruction matrix is not positive definite (x) (at ν = 0.4999, near the \
             incompressible limit, a constant pressure is nearly free unless a traction \
             boundary fixes it)"
        );
        assert_eq!(with_hint("other".into(), &scene(0.5)), "other");
    }

    #[test]
    fn warning_only_above_the_threshold() {
        let mut info = crate::solve::SolveInfo {
            condition_estimate: 3e7,
            ..crate::solve::SolveInfo::default()
        };
        assert_eq!(condition_warning(&info, "stress reconstruction"), None);
        info.condition_estimate = 2.5e11;
        assert_eq!(
            condition_warning(&info, "stress reconstruction").unwrap(),
            "warning: stress reconstruction: condition estimate 2.5e11 > 1e8; the reconstructed \
             field (and F) may have lost more than half of their 16 digits (about 11 lost)"
        );
    }
}
